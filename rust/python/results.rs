//! The named results that cross the boundary: one class per kind of result,
//! its fields NumPy arrays (flat, row-major; the Python front reshapes them)
//! or numbers. Built once from the core's result structs.

use super::convert::vec1;
use crate::accuracy::McStats;
use crate::compensate::Compensation;
use crate::elastic::{Derivatives, Equilibria};
use crate::fit::FitResult;
use crate::fit::Predictions;
use crate::plant::ElasticSolution;
use crate::rows::BatchSolution;
use crate::sensitivity::Sensitivities;
use numpy::PyArray1;
use pyo3::prelude::*;

type A<T> = Py<PyArray1<T>>;

fn arr<T: numpy::Element>(py: Python<'_>, v: Vec<T>) -> A<T> {
    vec1(py, v).unbind()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<SolveResult>()?;
    m.add_class::<DeviationResult>()?;
    m.add_class::<MonteCarloStats>()?;
    m.add_class::<SensitivityResult>()?;
    m.add_class::<ElasticResult>()?;
    m.add_class::<PlantPrediction>()?;
    m.add_class::<PlantFit>()?;
    m.add_class::<CompensationResult>()?;
    m.add_class::<TensionResult>()?;
    m.add_class::<EquilibriumResult>()?;
    m.add_class::<EquilibriumDerivatives>()?;
    Ok(())
}

/// Solves of a batch: `theta (N*n)` rad, `converged`, `iterations`,
/// `residual` (m or rad), `within_limits`, `reason` (codes of `REASONS`).
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct SolveResult {
    pub theta: A<f64>,
    pub converged: A<bool>,
    pub iterations: A<u32>,
    pub residual: A<f64>,
    pub within_limits: A<bool>,
    pub reason: A<u8>,
}

impl SolveResult {
    pub fn new(py: Python<'_>, s: BatchSolution) -> SolveResult {
        SolveResult {
            theta: arr(py, s.theta),
            converged: arr(py, s.converged),
            iterations: arr(py, s.iterations),
            residual: arr(py, s.residual),
            within_limits: arr(py, s.within_limits),
            reason: arr(py, s.reason),
        }
    }
}

/// End deviations `ds (N*task)` (planar m, m, rad; spatial m and the
/// rotation vector, rad) and the perturbed solves.
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct DeviationResult {
    pub ds: A<f64>,
    pub solution: Py<SolveResult>,
}

impl DeviationResult {
    pub fn new(py: Python<'_>, ds: Vec<f64>, s: BatchSolution) -> PyResult<DeviationResult> {
        Ok(DeviationResult {
            ds: arr(py, ds),
            solution: Py::new(py, SolveResult::new(py, s))?,
        })
    }
}

/// Per-configuration Monte-Carlo statistics (see `accuracy.rs`).
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct MonteCarloStats {
    pub quantities: usize,
    pub count: A<u64>,
    pub failed: A<u64>,
    pub sum: A<f64>,
    pub sum_sq: A<f64>,
    pub min: A<f64>,
    pub max: A<f64>,
    /// `(N * hist_width)` counts of the histogram bins `hist_lo..hist_lo + hist_width`
    pub hist: A<u32>,
    pub hist_lo: usize,
    pub hist_width: usize,
    pub slack: A<u64>,
}

impl MonteCarloStats {
    pub fn new(py: Python<'_>, s: McStats) -> MonteCarloStats {
        let (hist_lo, hist_width, hist) = s.hist_window();
        MonteCarloStats {
            quantities: s.quantities,
            count: arr(py, s.count),
            failed: arr(py, s.failed),
            sum: arr(py, s.sum),
            sum_sq: arr(py, s.sum_sq),
            min: arr(py, s.min),
            max: arr(py, s.max),
            hist: arr(py, hist),
            hist_lo,
            hist_width,
            slack: arr(py, s.slack),
        }
    }
}

/// Tip sensitivities, either kind: `cable (N*task*m_pos)`, `groups
/// (N*task*G)` (the coherent hole groups), `coords (N*task*3H)` or None,
/// `ok (N)`.
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct SensitivityResult {
    pub cable: A<f64>,
    pub groups: A<f64>,
    pub coords: Option<A<f64>>,
    pub ok: A<bool>,
}

impl SensitivityResult {
    pub fn new(py: Python<'_>, s: Sensitivities, coords: bool) -> SensitivityResult {
        SensitivityResult {
            cable: arr(py, s.cable),
            groups: arr(py, s.groups),
            coords: coords.then(|| arr(py, s.coords)),
            ok: arr(py, s.ok),
        }
    }
}

/// Elastic solves: the solves, upper tensions `(N*n)` N, taut flags `(N)`.
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct ElasticResult {
    pub solution: Py<SolveResult>,
    pub tension: A<f64>,
    pub feasible: A<bool>,
}

impl ElasticResult {
    pub fn new(py: Python<'_>, e: ElasticSolution) -> PyResult<ElasticResult> {
        Ok(ElasticResult {
            solution: Py::new(py, SolveResult::new(py, e.solution))?,
            tension: arr(py, e.tension),
            feasible: arr(py, e.feasible),
        })
    }
}

/// Plant predictions: `observation (K*N*3)`, `converged (K*N)`, `theta
/// (K*N*n)` rad, and `jacobian (N*3*k)` when linearised (else None).
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct PlantPrediction {
    pub observation: A<f64>,
    pub converged: A<bool>,
    pub theta: A<f64>,
    /// Codes of `plant::REASONS` (`PLANT_REASONS`).
    pub reason: A<u8>,
    pub jacobian: Option<A<f64>>,
}

