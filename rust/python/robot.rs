//! `CoreRobot`: a validated robot and every batch call of the core on it,
//! with the GIL released around the work. The documented API is
//! `cdsm.Robot` and the Python modules that call these methods.

use super::convert::{err, ik_method, mask, method, opt_slice, options, slice, vec1, Arr, Array};
use super::plant::{self, Data, FitArgs};
use super::results::{
    CompensationResult, DeviationResult, ElasticResult, MonteCarloStats, PlantFit, PlantPrediction,
    SensitivityResult, SolveResult,
};
use crate::accuracy::{self, HoleErrors};
use crate::batch;
use crate::error::CdsmError;
use crate::model::Model;
use crate::robot::{CableMaterial, Robot};
use crate::statics::{self, BatchLoads};
use numpy::PyArray1;
use pyo3::prelude::*;

/// A validated robot (SI units); see `cdsm.Robot` for the documented API.
#[pyclass(frozen, module = "cdsm._cdsm")]
pub struct CoreRobot {
    inner: Robot,
    /// The same arm as the one model (the plant's).
    model: Model,
}

type ThetaMap = fn(&Robot, &[f64], usize) -> crate::Result<Vec<f64>>;

impl CoreRobot {
    fn of(inner: Robot) -> Self {
        CoreRobot {
            model: Model::from_planar(&inner),
            inner,
        }
    }

    /// A batched map of `theta (N, n)`, run with the GIL released.
    fn theta_map<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
        f: ThetaMap,
    ) -> PyResult<Array<'py>> {
        let t = slice("theta", &theta)?;
        let out = py.detach(|| f(&self.inner, t, threads)).map_err(err)?;
        Ok(vec1(py, out))
    }

    fn loads<'a>(
        lower: &'a Option<Arr<'_>>,
        tip_wrench: &'a Option<Arr<'_>>,
        gravity: &'a Option<Arr<'_>>,
    ) -> PyResult<BatchLoads<'a>> {
        Ok(BatchLoads {
            lower: opt_slice("lower", lower)?,
            tip_wrench: opt_slice("tip_wrench", tip_wrench)?,
            gravity: opt_slice("gravity", gravity)?,
        })
    }
}

#[pymethods]
impl CoreRobot {
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Self> {
        Ok(CoreRobot::of(Robot::from_toml(text).map_err(err)?))
    }

    #[staticmethod]
    fn paper() -> Self {
        CoreRobot::of(Robot::paper())
    }

