//! The paper's error studies (Fig. 3): tip deviation caused by upper-cable
//! length errors and hole-location errors, one scenario at a time or as a
//! Monte-Carlo study reduced to per-configuration statistics.

use crate::arm::PACK;
use crate::cables::CableGeometry;
use crate::chain::{Broadcast, Chain};
use crate::error::{CdsmError, Result};
use crate::kinds::{log_so3, Frame, HoleGrouping, Se2, Se3, Vector};
use crate::kinematics::fk;
use crate::model::Model;
use crate::planar::cable_lanes::{closed_form_block, ClosedFormBlock, BLOCK_ROWS};
use crate::real::pack::Pack;
use crate::real::Lane;
use crate::robot::PlanarView;
use crate::rows::{rows_exactly, rows_of, split_rows, BatchSolution};
use crate::simd::math::atan2_slice;
use crate::solve::{cs_difference, CableMethod, CableNewton, CableSolver, SolveOptions};
use crate::tension::{Balance, Wrench};
use pulp::{Simd, WithSimd};
use std::ops::Range;

type P = Pack<PACK>;

/// Hole-location errors of the samples of a Monte-Carlo study.
#[derive(Debug, Clone, Copy)]
pub enum HoleErrors<'a> {
    /// No hole error.
    None,
    /// `(S, n)`: the paper's per-disk hole-height errors (m); arms whose
    /// holes group per end disk only ([`HoleGrouping::PerEndDisk`]).
    PerPair(&'a [f64]),
    /// An error on every hole coordinate (m), in the kind's layout: planar
    /// `(S, 2n, n+1, 2, 2)`, otherwise `(S, 3H)` over [`Model::flat_holes`].
    Full(&'a [f64]),
}

impl<'a> HoleErrors<'a> {
    /// The hole errors of a study given as per-disk heights `dh` or every
    /// coordinate `dholes` (at most one; `dh` refused unless the kind's
    /// holes group per end disk).
    pub fn of(model: &Model, dh: Option<&'a [f64]>, dholes: Option<&'a [f64]>) -> Result<Self> {
        if dh.is_some() && model.kind.info().holes != HoleGrouping::PerEndDisk {
            return Err(per_pair_refused());
        }
        match (dh, dholes) {
            (None, None) => Ok(HoleErrors::None),
            (Some(a), None) => Ok(HoleErrors::PerPair(a)),
            (None, Some(a)) => Ok(HoleErrors::Full(a)),
            _ => Err(CdsmError::Option {
                name: "dh, dholes".into(),
                problem: "give at most one of them".into(),
            }),
        }
    }
}

/// The error for per-disk hole heights on an arm whose holes do not group
/// per end disk.
fn per_pair_refused() -> CdsmError {
    CdsmError::Option {
        name: "dh".into(),
        problem: "per-pair hole heights are planar; a spatial arm's Monte Carlo takes `dholes`"
            .into(),
    }
}

/// The planar fast paths' solver is the cable solver's planar evaluator.
const PLANAR: &str = "an arm with a planar view has the planar evaluator";

/// End deviation after the position cables are set to `L0 + dl` (L0:
/// nominal lengths at `theta0`, `dl (m_pos,)` m) on an arm whose holes are
/// `holes` (m, in the kind's layout: planar `(2n, n+1, 2, 2)`, otherwise
/// [`Model::flat_holes`]; `None`: nominal). `theta0 (N, n)` rad. Returns
/// `dS (N, task)`, NaN where the solve failed, and the solves (seeded at
/// `theta0`). Planar `[dX, dY, dphi]` (m, m, rad) by its fast path (poses
/// from the closed form's cos/sin); any other arm by the general solve
/// ([`crate::arm::solve_cables`]) and its end frames, `[dp, R0 log(R0ᵀ R1)]`
/// (m; the rotation vector of the end frame's change in the base frame, rad).
pub fn deviation(
    model: &Model,
    theta0: &[f64],
    dl: &[f64],
    holes: Option<&[f64]>,
    method: CableMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<(Vec<f64>, BatchSolution)> {
    let Some(robot) = model.planar() else {
        return general_deviation(model, theta0, dl, holes, method, opts, threads);
    };
    let n = robot.n();
    let rows = rows_of("theta0", theta0, n)?;
    check_len("dl", dl, n)?;
    crate::error::check_finite("dl", dl)?;
    if let Some(h) = holes {
        robot.with_holes(h)?;
    }
    let perturbed = CableGeometry::new(robot, holes);
    let parts = split_rows(rows, threads, |r| {
        let mut ds = Vec::with_capacity(r.len() * 3);
        let mut sol = BatchSolution::with_capacity(r.len(), n);
        let (mut cs, mut target, mut th) = (vec![(1.0, 0.0); n], vec![0.0; n], vec![0.0; n]);
        let mut driver = CableSolver::<Se2<f64>>::new(model, model, method, *opts);
        let (solver, nominal) = driver.planar_mut().expect(PLANAR);
        for i in r {
            let t0 = &theta0[i * n..(i + 1) * n];
            for (c, t) in cs.iter_mut().zip(t0) {
                *c = (t.cos(), t.sin());
            }
            nominal.upper_lengths(&cs, &mut target);
            for (t, d) in target.iter_mut().zip(dl) {
                *t += d;
            }
            th.copy_from_slice(t0);
            let st = solver.solve(&perturbed, &target, &mut th);
            let (p0, p) = (fk(robot, t0), solver.pose(&th));
            ds.extend((0..3).map(|k| if st.converged { p[k] - p0[k] } else { f64::NAN }));
            sol.push_row(&th, st, robot.limits().contains(&th));
        }
        (ds, sol)
    });
    let mut ds = Vec::with_capacity(rows * 3);
    let mut sol = BatchSolution::default();
    for (d, s) in parts {
        ds.extend(d);
        sol.extend(s);
    }
    Ok((ds, sol))
}

/// [`deviation`] by the general solve (any arm; the planar arms take their
/// fast path).
fn general_deviation(
    model: &Model,
    theta0: &[f64],
    dl: &[f64],
    holes: Option<&[f64]>,
    method: CableMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<(Vec<f64>, BatchSolution)> {
    let (n, pos) = (model.n(), model.position_cables());
    let m = pos.len();
    let rows = rows_of("theta0", theta0, n)?;
    check_len("dl", dl, m)?;
    crate::error::check_finite("dl", dl)?;
    let moved_arm;
    let moved = match holes {
        Some(h) => {
            moved_arm = model.with_holes(h, false)?;
            &moved_arm
        }
        None => model,
    };
    let all = crate::arm::cable_lengths(model, theta0, threads)?;
    let cables = model.cables.len();
    let mut target = Vec::with_capacity(rows * m);
    for i in 0..rows {
        target.extend(pos.iter().zip(dl).map(|(&c, d)| all[i * cables + c] + d));
    }
    let sol = crate::arm::solve_cables(moved, &target, Some(theta0), method, opts, threads)?;
    let f0 = crate::arm::fk_matrix(model, theta0, threads)?;
    let f1 = crate::arm::fk_matrix(moved, &sol.theta, threads)?;
    let mut ds = Vec::with_capacity(rows * 6);
    for i in 0..rows {
        let (a, b) = (&f0[16 * i..16 * (i + 1)], &f1[16 * i..16 * (i + 1)]);
        if !sol.converged[i] {
            ds.extend([f64::NAN; 6]);
            continue;
        }
        ds.extend((0..3).map(|k| b[4 * k + 3] - a[4 * k + 3]));
        // R0ᵀ R1, its rotation vector, turned into the base frame
        let rel: [[f64; 3]; 3] = std::array::from_fn(|p| {
            std::array::from_fn(|q| (0..3).map(|k| a[4 * k + p] * b[4 * k + q]).sum())
        });
        let v = log_so3(&rel);
        ds.extend((0..3).map(|p| (0..3).map(|k| a[4 * p + k] * v[k]).sum::<f64>()));
    }
    Ok((ds, sol))
}

fn check_len(name: &str, v: &[f64], n: usize) -> Result<()> {
    if v.len() != n {
        return Err(CdsmError::Shape {
            name: name.into(),
            expected: format!("({n},)"),
            got: format!("({},)", v.len()),
        });
    }
    Ok(())
}

/// Quantities tracked per configuration: dX (m), dY (m), dphi (rad), |d(X, Y)| (m).
pub const QUANTITIES: usize = 4;
/// Log-spaced histogram of the position-error norm: bins per decade, 232:
/// a bin spans a factor `10^(1/232) = 1.00997`, so the geometric middle of
/// the bin holding a quantile is within 0.498 % of it (`docs/model.md`,
/// "Monte-Carlo quantiles").
pub const HIST_PER_DECADE: usize = 232;
/// Lower edge of the first regular bin (m); values below go to bin 0.
pub const HIST_LO: f64 = 1e-9;
/// Decades covered (up to 10 m); values above go to the last bin.
pub const HIST_DECADES: usize = 10;
/// Number of histogram bins, including the under- and overflow bins.
pub const HIST_BINS: usize = HIST_PER_DECADE * HIST_DECADES + 2;

/// Edges (m) of the regular histogram bins: `HIST_LO · 10^(k / HIST_PER_DECADE)`,
/// `k = 0..=HIST_PER_DECADE · HIST_DECADES`. Bin `b` (1-based regular bins)
/// holds `[edges[b-1], edges[b])`; bin 0 is below `edges[0]`, the last bin at or
/// above the last edge.
pub fn hist_edges() -> &'static [f64] {
    static EDGES: std::sync::OnceLock<Vec<f64>> = std::sync::OnceLock::new();
    EDGES.get_or_init(|| {
        (0..=HIST_PER_DECADE * HIST_DECADES)
            .map(|k| HIST_LO * 10f64.powf(k as f64 / HIST_PER_DECADE as f64))
            .collect()
    })
}

/// Bin of a position-error norm (m), exact against [`hist_edges`]: a log
/// estimate from the float's exponent and mantissa within 0.7 bins, so the
/// bin is the estimate's or a neighbour, chosen by two comparisons with the
/// edges without branches (the walk after them never runs: it keeps the
/// answer exact whatever the estimate).
#[inline(always)]
pub fn hist_bin(v: f64) -> usize {
    let edges = hist_edges();
    if v.is_nan() || v < edges[0] {
        return 0;
    }
    let last = edges.len(); // == HIST_BINS - 1
    if v >= edges[last - 1] {
        return last;
    }
    let b0 = bin_estimate(v);
    // edges[0] <= v < edges[last - 1]: `down` is 0 at b0 = 1, `up` is 0 at b0 = last - 1
    let down = usize::from(v < edges[b0 - 1]);
    let up = usize::from(v >= edges[b0]);
    let mut b = b0 + up - down;
    if !(edges[b - 1] <= v && v < edges[b]) {
        while v < edges[b - 1] {
            b -= 1;
        }
        while v >= edges[b] {
            b += 1;
        }
    }
    b
}

/// The regular bin (`1..HIST_BINS - 1`) of a norm within the regular bins'
/// range (m) from its float's exponent and mantissa: log2 to within 0.01,
/// 0.7 bins, so the true bin is this one or a neighbour.
#[inline(always)]
fn bin_estimate(v: f64) -> usize {
    let bits = v.to_bits();
    let e = ((bits >> 52) & 0x7ff) as f64 - 1023.0;
    let m = f64::from_bits((bits & ((1u64 << 52) - 1)) | (1023u64 << 52)) - 1.0;
    let log2 = e + m * (1.3465 - 0.3465 * m);
    let per_log2 = HIST_PER_DECADE as f64 * std::f64::consts::LOG10_2;
    // truncation, not floor (a libm call): the caller corrects the guess
    let est = ((log2 - HIST_LO.log2()) * per_log2) as isize + 1;
    est.clamp(1, HIST_BINS as isize - 2) as usize
}

/// The number of samples of one Monte-Carlo call, checked: the histogram
/// counts them in 32 bits (a study of more samples runs in chunks).
pub fn check_samples(samples: usize) -> Result<usize> {
    if samples > u32::MAX as usize {
        return Err(CdsmError::Option {
            name: "dl".into(),
            problem: format!(
                "{samples} samples in one call; at most {} (run the study in chunks)",
                u32::MAX
            ),
        });
    }
    Ok(samples)
}

/// Per-configuration statistics of a Monte-Carlo study, mergeable across
/// chunks: `quantities` values per sample (planar: dX, dY, dphi, |dXY|;
/// spatial: dX, dY, dZ, |dXYZ|, rotation angle), the histogram over the
/// position-error norm (quantity [`NORM`]).
#[derive(Debug, Clone, PartialEq)]
pub struct McStats {
    pub configs: usize,
    pub quantities: usize,
    /// Samples whose solve converged, per configuration.
    pub count: Vec<u64>,
    /// Samples whose solve failed (not included in the moments), per configuration.
    pub failed: Vec<u64>,
    /// `(N, quantities)` sums, sums of squares, minima and maxima.
    pub sum: Vec<f64>,
    pub sum_sq: Vec<f64>,
    pub min: Vec<f64>,
    pub max: Vec<f64>,
    /// Per configuration, the counts of the position-error norm per
    /// log-spaced bin ([`hist_bin`]), held as the window of bins it reached
    /// (filled while its block is open: [`McStats::open`]).
    pub hist: Vec<BinWindow>,
    open: OpenRows,
    /// Converged samples whose perturbed configuration needs a slack upper
    /// cable (counted only when asked), per configuration.
    pub slack: Vec<u64>,
}

/// The histogram of one configuration: the counts of bins
/// `lo..lo + counts.len()` (of [`HIST_BINS`]; every other bin is empty), from
/// its first to its last non-empty bin: a study holds the few hundred bins its
/// errors reach rather than every bin of every configuration.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BinWindow {
    pub lo: usize,
    pub counts: Vec<u32>,
}

impl BinWindow {
    /// The bins `a..b` from the first to past the last non-empty one, or None.
    pub fn occupied(&self) -> Option<(usize, usize)> {
        (!self.counts.is_empty()).then(|| (self.lo, self.lo + self.counts.len()))
    }
}

/// The histograms of the configurations being filled, one dense row of
/// every bin each (in cache while a block of configurations takes its
/// samples), each row taken out as its [`BinWindow`] when the block is done.
#[derive(Debug, Clone, PartialEq, Default)]
struct OpenRows {
    /// the first configuration of the block
    base: usize,
    /// `(rows, HIST_BINS)` counts
    counts: Vec<u32>,
    /// per row, the first and past the last non-empty bin (`lo > hi`: none)
    used: Vec<(usize, usize)>,
}

/// Quantities of a spatial Monte-Carlo sample ([`GeneralPacks`]): dX, dY,
/// dZ, |dXYZ| (m), rotation angle (rad).
pub const SPATIAL_QUANTITIES: usize = 5;

/// Index of the position-error norm among the quantities of both kinds.
pub const NORM: usize = 3;

impl McStats {
    /// Planar statistics ([`QUANTITIES`] per sample).
    pub fn new(configs: usize) -> Self {
        McStats::with_quantities(configs, QUANTITIES)
    }

    pub fn with_quantities(configs: usize, quantities: usize) -> Self {
        McStats {
            configs,
            quantities,
            count: vec![0; configs],
            failed: vec![0; configs],
            slack: vec![0; configs],
            sum: vec![0.0; configs * quantities],
            sum_sq: vec![0.0; configs * quantities],
            min: vec![f64::INFINITY; configs * quantities],
            max: vec![f64::NEG_INFINITY; configs * quantities],
            hist: vec![BinWindow::default(); configs],
            open: OpenRows::default(),
        }
    }

    /// One sample's quantities (the norm at [`NORM`]).
    pub fn add_values(&mut self, j: usize, v: &[f64]) {
        self.count[j] += 1;
        for (q, vq) in v.iter().enumerate() {
            let k = j * self.quantities + q;
            self.sum[k] += vq;
            self.sum_sq[k] += vq * vq;
            self.min[k] = self.min[k].min(*vq);
            self.max[k] = self.max[k].max(*vq);
        }
        self.add_to_hist(j, v[NORM]);
    }

    /// Opens the histograms of the configurations `base..base + rows` (of
    /// this one's): their samples may be added until [`McStats::close`].
    pub fn open(&mut self, base: usize, rows: usize) {
        let o = &mut self.open;
        o.base = base;
        o.counts.resize(rows * HIST_BINS, 0);
        o.used.clear();
        o.used.resize(rows, (usize::MAX, 0));
    }

    /// Counts a position-error norm `norm` (m) of configuration `j` (of the
    /// open block) in its bin.
    #[inline(always)]
    fn add_to_hist(&mut self, j: usize, norm: f64) {
        let (o, bin) = (&mut self.open, hist_bin(norm));
        let r = j - o.base;
        o.counts[r * HIST_BINS + bin] += 1;
        o.used[r] = (o.used[r].0.min(bin), o.used[r].1.max(bin + 1));
    }

    /// Closes the open block: each configuration keeps the window of bins
    /// its samples reached (the block's rows are left empty for the next).
    pub fn close(&mut self) {
        let o = &mut self.open;
        for (r, (lo, hi)) in o.used.iter().enumerate() {
            if lo < hi {
                let row = &mut o.counts[r * HIST_BINS + lo..r * HIST_BINS + hi];
                self.hist[o.base + r] = BinWindow {
                    lo: *lo,
                    counts: row.to_vec(),
                };
                row.fill(0);
            }
        }
        o.used.clear();
    }

    /// The histograms of every configuration in one common window of bins:
    /// `(lo, width, counts)`, counts `(N, width)` row-major of bins
    /// `lo..lo + width` (every bin outside is empty; `width` 0 when no
    /// configuration has a sample).
    pub fn hist_window(&self) -> (usize, usize, Vec<u32>) {
        let used = self.hist.iter().filter_map(BinWindow::occupied);
        let (lo, hi) = used.fold((usize::MAX, 0), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)));
        if lo > hi {
            return (0, 0, Vec::new());
        }
        let width = hi - lo;
        // written once, row by row (no zero-fill first)
        let mut counts = Vec::with_capacity(self.hist.len() * width);
        for w in &self.hist {
            match w.occupied() {
                Some((a, b)) => {
                    counts.resize(counts.len() + (a - lo), 0);
                    counts.extend_from_slice(&w.counts);
                    counts.resize(counts.len() + (hi - b), 0);
                }
                None => counts.resize(counts.len() + width, 0),
            }
        }
        (lo, width, counts)
    }

    /// Appends the configurations of `other` after those of `self`.
    pub fn extend(&mut self, other: McStats) {
        self.configs += other.configs;
        self.count.extend(other.count);
        self.failed.extend(other.failed);
        self.slack.extend(other.slack);
        self.sum.extend(other.sum);
        self.sum_sq.extend(other.sum_sq);
        self.min.extend(other.min);
        self.max.extend(other.max);
        self.hist.extend(other.hist);
        debug_assert!(self.open.used.is_empty() && other.open.used.is_empty());
    }
}

