//! Rows of a batch and the threads that work them: worker threads over
//! contiguous row ranges (`std::thread::scope`, no rayon), the checks of a
//! batch's shapes, and the result of a batch of solves. Every algorithm of
//! the crate runs its batches through these; they depend on no physics.

use crate::error::{check_finite, check_rows, CdsmError, Result};
use crate::lm::Status;
use std::ops::Range;

/// Number of worker threads: `0` means all available cores.
pub fn resolve_threads(threads: usize) -> usize {
    if threads > 0 {
        threads
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    }
}

/// Runs `work` on contiguous ranges of `0..rows` in up to `threads` scoped
/// threads and returns the per-range results in row order. A range whose
/// thread the system cannot start (too many threads) is worked by the
/// calling thread: the result does not depend on how many start.
pub fn split_rows<T: Send>(
    rows: usize,
    threads: usize,
    work: impl Fn(Range<usize>) -> T + Sync,
) -> Vec<T> {
    let threads = resolve_threads(threads).min(rows.max(1));
    if threads <= 1 {
        return vec![work(0..rows)];
    }
    let per = rows.div_ceil(threads);
    std::thread::scope(|s| {
        let w = &work;
        let started: Vec<_> = (0..threads)
            .map(|t| {
                let r = (t * per).min(rows)..((t + 1) * per).min(rows);
                std::thread::Builder::new()
                    .spawn_scoped(s, {
                        let r = r.clone();
                        move || w(r)
                    })
                    .map_err(|_| r)
            })
            .collect();
        started
            .into_iter()
            .map(|h| match h {
                Ok(h) => h.join().expect("worker thread panicked"),
                Err(r) => w(r),
            })
            .collect()
    })
}

/// Per-row `f64` map: `f(row_index, out_row)` fills `width` outputs per row.
pub fn map_rows(
    rows: usize,
    width: usize,
    threads: usize,
    f: impl Fn(usize, &mut [f64]) + Sync,
) -> Vec<f64> {
    split_rows(rows, threads, |r| {
        let mut out = vec![0.0; r.len() * width];
        for (j, i) in r.enumerate() {
            f(i, &mut out[j * width..(j + 1) * width]);
        }
        out
    })
    .concat()
}

/// Results of a batch of solves, one entry per row. Every batch solve of the
/// crate (cable solves, pose IK, deviations, elastic solves) assembles its
/// rows with [`BatchSolution::push`] and joins its threads' parts with
/// [`BatchSolution::extend`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BatchSolution {
    /// `(N, n)` row-major joint angles (rad).
    pub theta: Vec<f64>,
    pub converged: Vec<bool>,
    pub iterations: Vec<u32>,
    /// max |residual| per row (m, or rad for phi).
    pub residual: Vec<f64>,
    /// All angles within the joint limits.
    pub within_limits: Vec<bool>,
    /// Why each solve ended ([`crate::lm::Reason`] as `u8`).
    pub reason: Vec<u8>,
}

impl BatchSolution {
    pub(crate) fn with_capacity(rows: usize, n: usize) -> Self {
        BatchSolution {
            theta: Vec::with_capacity(rows * n),
            converged: Vec::with_capacity(rows),
            iterations: Vec::with_capacity(rows),
            residual: Vec::with_capacity(rows),
            within_limits: Vec::with_capacity(rows),
            reason: Vec::with_capacity(rows),
        }
    }

    /// Appends one row whose joint-limit flag is known.
    pub(crate) fn push_row(&mut self, theta: &[f64], st: Status, within_limits: bool) {
        self.theta.extend_from_slice(theta);
        self.push_status(st, within_limits);
    }

    /// Appends the status of a row whose angles are already in `theta`.
    pub(crate) fn push_status(&mut self, st: Status, within_limits: bool) {
        self.converged.push(st.converged);
        self.iterations.push(st.iterations);
        self.residual.push(st.residual);
        self.within_limits.push(within_limits);
        self.reason.push(st.reason as u8);
    }

    /// Appends the rows of `other` after those of `self`.
    pub(crate) fn extend(&mut self, other: BatchSolution) {
        self.theta.extend(other.theta);
        self.converged.extend(other.converged);
        self.iterations.extend(other.iterations);
        self.residual.extend(other.residual);
        self.within_limits.extend(other.within_limits);
        self.reason.extend(other.reason);
    }

    /// The parts' rows in order (one part is moved, not copied).
    pub(crate) fn concat(parts: Vec<BatchSolution>) -> Self {
        let mut parts = parts.into_iter();
        let mut out = parts.next().unwrap_or_default();
        for p in parts {
            out.extend(p);
        }
        out
    }
}

/// Validates a flat `(N, width)` batch; returns `N`.
pub fn rows_of(name: &str, values: &[f64], width: usize) -> Result<usize> {
    let rows = check_rows(name, values, width)?;
    check_finite(name, values).map_err(|e| match e {
        CdsmError::NonFinite { name, index, value } => CdsmError::NonFiniteAt {
            name,
            row: index / width,
            column: index % width,
            value,
        },
        e => e,
    })?;
    Ok(rows)
}

/// Validates a flat `(rows, width)` batch that must have exactly `rows` rows.
pub fn rows_exactly(name: &str, values: &[f64], width: usize, rows: usize) -> Result<()> {
    let got = rows_of(name, values, width)?;
    if got != rows {
        return Err(CdsmError::Shape {
            name: name.into(),
            expected: format!("({rows}, {width})"),
            got: format!("({got}, {width})"),
        });
    }
    Ok(())
}

/// Seeds: `None` gives zeros, otherwise `(N, n)` checked against `rows`.
pub fn seeds(seed: Option<&[f64]>, rows: usize, n: usize) -> Result<Option<&[f64]>> {
    if let Some(s) = seed {
        rows_exactly("seed", s, n, rows)?;
    }
    Ok(seed)
}

/// Per-row or shared values of a batch, `(width,)` or `(rows, width)`,
/// checked finite: `None` when not given, else the values and whether
/// they are per row.
pub fn shared_or_rows<'a>(
    name: &str,
    v: Option<&'a [f64]>,
    width: usize,
    rows: usize,
) -> Result<Option<(&'a [f64], bool)>> {
    let Some(v) = v else {
        return Ok(None);
    };
    check_finite(name, v)?;
    if v.len() == width {
        Ok(Some((v, false)))
    } else if v.len() == rows * width {
        Ok(Some((v, true)))
    } else {
        Err(CdsmError::Shape {
            name: name.into(),
            expected: format!("({width},) or ({rows}, {width})"),
            got: format!("{} values", v.len()),
        })
    }
}

/// Row `i` of values from [`shared_or_rows`] (the shared ones for every row).
pub fn row_of(v: Option<(&[f64], bool)>, width: usize, i: usize) -> Option<&[f64]> {
    v.map(|(v, per_row)| {
        if per_row {
            &v[i * width..(i + 1) * width]
        } else {
            v
        }
    })
}