    // ---- description -------------------------------------------------
    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }
    #[getter]
    fn link_before<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.link_before.clone())
    }
    #[getter]
    fn link_after<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.link_after.clone())
    }
    #[getter]
    fn thickness<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.thickness.clone())
    }
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.mass.clone())
    }
    #[getter]
    fn lower_tension<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.lower_tension.clone())
    }
    #[getter]
    fn joint_limits<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.joint_limits.concat())
    }
    #[getter]
    fn holes<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.holes.clone())
    }
    #[getter]
    fn youngs_modulus(&self) -> f64 {
        self.inner.cable.youngs_modulus
    }
    #[getter]
    fn cable_diameter(&self) -> f64 {
        self.inner.cable.diameter
    }
    #[getter]
    fn routing_length(&self) -> f64 {
        self.inner.cable.routing_length
    }
    #[getter]
    fn gravity(&self) -> (f64, f64) {
        (self.inner.gravity[0], self.inner.gravity[1])
    }
    #[getter]
    fn straight_length(&self) -> f64 {
        self.inner.straight_length()
    }
    #[getter]
    fn axial_stiffness(&self) -> f64 {
        statics::axial_stiffness(&self.inner)
    }

    fn with_holes(&self, holes: Arr<'_>) -> PyResult<Self> {
        let h = slice("holes", &holes)?;
        crate::error::check_finite("holes", h).map_err(err)?;
        Ok(CoreRobot::of(self.inner.with_holes(h).map_err(err)?))
    }

    /// The same robot with another cable material / routing length (validated).
    fn with_cable(
        &self,
        youngs_modulus: f64,
        diameter: f64,
        routing_length: f64,
    ) -> PyResult<Self> {
        let mut r = self.inner.clone();
        r.cable = CableMaterial {
            youngs_modulus,
            diameter,
            routing_length,
        };
        r.validate().map_err(err)?;
        Ok(CoreRobot::of(r))
    }

    /// The same robot with other loads: lower tensions (N) and gravity (m/s²).
    fn with_loads(&self, lower_tension: Arr<'_>, gravity: Arr<'_>) -> PyResult<Self> {
        let lo = slice("lower_tension", &lower_tension)?;
        let g = slice("gravity", &gravity)?;
        if lo.len() != self.inner.n() || g.len() != 2 {
            return Err(err(CdsmError::Shape {
                name: "lower_tension, gravity".into(),
                expected: format!("({},) and (2,)", self.inner.n()),
                got: format!("({},) and ({},)", lo.len(), g.len()),
            }));
        }
        let mut r = self.inner.clone();
        r.lower_tension = lo.to_vec();
        r.gravity = [g[0], g[1]];
        r.validate().map_err(err)?;
        Ok(CoreRobot::of(r))
    }

    fn hole_height_error<'py>(&self, py: Python<'py>, dh: Arr<'_>) -> PyResult<Array<'py>> {
        let d = slice("dh", &dh)?;
        if d.len() != self.inner.n() {
            return Err(err(CdsmError::Shape {
                name: "dh".into(),
                expected: format!("({},)", self.inner.n()),
                got: format!("{} values", d.len()),
            }));
        }
        crate::error::check_finite("dh", d).map_err(err)?;
        let mut out = vec![0.0; self.inner.holes.len()];
        self.inner.hole_height_error_into(d, &mut out);
        Ok(vec1(py, out))
    }

    // ---- kinematics ----------------------------------------------------
    fn fk<'py>(&self, py: Python<'py>, theta: Arr<'_>, threads: usize) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::fk)
    }

    fn fk_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::fk_jacobian)
    }

    fn cable_lengths<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::cable_lengths)
    }

    fn cable_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::cable_jacobian)
    }

    fn within_limits<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let t = slice("theta", &theta)?;
        let out = py
            .detach(|| batch::within_limits(&self.inner, t, threads))
            .map_err(err)?;
        Ok(vec1(py, out))
    }

    // ---- solves --------------------------------------------------------
    #[pyo3(signature = (pose, seed, mask, method, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn ik(
        &self,
        py: Python<'_>,
        pose: Arr<'_>,
        seed: Option<Arr<'_>>,
        mask: Vec<f64>,
        method: &str,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolveResult> {
        let p = slice("pose", &pose)?;
        let s = opt_slice("seed", &seed)?;
        let m = self::mask(&mask)?;
        let how = ik_method(method)?;
        let o = options(tol, max_iter, enforce_limits);
        let out = py
            .detach(|| batch::ik(&self.inner, p, s, m, how, &o, threads))
            .map_err(err)?;
        Ok(SolveResult::new(py, out))
    }

    #[pyo3(signature = (upper, seed, method, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn solve_cables(
        &self,
        py: Python<'_>,
        upper: Arr<'_>,
        seed: Option<Arr<'_>>,
        method: &str,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolveResult> {
        let u = slice("upper", &upper)?;
        let s = opt_slice("seed", &seed)?;
        let m = self::method(method)?;
        let o = options(tol, max_iter, enforce_limits);
        let out = py
            .detach(|| batch::solve_cables(&self.inner, u, s, m, &o, threads))
            .map_err(err)?;
        Ok(SolveResult::new(py, out))
    }

    // ---- error studies ---------------------------------------------------
    #[pyo3(signature = (theta0, dl, holes, method, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn deviation(
        &self,
        py: Python<'_>,
        theta0: Arr<'_>,
        dl: Arr<'_>,
        holes: Option<Arr<'_>>,
        method: &str,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<DeviationResult> {
        let t = slice("theta0", &theta0)?;
        let d = slice("dl", &dl)?;
        let h = opt_slice("holes", &holes)?;
        let m = self::method(method)?;
        let o = options(tol, max_iter, false);
        let (ds, sol) = py
            .detach(|| accuracy::deviation(&self.inner, t, d, h, m, &o, threads))
            .map_err(err)?;
        DeviationResult::new(py, ds, sol)
    }

    #[pyo3(signature = (theta0, dl, dh, dholes, method, tol, max_iter, check_slack, threads))]
    #[allow(clippy::too_many_arguments)]
    fn monte_carlo(
        &self,
        py: Python<'_>,
        theta0: Arr<'_>,
        dl: Arr<'_>,
        dh: Option<Arr<'_>>,
        dholes: Option<Arr<'_>>,
        method: &str,
        tol: f64,
        max_iter: u32,
        check_slack: bool,
        threads: usize,
    ) -> PyResult<MonteCarloStats> {
        let t = slice("theta0", &theta0)?;
        let d = slice("dl", &dl)?;
        let holes = match (opt_slice("dh", &dh)?, opt_slice("dholes", &dholes)?) {
            (None, None) => HoleErrors::None,
            (Some(a), None) => HoleErrors::PerPair(a),
            (None, Some(a)) => HoleErrors::Full(a),
            _ => {
                return Err(err(CdsmError::Option {
                    name: "dh, dholes".into(),
                    problem: "give at most one of them".into(),
                }))
            }
        };
        let m = self::method(method)?;
        let o = options(tol, max_iter, false);
        let st = py
            .detach(|| accuracy::monte_carlo(&self.inner, t, d, holes, m, &o, check_slack, threads))
            .map_err(err)?;
        Ok(MonteCarloStats::new(py, st))
    }

    #[pyo3(signature = (theta, holes, threads))]
    fn sensitivity(
        &self,
        py: Python<'_>,
        theta: Arr<'_>,
        holes: bool,
        threads: usize,
    ) -> PyResult<SensitivityResult> {
        let t = slice("theta", &theta)?;
        let s = py
            .detach(|| crate::sensitivity::sensitivities(&self.inner, t, holes, threads))
            .map_err(err)?;
        Ok(SensitivityResult::new(py, s, holes))
    }

    /// The linear RMS of |d(x, y)| (m) at `theta (N, n)` for uniform errors
    /// within `tol` (2n: cables then disks, m) and its gradient `(N, n)` in
    /// theta (central differences of `h` rad, in the core).
    #[pyo3(signature = (theta, tol, h, threads))]
    fn rms_amplification<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        tol: Arr<'_>,
        h: f64,
        threads: usize,
    ) -> PyResult<(Array<'py>, Array<'py>)> {
        let t = slice("theta", &theta)?;
        let tl = slice("tol", &tol)?;
        let (v, g) = py
            .detach(|| crate::sensitivity::rms_amplification(&self.inner, t, tl, h, threads))
            .map_err(err)?;
        Ok((vec1(py, v), vec1(py, g)))
    }

    // ---- statics -------------------------------------------------------
    #[pyo3(signature = (theta, lower, tip_wrench, gravity, threads))]
    fn tensions<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        lower: Option<Arr<'_>>,
        tip_wrench: Option<Arr<'_>>,
        gravity: Option<Arr<'_>>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        let t = slice("theta", &theta)?;
        let loads = Self::loads(&lower, &tip_wrench, &gravity)?;
        let out = py
            .detach(|| statics::tensions(&self.inner, t, &loads, threads))
            .map_err(err)?;
        Ok(vec1(py, out))
    }

    #[pyo3(signature = (theta, lower, tip_wrench, gravity, min_tension, threads))]
    #[allow(clippy::too_many_arguments)]
    fn feasible<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        lower: Option<Arr<'_>>,
        tip_wrench: Option<Arr<'_>>,
        gravity: Option<Arr<'_>>,
        min_tension: f64,
        threads: usize,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let t = slice("theta", &theta)?;
        let loads = Self::loads(&lower, &tip_wrench, &gravity)?;
        let out = py
            .detach(|| statics::feasibility(&self.inner, t, &loads, min_tension, threads))
            .map_err(err)?;
        Ok(vec1(py, out))
    }

    #[pyo3(signature = (theta, lower, tip_wrench, gravity, threads))]
    fn stretch<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        lower: Option<Arr<'_>>,
        tip_wrench: Option<Arr<'_>>,
        gravity: Option<Arr<'_>>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        let t = slice("theta", &theta)?;
        let loads = Self::loads(&lower, &tip_wrench, &gravity)?;
        let out = py
            .detach(|| statics::stretches(&self.inner, t, &loads, threads))
            .map_err(err)?;
        Ok(vec1(py, out))
    }

    #[pyo3(signature = (upper, seed, lower, tip_wrench, gravity, min_tension, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn solve_elastic(
        &self,
        py: Python<'_>,
        upper: Arr<'_>,
        seed: Option<Arr<'_>>,
        lower: Option<Arr<'_>>,
        tip_wrench: Option<Arr<'_>>,
        gravity: Option<Arr<'_>>,
        min_tension: f64,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<ElasticResult> {
        let u = slice("upper", &upper)?;
        let s = opt_slice("seed", &seed)?;
        let loads = Self::loads(&lower, &tip_wrench, &gravity)?;
        let o = options(tol, max_iter, false);
        let out = py
            .detach(|| statics::solve_elastic(&self.inner, u, s, &loads, min_tension, &o, threads))
            .map_err(err)?;
        ElasticResult::new(py, out)
    }

    // ---- the plant -----------------------------------------------------
    /// Names and sizes of the plant's effects, in parameter order.
    fn plant_effects(&self) -> Vec<(String, usize)> {
        plant::effects(&self.model)
    }

    /// Lower and upper bounds of the plant's parameters (the physical domain).
    fn plant_bounds<'py>(&self, py: Python<'py>) -> (Array<'py>, Array<'py>) {
        plant::bounds(py, &self.model)
    }

    #[pyo3(signature = (params, theta_cmd, dl, kind, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn plant_predict(
        &self,
        py: Python<'_>,
        params: Arr<'_>,
        theta_cmd: Arr<'_>,
        dl: Arr<'_>,
        kind: Vec<u8>,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<PlantPrediction> {
        let data = Data::of(&theta_cmd, &dl, &kind)?;
        plant::predict(py, &self.model, params, &data, tol, max_iter, threads)
    }

    #[pyo3(signature = (params, free, theta_cmd, dl, kind, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn plant_linearise(
        &self,
        py: Python<'_>,
        params: Arr<'_>,
        free: Vec<usize>,
        theta_cmd: Arr<'_>,
        dl: Arr<'_>,
        kind: Vec<u8>,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<PlantPrediction> {
        let data = Data::of(&theta_cmd, &dl, &kind)?;
        plant::linearise(
            py,
            &self.model,
            params,
            &free,
            &data,
            tol,
            max_iter,
            threads,
        )
    }

    /// Fits the plant parameters `free` (scaled by `scale`) from `start` on
    /// every fold's scored rows (`scored (F, N)`), folds in parallel.
    #[pyo3(signature = (theta_cmd, dl, kind, measured, scored, free, scale, start, tol, max_iter, fit_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn plant_fit(
        &self,
        py: Python<'_>,
        theta_cmd: Arr<'_>,
        dl: Arr<'_>,
        kind: Vec<u8>,
        measured: Arr<'_>,
        scored: Vec<bool>,
        free: Vec<usize>,
        scale: Vec<f64>,
        start: Arr<'_>,
        tol: f64,
        max_iter: u32,
        fit_iter: u32,
        threads: usize,
    ) -> PyResult<Vec<PlantFit>> {
        let data = Data::of(&theta_cmd, &dl, &kind)?;
        let args = FitArgs {
            measured: slice("measured", &measured)?,
            scored: &scored,
            free: &free,
            scale: &scale,
            start: slice("start", &start)?,
            fit_iter,
        };
        plant::fit(py, &self.model, &data, args, tol, max_iter, threads)
    }

    #[pyo3(signature = (params, theta_cmd, targets, weights, start, tol, settle_tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn compensate(
        &self,
        py: Python<'_>,
        params: Arr<'_>,
        theta_cmd: Arr<'_>,
        targets: Arr<'_>,
        weights: Vec<f64>,
        start: Option<Arr<'_>>,
        tol: f64,
        settle_tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<CompensationResult> {
        plant::compensate(
            py,
            &self.model,
            params,
            theta_cmd,
            targets,
            &weights,
            start,
            tol,
            settle_tol,
            max_iter,
            threads,
        )
    }
}

/// Edges (m) of the Monte-Carlo histogram's regular bins (see `accuracy::hist_edges`).
#[pyfunction]
pub fn hist_edges<'py>(py: Python<'py>) -> Array<'py> {
    vec1(py, accuracy::hist_edges().to_vec())
}

/// The SIMD instruction set the kernels dispatch to on this machine.
#[pyfunction]
pub fn simd_instruction_set() -> String {
    crate::simd::instruction_set()
}
