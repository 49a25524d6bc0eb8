//! The timing loop of the Rust benches (`cargo bench [filter]`): one thread,
//! each case calibrated to at least 20 ms per sample, 15 samples; prints the
//! best and the median time per iteration and, for batches, elements per
//! second at the best. Best-of-N, as the Python benches report.

use std::time::{Duration, Instant};

const SAMPLES: usize = 15;
const SAMPLE_TIME: Duration = Duration::from_millis(20);

/// The cases to run: those whose name contains the command line's first
/// argument that is not an option (all when none).
pub struct Bench {
    filter: Option<String>,
}

impl Bench {
    pub fn from_args() -> Self {
        Bench {
            filter: std::env::args().skip(1).find(|a| !a.starts_with('-')),
        }
    }

    /// Times `f`; `elements` is the number of solves one call makes (1 for a
    /// single solve).
    pub fn run<R>(&self, name: &str, elements: u64, mut f: impl FnMut() -> R) {
        if self.filter.as_deref().is_some_and(|s| !name.contains(s)) {
            return;
        }
        let mut iters = 1u64;
        loop {
            let t = Instant::now();
            for _ in 0..iters {
                std::hint::black_box(f());
            }
            if t.elapsed() >= SAMPLE_TIME || iters >= 1 << 30 {
                break;
            }
            iters *= 2;
        }
        let mut per: Vec<f64> = (0..SAMPLES)
            .map(|_| {
                let t = Instant::now();
                for _ in 0..iters {
                    std::hint::black_box(f());
                }
                t.elapsed().as_secs_f64() / iters as f64
            })
            .collect();
        per.sort_by(f64::total_cmp);
        let (best, median) = (per[0], per[SAMPLES / 2]);
        let rate = if elements > 1 {
            format!("   {:.2} M elements/s", elements as f64 / best / 1e6)
        } else {
            String::new()
        };
        println!(
            "{name:<48} best {}   median {}{rate}",
            human(best),
            human(median)
        );
    }
}

fn human(s: f64) -> String {
    if s < 1e-6 {
        format!("{:8.1} ns", s * 1e9)
    } else if s < 1e-3 {
        format!("{:8.2} µs", s * 1e6)
    } else {
        format!("{:8.2} ms", s * 1e3)
    }
}
