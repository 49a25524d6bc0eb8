//! The diagnosis fit: the parameters of chosen plant effects that make a
//! plant's predictions meet the measurements, by the shared solver
//! ([`crate::lm`], QR step, Marquardt damping) in parameters scaled by their
//! typical size, within the plant's physical domain, with an active set on
//! its bounds. Any plant that implements [`FitModel`] is fitted the same
//! way (the one plant of either kind: [`crate::plant::PlantFit`], exact
//! Jacobians). Cross-validation folds are fitted in one call, in parallel.
//!
//! Residual: for every scored row and every measured component,
//! `w_c (prediction - measurement)` with the model's weights (an attitude
//! error counts as the tip displacement it causes: the straight arm length
//! times the angle); components not measured are NaN in `measured` and left
//! out.

use crate::error::{CdsmError, Result};
use crate::lm::{self, Damping, Lm, Problem, Step, Workspace};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Predictions of `K` plants for one data set: observations `(K, N, TASK)`
/// (NaN for unmeasured rows and rows that did not settle), converged
/// `(K, N)`, and the configuration each row's last command settles at
/// `(K, N, n)` (rad); why each row did not settle (`(K, N)`, codes of
/// [`crate::plant::REASONS`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Predictions {
    pub observation: Vec<f64>,
    pub converged: Vec<bool>,
    pub theta: Vec<f64>,
    pub reason: Vec<u8>,
}

/// A plant the diagnosis can fit: predictions of a data set's rows for a
/// flat parameter vector, and their derivatives with respect to some of the
/// parameters.
pub trait FitModel: Sync {
    /// What a settle leaves for the Jacobian at the same parameters.
    type State;
    /// Rows of the data set.
    fn rows(&self) -> usize;
    /// Observed components per row.
    fn width(&self) -> usize;
    /// Residual weight of each component (m per unit of the component).
    fn weights(&self) -> Vec<f64>;
    /// Length of the flat parameter vector.
    fn params(&self) -> usize;
    /// The physical domain: `[lower, upper]` per parameter.
    fn bounds(&self) -> (Vec<f64>, Vec<f64>);
    /// Every row settled with parameters `p`; `None` outside the domain.
    fn settle(&self, p: &[f64]) -> Option<Self::State>;
    /// The rows' predictions (`observation (rows, width)`, NaN where a row
    /// did not settle, and the flags).
    fn predictions(&self, state: &Self::State) -> Predictions;
    /// `(rows, width, k)` derivatives of the predictions with respect to the
    /// parameters `free` at `p` (the state of [`FitModel::settle`] at `p`),
    /// of the rows flagged in `rows` (`(rows,)`; the others' may be NaN).
    fn jacobian(
        &self,
        p: &[f64],
        state: &Self::State,
        free: &[usize],
        rows: &[bool],
    ) -> Option<Vec<f64>>;
    /// Whether a settle costs enough (an elastic arm's statics) that the fit
    /// also stops at a step small against the parameters' standard errors
    /// ([`SE_STEP`]); false: at [`MIN_DECREASE`] alone.
    fn costly(&self) -> bool {
        false
    }
}

/// The fit stops converged when an accepted step lowers the cost by less than
/// this fraction.
pub const MIN_DECREASE: f64 = 1e-7;

/// A costly plant's fit ([`FitModel::costly`]) also stops converged when an
/// accepted step moved every parameter by at most this fraction of its
/// standard error at the new point, `sigma sqrt((J^T J)^-1_ii)` with `sigma^2
/// = S / (m - k)` (`S` the cost, `m` residuals, `k` parameters; the fit's
/// own covariance, [`FitResult::r_factor`]): the steps left move the answer
/// by less than its uncertainty can tell.
pub const SE_STEP: f64 = 0.1;

/// What to fit and where.
pub struct FitSpec<'a, M: FitModel> {
    pub model: &'a M,
    /// `(N, width)` measured components; NaN: not measured.
    pub measured: &'a [f64],
    /// Indices of the fitted parameters in the flat vector.
    pub free: &'a [usize],
    /// Typical size of each fitted parameter (its unit in the solver).
    pub scale: &'a [f64],
    /// The flat parameter vector the fitted ones start from (the others stay).
    pub start: &'a [f64],
    /// Maximum number of trial steps of the fit.
    pub max_iter: u32,
}