/// Monte-Carlo study of an arm of either kind: for every sample `s`
/// (position-cable errors `dl[s] (m_pos)` m, hole errors per `holes`) and
/// every configuration `theta0[j] (n)` rad, the cable solve seeded at
/// `theta0[j]` and the end's deviation, reduced to [`McStats`] with the
/// kind's quantities ([`crate::kinds::KindInfo::quantities`]: planar dX,
/// dY, dphi, |dXY|; spatial dX, dY, dZ, |dXYZ|, rotation angle). One driver
/// (the checks, each sample's arm, the threads, the merge) over two
/// strategies chosen once here, each with its own order of accumulation: a
/// planar arm's SIMD lanes ([`PlanarLanes`]: the closed form across blocks
/// of configurations, `method`; the solver's fallback), any other arm's
/// packs of the general solve ([`GeneralPacks`]). With `check_slack`, every
/// converged sample's configuration is also checked for position tensions
/// holding the arm (no load, the arm's gravity and lower/force cables) and
/// counted in `slack` when a cable would go slack (planar: nominal holes for
/// the moment arms; general: the sample's).
#[allow(clippy::too_many_arguments)]
pub fn monte_carlo(
    model: &Model,
    theta0: &[f64],
    dl: &[f64],
    holes: HoleErrors,
    method: CableMethod,
    opts: &SolveOptions,
    check_slack: bool,
    threads: usize,
) -> Result<McStats> {
    let (n, m) = (model.n(), model.position_cables().len());
    let rows = rows_of("theta0", theta0, n)?;
    let samples = check_samples(rows_of("dl", dl, m)?)?;
    let quantities = model.kind.info().quantities.len();
    let strategy = match model.planar() {
        Some(robot) => Strategy::Lanes(PlanarLanes::new(
            model, robot, holes, samples, method, opts,
        )?),
        None => Strategy::Packs(GeneralPacks::new(model, holes, samples, opts)?),
    };
    // configurations outermost: each one's statistics stay in cache while its
    // samples are added (in sample order, as any chunking of the samples would)
    let parts = split_rows(rows, threads, |r| match &strategy {
        Strategy::Lanes(s) => s.rows(theta0, dl, check_slack, r),
        Strategy::Packs(s) => s.rows(theta0, dl, check_slack, r),
    });
    let mut out = McStats::with_quantities(0, quantities);
    for p in parts {
        out.extend(p);
    }
    Ok(out)
}