impl PlantPrediction {
    pub fn new(py: Python<'_>, p: Predictions, jacobian: Option<Vec<f64>>) -> PlantPrediction {
        PlantPrediction {
            observation: arr(py, p.observation),
            converged: arr(py, p.converged),
            theta: arr(py, p.theta),
            reason: arr(py, p.reason),
            jacobian: jacobian.map(|j| arr(py, j)),
        }
    }
}

/// One fitted plant: `p (P)`, `converged`, `iterations`, `cost` (m²), `m`
/// residual components, `r_factor (min(m, k)*k)`: the triangular factor of the
/// residual's Jacobian in scaled parameters (`J^T J = R^T R`), `reason`, and
/// its `prediction` of every row.
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct PlantFit {
    pub p: A<f64>,
    pub converged: bool,
    pub iterations: u32,
    pub cost: f64,
    pub m: usize,
    pub r_factor: A<f64>,
    pub reason: u8,
    pub prediction: Py<PlantPrediction>,
}

impl PlantFit {
    pub fn new(py: Python<'_>, f: FitResult) -> PyResult<PlantFit> {
        Ok(PlantFit {
            p: arr(py, f.p),
            converged: f.converged,
            iterations: f.iterations,
            cost: f.cost,
            m: f.m,
            r_factor: arr(py, f.r_factor),
            reason: f.reason,
            prediction: Py::new(py, PlantPrediction::new(py, f.predictions, None))?,
        })
    }
}

/// Compensated commands (see `compensate.rs`): `command`, `nominal`, `theta`
/// `(N*n)`, `converged`, `residual` `(N)`, `seen`, `seen_nominal` `(N*3)`.
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct CompensationResult {
    pub command: A<f64>,
    pub nominal: A<f64>,
    pub converged: A<bool>,
    pub residual: A<f64>,
    pub theta: A<f64>,
    pub seen: A<f64>,
    pub seen_nominal: A<f64>,
}

impl CompensationResult {
    pub fn new(py: Python<'_>, c: Compensation) -> CompensationResult {
        CompensationResult {
            command: arr(py, c.command),
            nominal: arr(py, c.nominal),
            converged: arr(py, c.converged),
            residual: arr(py, c.residual),
            theta: arr(py, c.theta),
            seen: arr(py, c.seen),
            seen_nominal: arr(py, c.seen_nominal),
        }
    }
}

/// Statics of a spatial arm: `tension (N*m_pos)` N (NaN where no tension set
/// above the floor exists) and `feasible (N)`.
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct TensionResult {
    pub tension: A<f64>,
    pub feasible: A<bool>,
}

impl TensionResult {
    pub fn new(py: Python<'_>, tension: Vec<f64>, feasible: Vec<bool>) -> TensionResult {
        TensionResult {
            tension: arr(py, tension),
            feasible: arr(py, feasible),
        }
    }
}

/// Frictionless equilibria of an elastic arm (`crate::elastic`), row-major:
/// `theta (N*n)` rad, `tension (N*m)` N, `slack`, `capped (N*m)`,
/// `converged`, `reason` (codes of `ELASTIC_REASONS`), `iterations`,
/// `gradient` (N m, max |dU/dq|), `energy` (J).
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct EquilibriumResult {
    pub theta: A<f64>,
    pub tension: A<f64>,
    pub slack: A<bool>,
    pub capped: A<bool>,
    pub converged: A<bool>,
    pub reason: A<u8>,
    pub iterations: A<u32>,
    pub gradient: A<f64>,
    pub energy: A<f64>,
}

impl EquilibriumResult {
    pub fn new(py: Python<'_>, e: Equilibria) -> EquilibriumResult {
        EquilibriumResult {
            theta: arr(py, e.theta),
            tension: arr(py, e.tension),
            slack: arr(py, e.slack),
            capped: arr(py, e.capped),
            converged: arr(py, e.converged),
            reason: arr(py, e.reason),
            iterations: arr(py, e.iterations),
            gradient: arr(py, e.gradient),
            energy: arr(py, e.energy),
        }
    }
}

/// Derivatives of equilibria by the implicit function theorem, row-major
/// per row (`crate::elastic::Derivatives`): `theta_*` `(n, p)`, `task_*`
/// `(t, p)`, `tension_*` `(m, p)` for `p` the lengths, displacements and
/// wrench rows; `definite (N,)`.
#[pyclass(frozen, get_all, module = "cdsm._cdsm")]
pub struct EquilibriumDerivatives {
    pub theta_lengths: A<f64>,
    pub theta_displacements: A<f64>,
    pub theta_wrench: A<f64>,
    pub task_lengths: A<f64>,
    pub task_displacements: A<f64>,
    pub task_wrench: A<f64>,
    pub tension_lengths: A<f64>,
    pub tension_displacements: A<f64>,
    pub tension_wrench: A<f64>,
    pub definite: A<bool>,
}

impl EquilibriumDerivatives {
    pub fn new(py: Python<'_>, d: Derivatives) -> EquilibriumDerivatives {
        EquilibriumDerivatives {
            theta_lengths: arr(py, d.theta_lengths),
            theta_displacements: arr(py, d.theta_displacements),
            theta_wrench: arr(py, d.theta_wrench),
            task_lengths: arr(py, d.task_lengths),
            task_displacements: arr(py, d.task_displacements),
            task_wrench: arr(py, d.task_wrench),
            tension_lengths: arr(py, d.tension_lengths),
            tension_displacements: arr(py, d.tension_displacements),
            tension_wrench: arr(py, d.tension_wrench),
            definite: arr(py, d.definite),
        }
    }
}