/// A fitted plant.
#[derive(Debug, Clone, Default)]
pub struct FitResult {
    /// The flat parameter vector at the answer.
    pub p: Vec<f64>,
    pub converged: bool,
    pub iterations: u32,
    /// Sum of squared weighted residuals on the scored rows (m²).
    pub cost: f64,
    /// Number of residual components scored.
    pub m: usize,
    /// `(min(m, k), k)` triangular factor `R` of the residual's Jacobian in
    /// scaled parameters at the answer (`J^T J = R^T R`).
    pub r_factor: Vec<f64>,
    /// The plant's predictions of every row at the answer.
    pub predictions: Predictions,
    /// Why the solve ended ([`crate::lm::Reason`] as u8).
    pub reason: u8,
}

/// The fit as a problem of the shared solver.
struct FitProblem<'a, M: FitModel> {
    spec: &'a FitSpec<'a, M>,
    /// (row, component) of every residual.
    index: Vec<(usize, usize)>,
    weight: Vec<f64>,
    /// The rows with a residual (the Jacobian's rows needed).
    rows: Vec<bool>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    p: Vec<f64>,
    last: Option<(Vec<f64>, M::State)>,
}

impl<'a, M: FitModel> FitProblem<'a, M> {
    fn new(spec: &'a FitSpec<'a, M>, scored: &[bool]) -> FitProblem<'a, M> {
        let w = spec.model.width();
        let mut index = Vec::new();
        for (i, s) in scored.iter().enumerate() {
            if *s {
                for c in 0..w {
                    if spec.measured[i * w + c].is_finite() {
                        index.push((i, c));
                    }
                }
            }
        }
        let mut rows = vec![false; scored.len()];
        for (i, _) in &index {
            rows[*i] = true;
        }
        let (blo, bhi) = spec.model.bounds();
        let lo = spec
            .free
            .iter()
            .zip(spec.scale)
            .map(|(f, s)| blo[*f] / s)
            .collect();
        let hi = spec
            .free
            .iter()
            .zip(spec.scale)
            .map(|(f, s)| bhi[*f] / s)
            .collect();
        FitProblem {
            spec,
            index,
            weight: spec.model.weights(),
            rows,
            lo,
            hi,
            p: spec.start.to_vec(),
            last: None,
        }
    }

    fn params(&mut self, z: &[f64]) {
        for ((f, s), zi) in self.spec.free.iter().zip(self.spec.scale).zip(z) {
            self.p[*f] = zi * s;
        }
    }
}

impl<M: FitModel> Problem for FitProblem<'_, M> {
    fn dims(&self) -> (usize, usize) {
        (self.index.len(), self.spec.free.len())
    }

    fn jacobian_with_residual(&self) -> bool {
        false
    }

    fn eval(&mut self, z: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        self.params(z);
        let model = self.spec.model;
        let w = model.width();
        let Some(state) = model.settle(&self.p) else {
            return false;
        };
        let pred = model.predictions(&state);
        for (k, &(i, c)) in self.index.iter().enumerate() {
            if !pred.converged[i] {
                return false;
            }
            r[k] = self.weight[c] * (pred.observation[i * w + c] - self.spec.measured[i * w + c]);
        }
        self.last = Some((self.p.clone(), state));
        match jac {
            Some(j) => self.jacobian(z, j),
            None => true,
        }
    }

    fn jacobian(&mut self, z: &[f64], jac: &mut [f64]) -> bool {
        self.params(z);
        let spec = self.spec;
        let w = spec.model.width();
        let Some((p, state)) = self.last.as_ref() else {
            return false;
        };
        if *p != self.p {
            return false;
        }
        let Some(dj) = spec.model.jacobian(p, state, spec.free, &self.rows) else {
            return false;
        };
        let k = spec.free.len();
        for (row, &(i, c)) in self.index.iter().enumerate() {
            for q in 0..k {
                jac[row * k + q] = self.weight[c] * dj[(i * w + c) * k + q] * spec.scale[q];
            }
        }
        jac.iter().all(|v| v.is_finite())
    }

    fn small_step(&self, from: &[f64], to: &[f64], jac: &[f64], cost: f64) -> bool {
        self.spec.model.costly() && within_errors(from, to, jac, cost)
    }

    fn project(&self, z: &mut [f64]) {
        for ((v, l), h) in z.iter_mut().zip(&self.lo).zip(&self.hi) {
            *v = v.clamp(*l, *h);
        }
    }

    fn bounded(&self) -> bool {
        true
    }

    fn blocked(&self, z: &[f64], k: usize, toward: f64) -> bool {
        (toward < 0.0 && z[k] <= self.lo[k]) || (toward > 0.0 && z[k] >= self.hi[k])
    }
}