/// The two ways [`monte_carlo`] runs the configurations of a thread.
enum Strategy<'a> {
    Lanes(PlanarLanes<'a>),
    Packs(GeneralPacks<'a>),
}

/// A planar arm's Monte Carlo ([`QUANTITIES`] per sample): blocks of
/// configurations, one per SIMD lane, the closed form of a block for one
/// sample sharing that sample's cable geometry (no robot rebuilt per
/// sample: only its cable geometry); the lanes it does not settle, and
/// every solve when Newton is asked for or the limits are enforced, through
/// [`CableSolver`]. Slack: the square balance over the nominal holes.
pub struct PlanarLanes<'a> {
    model: &'a Model,
    robot: &'a PlanarView,
    nominal: CableGeometry,
    /// every sample's cable geometry (empty: every sample the nominal one)
    geoms: Vec<CableGeometry>,
    method: CableMethod,
    opts: SolveOptions,
    samples: usize,
}

impl<'a> PlanarLanes<'a> {
    fn new(
        model: &'a Model,
        robot: &'a PlanarView,
        holes: HoleErrors,
        samples: usize,
        method: CableMethod,
        opts: &SolveOptions,
    ) -> Result<Self> {
        let n = robot.n();
        let hole_len = robot.holes.len();
        match holes {
            HoleErrors::None => {}
            HoleErrors::PerPair(h) => rows_exactly("dh", h, n, samples)?,
            HoleErrors::Full(h) => rows_exactly("dholes", h, hole_len, samples)?,
        }
        let nominal = CableGeometry::new(robot, None);
        // every sample's cable geometry once (no robot rebuilt), shared by the threads
        let mut hbuf = vec![0.0; hole_len];
        let geoms: Vec<CableGeometry> = match holes {
            HoleErrors::None => Vec::new(),
            HoleErrors::PerPair(h) => (0..samples)
                .map(|s| {
                    robot.hole_height_error_into(&h[s * n..(s + 1) * n], &mut hbuf);
                    CableGeometry::new(robot, Some(&hbuf))
                })
                .collect(),
            HoleErrors::Full(h) => (0..samples)
                .map(|s| {
                    let e = &h[s * hole_len..(s + 1) * hole_len];
                    for (b, (a, d)) in hbuf.iter_mut().zip(robot.holes.iter().zip(e)) {
                        *b = a + d;
                    }
                    CableGeometry::new(robot, Some(&hbuf))
                })
                .collect(),
        };
        Ok(PlanarLanes {
            model,
            robot,
            nominal,
            geoms,
            method,
            opts: *opts,
            samples,
        })
    }