/// The solver settings of the fit.
fn fit_lm(max_iter: u32) -> Lm {
    Lm {
        step: Step::Qr,
        damping: Damping::Marquardt,
        tol: 0.0,
        max_iter,
        lambda0: 1e-3,
        min_decrease: MIN_DECREASE,
    }
}

/// Whether the step `from -> to` (scaled parameters) moved every parameter
/// by at most [`SE_STEP`] of its standard error at `to` (`jac (m, k)`,
/// `cost` there). Parameters the residual does not see (a zero column) are
/// left out; false where `J^T J` of the others is not positive definite.
fn within_errors(from: &[f64], to: &[f64], jac: &[f64], cost: f64) -> bool {
    let k = from.len();
    let m = jac.len() / k.max(1);
    if m <= k {
        return false;
    }
    let seen: Vec<usize> = (0..k)
        .filter(|&c| (0..m).any(|i| jac[i * k + c] != 0.0))
        .collect();
    let s = seen.len();
    let mut a = vec![0.0; s * s];
    for row in jac.chunks_exact(k) {
        for (x, &i) in seen.iter().enumerate() {
            let ri = row[i];
            if ri == 0.0 {
                continue;
            }
            for (y, &j) in seen.iter().enumerate().take(x + 1) {
                a[x * s + y] += ri * row[j];
            }
        }
    }
    // Cholesky (lower), then the diagonal of the inverse column by column
    for j in 0..s {
        let mut d = a[j * s + j];
        for p in 0..j {
            d -= a[j * s + p] * a[j * s + p];
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        a[j * s + j] = d;
        for i in j + 1..s {
            let mut v = a[i * s + j];
            for p in 0..j {
                v -= a[i * s + p] * a[j * s + p];
            }
            a[i * s + j] = v / d;
        }
    }
    let sigma2 = cost / (m - k) as f64;
    let mut e = vec![0.0; s];
    for (x, &i) in seen.iter().enumerate() {
        // (J^T J)^-1_xx = |L^-1 e_x|^2
        e.iter_mut().for_each(|v| *v = 0.0);
        e[x] = 1.0;
        for r in x..s {
            let mut v = e[r];
            for p in x..r {
                v -= a[r * s + p] * e[p];
            }
            e[r] = v / a[r * s + r];
        }
        let var = sigma2 * e[x..].iter().map(|v| v * v).sum::<f64>();
        let within = (to[i] - from[i]).abs() <= SE_STEP * var.sqrt();
        if !within {
            return false;
        }
    }
    true
}

/// Fits the free parameters on the rows `scored` (N,).
pub fn fit<M: FitModel>(spec: &FitSpec<M>, scored: &[bool]) -> Result<FitResult> {
    check(spec, scored)?;
    Ok(fit_one(spec, scored))
}

fn check<M: FitModel>(spec: &FitSpec<M>, scored: &[bool]) -> Result<()> {
    let n_rows = spec.model.rows();
    let w = spec.model.width();
    let total = spec.model.params();
    let bad = |name: &str, problem: String| {
        Err(CdsmError::Option {
            name: name.into(),
            problem,
        })
    };
    if spec.measured.len() != w * n_rows {
        return bad(
            "measured",
            format!("needs ({n_rows}, {w}) values, got {}", spec.measured.len()),
        );
    }
    if scored.len() != n_rows {
        return bad(
            "scored",
            format!("needs {n_rows} flags, got {}", scored.len()),
        );
    }
    if spec.start.len() != total {
        return bad(
            "start",
            format!("needs {total} parameters, got {}", spec.start.len()),
        );
    }
    if spec.scale.len() != spec.free.len()
        || spec.scale.iter().any(|s| !(*s > 0.0 && s.is_finite()))
    {
        return bad(
            "scale",
            "needs one positive finite scale per free parameter".into(),
        );
    }
    if let Some(f) = spec.free.iter().find(|f| **f >= total) {
        return bad(
            "free",
            format!("parameter index {f} is beyond the {total} parameters"),
        );
    }
    Ok(())
}

fn fit_one<M: FitModel>(spec: &FitSpec<M>, scored: &[bool]) -> FitResult {
    let mut prob = FitProblem::new(spec, scored);
    if spec.free.is_empty() {
        let mut r = vec![0.0; prob.index.len()];
        let ok = prob.eval(&[], &mut r, None);
        let predictions = prob
            .last
            .as_ref()
            .map(|(_, s)| spec.model.predictions(s))
            .unwrap_or_default();
        return FitResult {
            p: spec.start.to_vec(),
            converged: ok,
            iterations: 0,
            cost: if ok {
                r.iter().map(|v| v * v).sum()
            } else {
                f64::NAN
            },
            m: r.len(),
            r_factor: Vec::new(),
            predictions,
            reason: if ok {
                lm::Reason::Converged
            } else {
                lm::Reason::Singular
            } as u8,
        };
    }
    let mut z: Vec<f64> = spec
        .free
        .iter()
        .zip(spec.scale)
        .map(|(f, s)| spec.start[*f] / s)
        .collect();
    prob.project(&mut z);
    let mut ws = Workspace::default();
    let st = lm::solve(&mut prob, &mut z, &fit_lm(spec.max_iter), &mut ws);
    prob.params(&z);
    let p = prob.p.clone();
    // the last evaluation's settle when it was at the answer (settling is a
    // function of the parameters), else one more
    let predictions = match prob.last.as_ref().filter(|(q, _)| *q == p) {
        Some((_, state)) => spec.model.predictions(state),
        None => match spec.model.settle(&p) {
            Some(state) => spec.model.predictions(&state),
            None => Predictions::default(),
        },
    };
    FitResult {
        p,
        converged: st.converged,
        iterations: st.iterations,
        cost: st.cost,
        m: prob.index.len(),
        r_factor: lm::r_factor(ws.jacobian(), prob.index.len(), spec.free.len()),
        predictions,
        reason: st.reason as u8,
    }
}

/// Fits the free parameters once per fold (`scored`: `(F, N)` flags, the
/// rows each fold trains on), folds in parallel over `threads`.
pub fn fit_folds<M: FitModel>(
    spec: &FitSpec<M>,
    scored: &[bool],
    threads: usize,
) -> Result<Vec<FitResult>> {
    let folds = scored.len() / spec.model.rows().max(1);
    fit_each(std::slice::from_ref(spec), &vec![0; folds], scored, threads)
}

/// Fits of several candidates on one data set: fit `f` fits the free
/// parameters of `specs[which[f]]` on the rows `scored[f]` (`scored`: `(F,
/// N)` flags, `which`: `(F,)`; the specs share the model). The fits run in
/// parallel over `threads`, each thread taking the next fit not yet taken
/// (fits differ in cost: a fixed share per thread would leave threads
/// idle); each fit's result does not depend on the threads.
pub fn fit_each<M: FitModel>(
    specs: &[FitSpec<M>],
    which: &[usize],
    scored: &[bool],
    threads: usize,
) -> Result<Vec<FitResult>> {
    let Some(first) = specs.first() else {
        return Err(CdsmError::Option {
            name: "free".into(),
            problem: "needs at least one set of free parameters".into(),
        });
    };
    let n_rows = first.model.rows();
    if n_rows == 0 || !scored.len().is_multiple_of(n_rows) {
        return Err(CdsmError::Shape {
            name: "scored".into(),
            expected: format!("(F, {n_rows}) flags"),
            got: format!("{} values", scored.len()),
        });
    }
    let folds = scored.len() / n_rows;
    if which.len() != folds {
        return Err(CdsmError::Shape {
            name: "candidate".into(),
            expected: format!("{folds} indices, one per fit"),
            got: format!("{} values", which.len()),
        });
    }
    if let Some(c) = which.iter().find(|c| **c >= specs.len()) {
        return Err(CdsmError::Option {
            name: "candidate".into(),
            problem: format!(
                "index {c} is beyond the {} sets of free parameters",
                specs.len()
            ),
        });
    }
    for f in 0..folds {
        check(&specs[which[f]], &scored[f * n_rows..(f + 1) * n_rows])?;
    }
    Ok(queued(folds, threads, |f| {
        fit_one(&specs[which[f]], &scored[f * n_rows..(f + 1) * n_rows])
    }))
}

/// `work(0..count)` in order, over up to `threads` threads that each take
/// the next index not yet taken; the calling thread works too (and alone
/// where no thread can start).
fn queued<T: Send>(count: usize, threads: usize, work: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = crate::rows::resolve_threads(threads).min(count.max(1));
    if threads <= 1 {
        return (0..count).map(work).collect();
    }
    let next = AtomicUsize::new(0);
    let take = || {
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= count {
                return done;
            }
            done.push((i, work(i)));
        }
    };
    let mut out: Vec<Option<T>> = (0..count).map(|_| None).collect();
    std::thread::scope(|s| {
        let helpers: Vec<_> = (1..threads)
            .filter_map(|_| std::thread::Builder::new().spawn_scoped(s, take).ok())
            .collect();
        let mut parts = vec![take()];
        parts.extend(
            helpers
                .into_iter()
                .map(|h| h.join().expect("worker thread panicked")),
        );
        for (i, v) in parts.into_iter().flatten() {
            out[i] = Some(v);
        }
    });
    out.into_iter()
        .map(|v| v.expect("every index is taken once"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::Planar;
    use crate::model::Model;
    use crate::plant::{layout, predict, Effect, PlantFit, Reading, Rows, Sequence};
    use crate::robot::PlanarView;
    use crate::solve::SolveOptions;

    #[test]
    fn a_step_is_within_errors_below_a_tenth_of_a_standard_error() {
        // J = [1 0; 1 0; 1 0; 1 0] (the second parameter unseen), cost 2 on
        // 4 - 2 dof: sigma^2 = 1, the first parameter's error sqrt(1/4) = 0.5
        let jac = [1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0];
        assert!(within_errors(&[0.0, 0.0], &[0.049, 3.0], &jac, 2.0));
        assert!(!within_errors(&[0.0, 0.0], &[0.051, 3.0], &jac, 2.0));
        assert!(!within_errors(&[0.0, 0.0], &[-0.051, 0.0], &jac, 2.0));
        // no error (an exact fit): only no step is within it
        assert!(!within_errors(&[0.0, 0.0], &[1e-12, 0.0], &jac, 0.0));
    }

    #[test]
    fn a_hidden_effect_is_recovered_from_exact_data() {
        let r = Model::from_planar(&PlanarView::paper());
        let lay = layout(&r);
        let total = lay.total;
        let (scale, holes) = (
            lay.find(Effect::ActuationScale).unwrap().0,
            lay.find(Effect::HoleHeight).unwrap().0,
        );
        let off = [scale, 0, holes];
        let mut truth = vec![0.0; total];
        truth[off[2]] = 2e-4;
        truth[off[2] + 1] = -1e-4;
        truth[off[0]] = 0.02;
        let (th, dl, reading) = paper_commands();
        let rows = Rows {
            theta_cmd: &th,
            dl: &dl,
            reading: &reading,
        };
        let o = SolveOptions::default();
        let meas = predict(&r, &truth, &rows, &o, 1).unwrap().observation;
        let seq = Sequence::new(&r, &rows).unwrap();
        let free = [off[0], off[2], off[2] + 1, off[2] + 2];
        let model = PlantFit::<Planar>::new(&r, &seq, o);
        let spec = FitSpec {
            model: &model,
            measured: &meas,
            free: &free,
            scale: &[0.02, 2e-4, 2e-4, 2e-4],
            start: &vec![0.0; total],
            max_iter: 50,
        };
        let folds = [
            vec![true; 12],
            (0..12).map(|i| i % 3 != 0).collect::<Vec<_>>(),
        ]
        .concat();
        let res = fit_folds(&spec, &folds, 2).unwrap();
        for f in &res {
            assert!(f.converged, "{f:?}");
            for &i in &free {
                assert!(
                    (f.p[i] - truth[i]).abs() < 1e-9,
                    "{i}: {} vs {}",
                    f.p[i],
                    truth[i]
                );
            }
        }
    }

    /// 12 absolute rows of the paper arm: `theta_cmd (12, 3)` rad and `dl
    /// (12, 3)` m.
    fn paper_commands() -> (Vec<f64>, Vec<f64>, Vec<Reading>) {
        let (mut th, mut dl) = (Vec::new(), Vec::new());
        for i in 0..12 {
            let a = i as f64 * 0.37;
            th.extend_from_slice(&[
                0.4 * a.sin(),
                0.3 * (1.3 * a).cos(),
                -0.35 * (0.7 * a).sin(),
            ]);
            dl.extend_from_slice(&[1e-3 * (2.1 * a).sin(), 0.0, -5e-4 * a.cos()]);
        }
        let reading = vec![Reading::Absolute; 12];
        (th, dl, reading)
    }

    /// The paper arm on 12 absolute rows with two effects hidden: the
    /// model, the rows' sequence and their measurements.
    fn paper_rows() -> (Model, Sequence, Vec<f64>) {
        let r = Model::from_planar(&PlanarView::paper());
        let lay = layout(&r);
        let mut truth = vec![0.0; lay.total];
        truth[lay.find(Effect::HoleHeight).unwrap().0] = 2e-4;
        truth[lay.find(Effect::ActuationScale).unwrap().0] = 0.02;
        let (th, dl, reading) = paper_commands();
        let rows = Rows {
            theta_cmd: &th,
            dl: &dl,
            reading: &reading,
        };
        let meas = predict(&r, &truth, &rows, &SolveOptions::default(), 1)
            .unwrap()
            .observation;
        let seq = Sequence::new(&r, &rows).unwrap();
        (r, seq, meas)
    }

    #[test]
    fn candidates_fitted_together_equal_each_fitted_alone_whatever_the_threads() {
        let (r, seq, meas) = paper_rows();
        let model = PlantFit::<Planar>::new(&r, &seq, SolveOptions::default());
        let lay = layout(&r);
        let (scale, holes) = (
            lay.find(Effect::ActuationScale).unwrap().0,
            lay.find(Effect::HoleHeight).unwrap().0,
        );
        let start = vec![0.0; lay.total];
        let frees = [vec![scale], vec![holes, holes + 1, scale]];
        let scales = [vec![0.02], vec![2e-4, 2e-4, 0.02]];
        let specs: Vec<_> = frees
            .iter()
            .zip(&scales)
            .map(|(free, scale)| FitSpec {
                model: &model,
                measured: &meas,
                free,
                scale,
                start: &start,
                max_iter: 30,
            })
            .collect();
        let folds: Vec<Vec<bool>> = (0..3)
            .map(|f| (0..12).map(|i| f == 0 || i % 3 != f).collect())
            .collect();
        // fits 0..6: candidate 1, 0, 1, 0, 1, 0 on folds 0, 0, 1, 1, 2, 2
        let which = [1, 0, 1, 0, 1, 0];
        let scored: Vec<bool> = (0..6).flat_map(|f| folds[f / 2].clone()).collect();
        for threads in [1, 2, 5] {
            let together = fit_each(&specs, &which, &scored, threads).unwrap();
            for (f, got) in together.iter().enumerate() {
                let alone = fit_folds(&specs[which[f]], &folds[f / 2], 1).unwrap();
                let want = &alone[0];
                assert_eq!(got.p, want.p, "fit {f}, {threads} threads");
                assert_eq!(got.cost.to_bits(), want.cost.to_bits());
                assert_eq!(got.iterations, want.iterations);
                assert_eq!(got.r_factor, want.r_factor);
                assert_eq!(got.predictions, want.predictions);
            }
        }
        let bad = fit_each(&specs, &[0, 2, 0, 0, 0, 0], &scored, 2).unwrap_err();
        assert!(bad.to_string().contains("candidate"), "{bad}");
        let short = fit_each(&specs, &[0, 1], &scored, 2).unwrap_err();
        assert!(short.to_string().contains("candidate"), "{short}");
    }

    #[test]
    fn a_queue_keeps_the_order_of_its_work() {
        for threads in [1, 2, 7] {
            let out = queued(23, threads, |i| {
                // uneven work: later items finish first on other threads
                std::thread::sleep(std::time::Duration::from_micros(((23 - i) * 50) as u64));
                i * i
            });
            assert_eq!(out, (0..23).map(|i| i * i).collect::<Vec<_>>());
        }
        assert!(queued(0, 3, |i| i).is_empty());
    }

    #[test]
    fn the_jacobian_of_some_rows_equals_those_rows_of_the_whole() {
        let (r, seq, _) = paper_rows();
        let model = PlantFit::<Planar>::new(&r, &seq, SolveOptions::default());
        let lay = layout(&r);
        let mut p = vec![0.0; lay.total];
        p[lay.find(Effect::HoleHeight).unwrap().0] = 1e-4;
        let free: Vec<usize> = (0..lay.total).collect();
        let state = model.settle(&p).unwrap();
        let all = model.jacobian(&p, &state, &free, &[true; 12]).unwrap();
        let some: Vec<bool> = (0..12).map(|i| i % 4 != 1).collect();
        let part = model.jacobian(&p, &state, &free, &some).unwrap();
        let per = all.len() / 12;
        for (i, s) in some.iter().enumerate() {
            let (a, b) = (&all[i * per..(i + 1) * per], &part[i * per..(i + 1) * per]);
            if *s {
                assert!(
                    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "row {i}"
                );
                assert!(a.iter().all(|v| v.is_finite()));
            } else {
                assert!(b.iter().all(|v| v.is_nan()), "row {i} not derived");
            }
        }
    }
}