    /// The statistics of the configurations `r` of `theta0`.
    fn rows(&self, theta0: &[f64], dl: &[f64], check_slack: bool, r: Range<usize>) -> McStats {
        let PlanarLanes {
            model,
            robot,
            ref nominal,
            ref geoms,
            method,
            ref opts,
            samples,
        } = *self;
        let n = robot.n();
        let geom_of = |s: usize| geoms.get(s).unwrap_or(nominal);
        // |t_k - t0_k| below this on every joint keeps |dphi| < pi/2: one atan2
        let small = (std::f64::consts::FRAC_PI_2 / n as f64).cos();
        let arch = pulp::Arch::new();
        let mut stats = McStats::with_quantities(r.len(), QUANTITIES);
        let (mut target, mut th) = (vec![0.0; n], vec![0.0; n]);
        let mut driver = CableSolver::<Se2<f64>>::new(model, model, method, *opts);
        let (solver, _) = driver.planar_mut().expect(PLANAR);
        let mut chain = Chain::<f64, Se2<f64>>::new(model);
        let mut bal = Balance::<f64>::new(model);
        let mut tension = vec![0.0; n];
        let zero = [0.0; 3];
        let mut slack_at = |theta: &[f64]| {
            chain.at(model, model, theta);
            let wrench = Wrench {
                force: zero,
                couple: &zero[..1],
            };
            bal.at(model, model, &mut chain, model.gravity, wrench);
            !(bal.solve_square(&mut tension) && tension.iter().all(|t| *t > 0.0))
        };
        // blocks of configurations, one per SIMD lane: the closed form of a
        // block for one sample shares that sample's geometry; each
        // configuration still gets its samples in sample order
        let mut block = ClosedFormBlock::new(n);
        let mut seed_cs = vec![(1.0, 0.0); n * BLOCK_ROWS];
        let mut l0 = vec![0.0; n * BLOCK_ROWS];
        let mut p0 = [[0.0; 3]; BLOCK_ROWS];
        let first = r.start;
        let mut acc = BlockStats::default();
        let mut v = [[0.0; BLOCK_ROWS]; QUANTITIES];
        // the SIMD lanes accept a closed form within tol; with the joint
        // limits enforced every solve goes the general path (its `finish`
        // also checks the answer against the limits)
        let simd = method != CableMethod::Newton && !opts.enforce_limits;
        for start in r.clone().step_by(BLOCK_ROWS) {
            let lanes = BLOCK_ROWS.min(r.end - start);
            for b in 0..lanes {
                let t0 = &theta0[(start + b) * n..(start + b + 1) * n];
                let sc = &mut seed_cs[b * n..(b + 1) * n];
                for (c, t) in sc.iter_mut().zip(t0) {
                    *c = (t.cos(), t.sin());
                }
                nominal.upper_lengths(sc, &mut l0[b * n..(b + 1) * n]);
                p0[b] = fk(robot, t0);
                for (k, (c, s)) in sc.iter().enumerate() {
                    block.seed_cos[k * BLOCK_ROWS + b] = *c;
                    block.seed_sin[k * BLOCK_ROWS + b] = *s;
                }
            }
            acc.clear();
            stats.open(start - first, lanes);
            for s in 0..samples {
                let geom = geom_of(s);
                let mut taken = [false; BLOCK_ROWS];
                if simd {
                    // the lanes' closed form and deviations, compiled for
                    // the instruction set of `arch`; a lane not taken goes
                    // the general path below
                    taken = arch.dispatch(SampleLanes {
                        robot,
                        geom,
                        block: &mut block,
                        l0: &l0,
                        dl: &dl[s * n..(s + 1) * n],
                        p0: &p0,
                        small,
                        tol: opts.tol,
                        lanes,
                        acc: &mut acc,
                        v: &mut v,
                        stats: &mut stats,
                        j0: start - first,
                    });
                    if check_slack {
                        for b in (0..lanes).filter(|b| taken[*b]) {
                            // the answer's angles from its cos/sin, relative to the seed
                            let t0 = &theta0[(start + b) * n..(start + b + 1) * n];
                            let sc = &seed_cs[b * n..(b + 1) * n];
                            for (k, (t, (s0, t0k))) in
                                th.iter_mut().zip(sc.iter().zip(t0)).enumerate()
                            {
                                let c =
                                    (block.cos[k * BLOCK_ROWS + b], block.sin[k * BLOCK_ROWS + b]);
                                let d = cs_difference(c, *s0);
                                *t = t0k + d.1.atan2(d.0);
                            }
                            acc.slack[b] += u64::from(slack_at(&th));
                        }
                    }
                }
                for b in (0..lanes).filter(|b| !taken[*b]) {
                    // the general path (Newton asked for, or the closed form's failure)
                    let (i, j) = (start + b, start + b - first);
                    for (k, tk) in target.iter_mut().enumerate() {
                        *tk = l0[b * n + k] + dl[s * n + k];
                    }
                    th.copy_from_slice(&theta0[i * n..(i + 1) * n]);
                    let st = solver.solve(geom, &target, &mut th);
                    if st.converged {
                        let p = solver.pose(&th);
                        let q = p0[b];
                        let ds = [p[0] - q[0], p[1] - q[1], p[2] - q[2]];
                        let norm = (ds[0] * ds[0] + ds[1] * ds[1]).sqrt();
                        acc.add(b, [ds[0], ds[1], ds[2], norm]);
                        stats.add_to_hist(j, norm);
                        if check_slack {
                            acc.slack[b] += u64::from(slack_at(&th));
                        }
                    } else {
                        acc.failed[b] += 1;
                    }
                }
            }
            acc.store(&mut stats, start - first, lanes);
            stats.close();
        }
        stats
    }
}

/// Any other arm's Monte Carlo (the kind's quantities per sample: spatial
/// dX, dY, dZ, |dXYZ| (m) and the rotation angle (rad)): packs of
/// [`PACK`] configurations by the general solve, each sample's hole errors
/// `dholes (S, 3H)` (m, over [`Model::flat_holes`]) one arm built per
/// sample with its traversals. Slack: a set of position tensions holding
/// the arm under its gravity and force cables (the sample's holes for the
/// moment arms; [`crate::arm::held`] at floor 0).
pub struct GeneralPacks<'a> {
    model: &'a Model,
    /// the samples' arms (empty: every sample the nominal one)
    models: Vec<Model>,
    traverse: Vec<Vec<f64>>,
    opts: SolveOptions,
    quantities: usize,
    arch: pulp::Arch,
}

impl<'a> GeneralPacks<'a> {
    fn new(
        model: &'a Model,
        holes: HoleErrors,
        samples: usize,
        opts: &SolveOptions,
    ) -> Result<Self> {
        opts.check()?;
        let dholes = match holes {
            HoleErrors::None => None,
            HoleErrors::Full(d) => Some(d),
            HoleErrors::PerPair(_) => return Err(per_pair_refused()),
        };
        let nominal_holes = model.flat_holes();
        let h = nominal_holes.len();
        let models: Vec<Model> = match dholes {
            None => Vec::new(),
            Some(d) => {
                rows_exactly("dholes", d, h, samples)?;
                (0..samples)
                    .map(|s| {
                        let flat: Vec<f64> = nominal_holes
                            .iter()
                            .zip(&d[s * h..(s + 1) * h])
                            .map(|(a, b)| a + b)
                            .collect();
                        model.with_flat_holes(&flat)
                    })
                    .collect::<Result<_>>()?
            }
        };
        let model_of = |s: usize| models.get(s).unwrap_or(model);
        // every arm's traversals once (the nominal one's when no hole moves)
        let pos = model.position_cables();
        let traverse: Vec<Vec<f64>> = (0..samples.min(models.len()).max(1))
            .map(|s| {
                let mut t = Vec::new();
                Broadcast::traversals(model_of(s), model_of(s), &pos, &mut t);
                t
            })
            .collect();
        Ok(GeneralPacks {
            model,
            models,
            traverse,
            opts: *opts,
            quantities: model.kind.info().quantities.len(),
            arch: pulp::Arch::new(),
        })
    }

    /// The statistics of the configurations `r` of `theta0`.
    fn rows(&self, theta0: &[f64], dl: &[f64], check_slack: bool, r: Range<usize>) -> McStats {
        self.arch.dispatch(McRows {
            model: self.model,
            models: &self.models,
            traverse: &self.traverse,
            theta0,
            dl,
            opts: &self.opts,
            check_slack,
            rows: r,
            quantities: self.quantities,
        })
    }
}

/// The configurations `rows` of [`monte_carlo`]: packs of [`PACK`]
/// configurations, each sample's solves of a pack in lanes (sharing the
/// sample's arm), the lanes that leave the Newton phase through
/// the chain's cable solver ([`crate::solve::ChainSolver`]); every
/// configuration gets its samples in sample order.
struct McRows<'a> {
    model: &'a Model,
    /// the samples' arms (empty: every sample the nominal one)
    models: &'a [Model],
    traverse: &'a [Vec<f64>],
    theta0: &'a [f64],
    dl: &'a [f64],
    opts: &'a SolveOptions,
    check_slack: bool,
    rows: Range<usize>,
    /// the kind's quantities per sample (5)
    quantities: usize,
}

/// Lane `b` of a pack of frames.
fn lane_frame(f: &Se3<P>, b: usize) -> Se3<f64> {
    Se3 {
        r: std::array::from_fn(|i| std::array::from_fn(|k| f.r[i][k].0[b])),
        t: std::array::from_fn(|i| f.t[i].0[b]),
    }
}

/// A Monte-Carlo sample's quantities: the end frame `end` against the
/// nominal `end0`: dX, dY, dZ, |dXYZ| (m) and the rotation angle (rad).
fn sample_quantities(end0: &Se3<f64>, end: &Se3<f64>) -> [f64; SPATIAL_QUANTITIES] {
    let d = end.t.sub(end0.t);
    let rel: [[f64; 3]; 3] = std::array::from_fn(|a| {
        std::array::from_fn(|b| (0..3).map(|k| end0.r[k][a] * end.r[k][b]).sum())
    });
    [d[0], d[1], d[2], d.norm(), log_so3(&rel).norm()]
}

impl WithSimd for McRows<'_> {
    type Output = McStats;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> McStats {
        let McRows {
            model,
            models,
            traverse,
            theta0,
            dl,
            opts,
            check_slack,
            rows: r,
            quantities,
        } = self;
        let (n, pos) = (model.n(), model.position_cables());
        let m = pos.len();
        let samples = dl.len() / m;
        let model_of = |s: usize| models.get(s).unwrap_or(model);
        let mut stats = McStats::with_quantities(r.len(), quantities);
        let mut lanes = CableNewton::<P, Se3<P>>::new(model, *opts);
        let mut driver = CableSolver::<Se3<f64>>::new(model, model, CableMethod::Auto, *opts);
        let solver = driver
            .chain_mut()
            .expect("an arm without a planar view has the chain evaluator");
        let mut chain = Chain::<f64, Se3<f64>>::new(model);
        let (mut l0, mut end0) = (vec![0.0; PACK * m], [Se3::<f64>::identity(); PACK]);
        let (mut target, mut th) = (vec![0.0; m], vec![0.0; n]);
        let mut bal = Balance::<f64>::new(model);
        let mut t = vec![0.0; m];
        let zero = [0.0; 3];
        for start in r.clone().step_by(PACK) {
            let count = PACK.min(r.end - start);
            for b in 0..count {
                let t0 = &theta0[(start + b) * n..(start + b + 1) * n];
                chain.at(model, model, t0);
                chain.world(model, model);
                for (k, &c) in pos.iter().enumerate() {
                    l0[b * m + k] = chain.cable_length(model, model, c, None);
                }
                end0[b] = *chain.end();
            }
            stats.open(start - r.start, count);
            for s in 0..samples {
                let ms = model_of(s);
                let arm = Broadcast::new(ms, &traverse[s.min(traverse.len() - 1)]);
                let ds = &dl[s * m..(s + 1) * m];
                // a short pack repeats its last configuration in the spare lanes
                for b in 0..PACK {
                    let (i, bb) = (start + b.min(count - 1), b.min(count - 1));
                    for (k, x) in lanes.x.iter_mut().enumerate() {
                        x.0[b] = theta0[i * n + k];
                    }
                    for (k, tk) in lanes.target.iter_mut().enumerate() {
                        tk.0[b] = l0[bb * m + k] + ds[k];
                    }
                }
                let o = lanes.run(ms, &arm);
                if P::any(o.converged) {
                    lanes.chain.world(ms, &arm);
                }
                for b in 0..count {
                    let (i, j) = (start + b, start + b - r.start);
                    let end = if o.status(b).is_some() {
                        for (tk, x) in th.iter_mut().zip(&lanes.x) {
                            *tk = x.0[b];
                        }
                        lane_frame(lanes.chain.end(), b)
                    } else {
                        for (k, tk) in target.iter_mut().enumerate() {
                            *tk = l0[b * m + k] + ds[k];
                        }
                        th.copy_from_slice(&theta0[i * n..(i + 1) * n]);
                        if !solver.solve(ms, ms, &target, &mut th).converged {
                            stats.failed[j] += 1;
                            continue;
                        }
                        f64::cos_sin(&th, &mut chain.cs);
                        chain.at_cs(ms, ms, &th);
                        chain.world(ms, ms);
                        *chain.end()
                    };
                    stats.add_values(j, &sample_quantities(&end0[b], &end));
                    if check_slack {
                        let wrench = Wrench {
                            force: zero,
                            couple: &zero,
                        };
                        chain.at(ms, ms, &th);
                        bal.at(ms, ms, &mut chain, ms.gravity, wrench);
                        if !crate::arm::held(&mut bal, 0.0, &mut t) {
                            stats.slack[j] += 1;
                        }
                    }
                }
            }
            stats.close();
        }
        stats
    }
}

/// One sample on a block of configurations, SIMD across them: the closed
/// form of every lane (targets `l0 + dl`, seeded at the block's seeds), the
/// lanes it solved within `tol` taken, their deviations (`v`) added to the
/// block's statistics `acc` and to the histograms of configurations `j0..`
/// of `stats`. Returns which lanes were taken. Run through
/// `pulp::Arch::dispatch`, all of it is compiled for the chosen instruction
/// set (the helpers are inlined into it).
struct SampleLanes<'a> {
    robot: &'a PlanarView,
    geom: &'a CableGeometry,
    block: &'a mut ClosedFormBlock,
    /// nominal upper-cable lengths of the lanes, lane-major `(lanes, n)`, m
    l0: &'a [f64],
    /// the sample's upper-cable errors `(n,)`, m
    dl: &'a [f64],
    /// the lanes' nominal tip poses `[x (m), y (m), phi (rad)]`
    p0: &'a [[f64; 3]; BLOCK_ROWS],
    /// the cosine below which a joint's rotation from its seed counts as
    /// large (see [`block_deviation`])
    small: f64,
    /// cable-length tolerance (m) for accepting a lane's closed form
    tol: f64,
    lanes: usize,
    acc: &'a mut BlockStats,
    v: &'a mut [[f64; BLOCK_ROWS]; QUANTITIES],
    stats: &'a mut McStats,
    j0: usize,
}

impl WithSimd for SampleLanes<'_> {
    type Output = [bool; BLOCK_ROWS];

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> [bool; BLOCK_ROWS] {
        let SampleLanes {
            robot,
            geom,
            block,
            l0,
            dl,
            p0,
            small,
            tol,
            lanes,
            acc,
            v,
            stats,
            j0,
        } = self;
        let n = dl.len();
        for b in 0..lanes {
            for k in 0..n {
                block.target[k * BLOCK_ROWS + b] = l0[b * n + k] + dl[k];
            }
        }
        closed_form_block(simd, geom, block);
        let mut taken = [false; BLOCK_ROWS];
        for (b, t) in taken.iter_mut().enumerate().take(lanes) {
            *t = block.ok[b] && block.residual[b] <= tol;
        }
        // every lane's deviation at once (lanes not taken hold garbage)
        block_deviation(robot, block, p0, small, v);
        acc.add_lanes(&taken, v);
        for b in (0..lanes).filter(|b| taken[*b]) {
            stats.add_to_hist(j0 + b, v[NORM][b]);
        }
        taken
    }
}

/// The tip deviations `[dX, dY, dphi, |dXY|]` (m, m, rad, m; into `v`,
/// lane-major) of the closed-form answers of a block (`cos`/`sin` of
/// `block`), without inverse trigonometry per joint: the pose from the
/// answers' cos/sin (the chain of [`crate::geometry::ArmGeometry::fk_cs`],
/// the same operations lane by lane), dphi from the product of the joint
/// rotations relative to the seed (one atan2, the SIMD one, within 1 ulp of
/// libm's; per joint when a rotation is large, `small`: the cosine below
/// which it is). `p0`: the seeds' poses. Lanes without an answer hold
/// garbage. The loops run across lanes (vectorised where the caller is).
#[inline(always)]
fn block_deviation(
    robot: &PlanarView,
    block: &ClosedFormBlock,
    p0: &[[f64; 3]; BLOCK_ROWS],
    small: f64,
    v: &mut [[f64; BLOCK_ROWS]; QUANTITIES],
) {
    const W: usize = BLOCK_ROWS;
    let (mut x, mut y) = ([0.0f64; W], [0.0f64; W]);
    let (mut c, mut s) = ([1.0f64; W], [0.0f64; W]);
    let (mut pc, mut ps) = ([1.0f64; W], [0.0f64; W]);
    let mut large = [false; W];
    for k in 0..robot.n() {
        let (lb, la) = (
            robot.link_before[k],
            robot.link_after[k] + robot.thickness[k],
        );
        let ck = &block.cos[k * W..(k + 1) * W];
        let sk = &block.sin[k * W..(k + 1) * W];
        let c0 = &block.seed_cos[k * W..(k + 1) * W];
        let s0 = &block.seed_sin[k * W..(k + 1) * W];
        for b in 0..W {
            x[b] += lb * c[b];
            y[b] += lb * s[b];
            (c[b], s[b]) = (c[b] * ck[b] - s[b] * sk[b], s[b] * ck[b] + c[b] * sk[b]);
            x[b] += la * c[b];
            y[b] += la * s[b];
            // the joint's rotation relative to the seed, multiplied in
            let (dc, ds) = cs_difference((ck[b], sk[b]), (c0[b], s0[b]));
            large[b] |= dc < small;
            (pc[b], ps[b]) = (pc[b] * dc - ps[b] * ds, pc[b] * ds + ps[b] * dc);
        }
    }
    for b in 0..W {
        let (dx, dy) = (x[b] - p0[b][0], y[b] - p0[b][1]);
        v[0][b] = dx;
        v[1][b] = dy;
        v[3][b] = (dx * dx + dy * dy).sqrt();
    }
    // one atan2 of the product per lane (SIMD, within 1 ulp of libm's)
    atan2_slice(&ps, &pc, &mut v[2]);
    for b in (0..W).filter(|b| large[*b]) {
        v[2][b] = (0..robot.n())
            .map(|k| {
                let d = cs_difference(
                    (block.cos[k * W + b], block.sin[k * W + b]),
                    (block.seed_cos[k * W + b], block.seed_sin[k * W + b]),
                );
                d.1.atan2(d.0)
            })
            .sum();
    }
}

/// The statistics of the configurations of one block while its samples
/// are added (lane-major per quantity, so the lanes update at once), stored
/// into [`McStats`] when the block is done: the same sums in the same order
/// as [`McStats::add_values`].
#[derive(Debug, Clone)]
struct BlockStats {
    count: [u64; BLOCK_ROWS],
    failed: [u64; BLOCK_ROWS],
    slack: [u64; BLOCK_ROWS],
    sum: [[f64; BLOCK_ROWS]; QUANTITIES],
    sum_sq: [[f64; BLOCK_ROWS]; QUANTITIES],
    min: [[f64; BLOCK_ROWS]; QUANTITIES],
    max: [[f64; BLOCK_ROWS]; QUANTITIES],
}

impl Default for BlockStats {
    fn default() -> Self {
        let z = [[0.0; BLOCK_ROWS]; QUANTITIES];
        BlockStats {
            count: [0; BLOCK_ROWS],
            failed: [0; BLOCK_ROWS],
            slack: [0; BLOCK_ROWS],
            sum: z,
            sum_sq: z,
            min: [[f64::INFINITY; BLOCK_ROWS]; QUANTITIES],
            max: [[f64::NEG_INFINITY; BLOCK_ROWS]; QUANTITIES],
        }
    }
}

impl BlockStats {
    fn clear(&mut self) {
        *self = BlockStats::default();
    }

    /// One sample's quantities `v` on the lanes `take`.
    // lane loops over parallel arrays (they vectorise as written)
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn add_lanes(&mut self, take: &[bool; BLOCK_ROWS], v: &[[f64; BLOCK_ROWS]; QUANTITIES]) {
        for b in 0..BLOCK_ROWS {
            self.count[b] += u64::from(take[b]);
        }
        for q in 0..QUANTITIES {
            for b in 0..BLOCK_ROWS {
                // a lane not taken adds +0 (the sums never hold -0: exact)
                let x = if take[b] { v[q][b] } else { 0.0 };
                self.sum[q][b] += x;
                self.sum_sq[q][b] += x * x;
                let (lo, hi) = (self.min[q][b].min(x), self.max[q][b].max(x));
                self.min[q][b] = if take[b] { lo } else { self.min[q][b] };
                self.max[q][b] = if take[b] { hi } else { self.max[q][b] };
            }
        }
    }

    /// One sample's quantities on lane `b` alone.
    fn add(&mut self, b: usize, v: [f64; QUANTITIES]) {
        let mut take = [false; BLOCK_ROWS];
        take[b] = true;
        let mut lanes = [[0.0; BLOCK_ROWS]; QUANTITIES];
        for (l, x) in lanes.iter_mut().zip(v) {
            l[b] = x;
        }
        self.add_lanes(&take, &lanes);
    }

    /// Stores the first `lanes` lanes as the configurations `j0..` of `stats`.
    fn store(&self, stats: &mut McStats, j0: usize, lanes: usize) {
        for b in 0..lanes {
            let j = j0 + b;
            stats.count[j] = self.count[b];
            stats.failed[j] = self.failed[b];
            stats.slack[j] = self.slack[b];
            for q in 0..QUANTITIES {
                let k = j * stats.quantities + q;
                stats.sum[k] = self.sum[q][b];
                stats.sum_sq[k] = self.sum_sq[q][b];
                stats.min[k] = self.min[q][b];
                stats.max[k] = self.max[q][b];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table3_point1_singular_state() {
        // Table 3, point 1: straight pose, upper cable 1 shortened by 1 mm.
        let r = PlanarView::paper();
        let (ds, sol) = deviation(
            &Model::from_planar(&r),
            &[0.0; 3],
            &[-1e-3, 0.0, 0.0],
            None,
            CableMethod::Newton,
            &SolveOptions::default(),
            1,
        )
        .unwrap();
        assert!(sol.converged[0]);
        assert!((ds[0] * 1e3 - (-0.0415)).abs() < 2e-4, "{}", ds[0] * 1e3);
        assert!((ds[1] * 1e3 - 2.4299).abs() < 2e-4, "{}", ds[1] * 1e3);
    }

    #[test]
    fn monte_carlo_of_one_sample_is_the_deviation() {
        let r = PlanarView::paper();
        let th = [0.1, -0.2, 0.3, -0.4, 0.2, 0.1];
        let dl = [5e-4, -3e-4, 2e-4];
        let dh = [1e-4, -2e-4, 3e-4];
        let mut holes = vec![0.0; r.holes.len()];
        r.hole_height_error_into(&dh, &mut holes);
        let opts = SolveOptions::default();
        let m = Model::from_planar(&r);
        let (ds, _) = deviation(&m, &th, &dl, Some(&holes), CableMethod::Auto, &opts, 2).unwrap();
        let st = monte_carlo(
            &m,
            &th,
            &dl,
            HoleErrors::PerPair(&dh),
            CableMethod::Auto,
            &opts,
            false,
            2,
        )
        .unwrap();
        for j in 0..2 {
            for q in 0..3 {
                assert!((st.sum[j * 4 + q] - ds[j * 3 + q]).abs() < 1e-15);
            }
            assert_eq!(st.count[j], 1);
        }
    }

    /// A spatial arm's deviation (one call for both kinds) is the general
    /// Monte Carlo of one sample: its position change and the length of its
    /// rotation vector; hole errors move the arm; `dh` is refused by the kind.
    #[test]
    fn spatial_deviation_is_the_monte_carlo_of_one_sample() {
        let model =
            Model::from_toml(include_str!("../python/cdsm/robots/two_universal.toml")).unwrap();
        let (n, m) = (model.n(), model.position_cables().len());
        let th: Vec<f64> = (0..2 * n)
            .map(|k| 0.05 * (k as f64 + 1.0) * if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let dl: Vec<f64> = (0..m).map(|k| 2e-4 * (k as f64 - 1.0)).collect();
        let nominal = model.flat_holes();
        let dholes: Vec<f64> = (0..nominal.len())
            .map(|k| 1e-4 * ((k % 7) as f64 - 3.0))
            .collect();
        let moved: Vec<f64> = nominal.iter().zip(&dholes).map(|(a, b)| a + b).collect();
        let opts = SolveOptions::default();
        let method = CableMethod::Auto;
        for holes in [None, Some(&moved[..])] {
            let (ds, sol) = deviation(&model, &th, &dl, holes, method, &opts, 1).unwrap();
            assert_eq!(ds.len(), 2 * 6);
            let errors = match holes {
                None => HoleErrors::None,
                Some(_) => HoleErrors::Full(&dholes),
            };
            let st = monte_carlo(&model, &th, &dl, errors, method, &opts, false, 1).unwrap();
            assert_eq!(st.quantities, 5);
            for j in 0..2 {
                assert!(sol.converged[j]);
                let d = &ds[j * 6..(j + 1) * 6];
                for (q, dq) in d[..3].iter().enumerate() {
                    assert!((st.sum[j * 5 + q] - dq).abs() < 1e-15, "{j} {q}");
                }
                let rot = (d[3] * d[3] + d[4] * d[4] + d[5] * d[5]).sqrt();
                assert!(rot > 1e-6 && (st.sum[j * 5 + 4] - rot).abs() < 1e-14 * rot.max(1.0));
            }
        }
        let err = HoleErrors::of(&model, Some(&dl), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("dh") && err.contains("planar"), "{err}");
        let planar = Model::from_planar(&PlanarView::paper());
        assert!(matches!(
            HoleErrors::of(&planar, Some(&dl), None),
            Ok(HoleErrors::PerPair(_))
        ));
    }

    #[test]
    fn monte_carlo_with_enforced_limits_counts_as_the_solver() {
        // a configuration 1 mrad inside joint 1's upper limit: of +-1 mm on
        // cable 1 (about +-33 mrad on joint 1) one sample ends past the limit
        let r = PlanarView::paper();
        let hi = r.joint_limits[0][1];
        let th = [hi - 1e-3, 0.0, 0.0, 0.0, 0.1, -0.1];
        let dl = [1e-3, 0.0, 0.0, -1e-3, 0.0, 0.0];
        let opts = SolveOptions {
            enforce_limits: true,
            ..SolveOptions::default()
        };
        let method = CableMethod::ClosedForm;
        let m = Model::from_planar(&r);
        let st = monte_carlo(&m, &th, &dl, HoleErrors::None, method, &opts, false, 1).unwrap();
        let g = CableGeometry::new(&r, None);
        for j in 0..2 {
            let t0 = &th[j * 3..(j + 1) * 3];
            let mut l = [0.0; 6];
            g.lengths(t0, &mut l);
            let solved = (0..2)
                .filter(|s| {
                    let d = &dl[s * 3..(s + 1) * 3];
                    let target = [l[0] + d[0], l[2] + d[1], l[4] + d[2]];
                    let mut x = t0.to_vec();
                    crate::solve::solve_cables(&r, &g, &target, &mut x, method, &opts).converged
                })
                .count() as u64;
            assert_eq!(st.count[j], solved, "configuration {j}");
            assert_eq!(st.count[j] + st.failed[j], 2);
        }
        assert_eq!(st.count, [1, 2]);
    }

    #[test]
    fn bin_windows_count_as_a_dense_histogram() {
        // two blocks; bins in no order, one repeated; the third configuration empty
        let bins = [900, 905, 2, HIST_BINS - 1, 0, 1500, 905, 37];
        let mut dense = vec![0u64; HIST_BINS];
        let mut st = McStats::new(4);
        st.open(0, 3);
        for (i, b) in bins.iter().enumerate() {
            dense[*b] += 1;
            st.add_to_hist(
                i % 2,
                hist_edges()[b.max(&1) - 1] * if *b == 0 { 0.5 } else { 1.0 },
            );
        }
        st.close();
        st.open(3, 1);
        st.add_to_hist(3, hist_edges()[699]);
        st.close();
        dense[700] += 1;
        let (lo, width, counts) = st.hist_window();
        assert_eq!((lo, width), (0, HIST_BINS));
        let mut summed = vec![0u64; HIST_BINS];
        for row in counts.chunks_exact(width) {
            for (s, c) in summed[lo..].iter_mut().zip(row) {
                *s += u64::from(*c);
            }
        }
        assert_eq!(summed, dense);
        assert!(counts[2 * width..3 * width].iter().all(|c| *c == 0));
        assert_eq!(
            st.hist[3],
            BinWindow {
                lo: 700,
                counts: vec![1]
            }
        );
        let mut one = McStats::new(2);
        one.open(0, 2);
        one.add_to_hist(1, hist_edges()[699]);
        one.add_to_hist(1, hist_edges()[701]);
        one.close();
        assert_eq!(one.hist_window(), (700, 3, vec![0, 0, 0, 1, 0, 1]));
        assert_eq!(McStats::new(2).hist_window(), (0, 0, Vec::new()));
        assert!(check_samples(u32::MAX as usize).is_ok());
        assert!(check_samples(u32::MAX as usize + 1).is_err());
    }

    #[test]
    fn histogram_bins_follow_the_edges() {
        let e = hist_edges();
        assert_eq!(e.len(), HIST_BINS - 1);
        assert_eq!(hist_bin(0.0), 0);
        assert_eq!(hist_bin(1e-9), 1);
        assert_eq!(hist_bin(10.0), HIST_BINS - 1);
        for (k, w) in e.windows(2).enumerate() {
            // the estimate is the bin or a neighbour (one comparison each way
            // corrects it), at the edges and inside the bin
            for v in [
                w[0],
                w[1] * (1.0 - 1e-15),
                w[0] * 0.7 + w[1] * 0.3,
                w[0] * 0.2 + w[1] * 0.8,
            ] {
                assert!(bin_estimate(v).abs_diff(k + 1) <= 1, "{v}: bin {}", k + 1);
            }
            // every edge starts its bin; just below it is the previous bin
            assert_eq!(hist_bin(w[0]), k + 1);
            assert_eq!(hist_bin(w[1] * (1.0 - 1e-15)), k + 1);
            assert_eq!(hist_bin(0.5 * (w[0] + w[1])), k + 1);
        }
    }
}
