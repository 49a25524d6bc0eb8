//! `CoreSpatialRobot`: a validated spatial robot (`docs/spatial.md`) and the
//! batch calls of the core on it, with the GIL released around the work. The
//! documented API is `cdsm.SpatialRobot`.

use super::convert::{err, opt_slice, options, slice, vec1, Arr, Array, CdsmInputError};
use super::plant::{self, Data, FitArgs};
use super::results::{
    CompensationResult, MonteCarloStats, PlantFit, PlantPrediction, SolveResult, TensionResult,
};
use crate::spatial::{self, solve::SpatialMask, SpatialRobot};
use pyo3::prelude::*;

/// A validated spatial robot (SI units); see `cdsm.SpatialRobot`.
#[pyclass(frozen, module = "cdsm._cdsm")]
pub struct CoreSpatialRobot {
    inner: SpatialRobot,
}

type ThetaMap = fn(&SpatialRobot, &[f64], usize) -> crate::Result<Vec<f64>>;

impl CoreSpatialRobot {
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
}

fn mask(name: &str) -> PyResult<SpatialMask> {
    match name {
        "position" => Ok(SpatialMask::Position),
        "pointing" => Ok(SpatialMask::Pointing),
        "pose" => Ok(SpatialMask::Pose),
        other => Err(CdsmInputError::new_err(format!(
            "`mask`: expected 'position', 'pointing' or 'pose' for a spatial arm, got {other:?}"
        ))),
    }
}

#[pymethods]
impl CoreSpatialRobot {
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<CoreSpatialRobot> {
        Ok(CoreSpatialRobot {
            inner: SpatialRobot::from_toml(text).map_err(err)?,
        })
    }

    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }

    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    /// `(n*2)` joint limits, rad.
    #[getter]
    fn joint_limits<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(
            py,
            self.inner.joints.iter().flat_map(|j| j.limits).collect(),
        )
    }

    /// `(n*3)` unit joint axes (local frames).
    #[getter]
    fn axes<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.joints.iter().flat_map(|j| j.axis).collect())
    }

    #[getter]
    fn gravity<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.gravity.to_vec())
    }

    /// Distance of the straight arm's tip from the base (m).
    #[getter]
    fn straight_length(&self) -> f64 {
        self.inner.straight_length()
    }

    /// Number of cables.
    #[getter]
    fn cables(&self) -> usize {
        self.inner.cables.len()
    }

    /// Indices of the position-controlled cables.
    #[getter]
    fn position_cables(&self) -> Vec<usize> {
        self.inner.position_cables()
    }

    /// The disk (1-based) each cable ends at.
    #[getter]
    fn cable_ends(&self) -> Vec<usize> {
        self.inner.cables.iter().map(|c| c.end).collect()
    }

    /// Set tensions of the cables (N; 0 for position-controlled ones).
    #[getter]
    fn cable_tensions<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.cables.iter().map(|c| c.tension).collect())
    }

    /// Every hole, flat (cable by cable, `[x, y, z]` per face), m.
    #[getter]
    fn holes<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.inner.flat_holes())
    }

    /// Disk radii (base first), m.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Array<'py> {
        let mut r = vec![self.inner.base_radius];
        r.extend(self.inner.disks.iter().map(|d| d.radius));
        vec1(py, r)
    }

    fn with_holes(&self, holes: Arr<'_>) -> PyResult<CoreSpatialRobot> {
        let h = slice("holes", &holes)?;
        Ok(CoreSpatialRobot {
            inner: self.inner.with_flat_holes(h).map_err(err)?,
        })
    }

    fn fk<'py>(&self, py: Python<'py>, theta: Arr<'_>, threads: usize) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, spatial::fk)
    }

    fn fk_matrix<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, spatial::fk_matrix)
    }

    fn fk_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, spatial::fk_jacobian)
    }

    fn cable_lengths<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, spatial::cable_lengths)
    }

    fn cable_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, spatial::cable_jacobian)
    }

    #[pyo3(signature = (lengths, seed, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn solve_cables(
        &self,
        py: Python<'_>,
        lengths: Arr<'_>,
        seed: Option<Arr<'_>>,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolveResult> {
        let l = slice("lengths", &lengths)?;
        let s = opt_slice("seed", &seed)?;
        let o = options(tol, max_iter, enforce_limits);
        let out = py
            .detach(|| spatial::solve_cables(&self.inner, l, s, &o, threads))
            .map_err(err)?;
        Ok(SolveResult::new(py, out))
    }

    #[pyo3(signature = (target, seed, mask, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn ik(
        &self,
        py: Python<'_>,
        target: Arr<'_>,
        seed: Option<Arr<'_>>,
        mask: &str,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolveResult> {
        let t = slice("target", &target)?;
        let s = opt_slice("seed", &seed)?;
        let m = self::mask(mask)?;
        let o = options(tol, max_iter, enforce_limits);
        let out = py
            .detach(|| spatial::ik(&self.inner, t, s, m, &o, threads))
            .map_err(err)?;
        Ok(SolveResult::new(py, out))
    }

    #[pyo3(signature = (theta0, dl, dholes, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn monte_carlo(
        &self,
        py: Python<'_>,
        theta0: Arr<'_>,
        dl: Arr<'_>,
        dholes: Option<Arr<'_>>,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<MonteCarloStats> {
        let t = slice("theta0", &theta0)?;
        let d = slice("dl", &dl)?;
        let h = opt_slice("dholes", &dholes)?;
        let o = options(tol, max_iter, false);
        let st = py
            .detach(|| spatial::monte_carlo(&self.inner, t, d, h, &o, threads))
            .map_err(err)?;
        Ok(MonteCarloStats::new(py, st))
    }

    // ---- the plant -----------------------------------------------------
    /// Names and sizes of the plant's effects, in parameter order.
    fn plant_effects(&self) -> Vec<(String, usize)> {
        plant::effects(&self.inner)
    }

    /// Lower and upper bounds of the plant's parameters (the physical domain).
    fn plant_bounds<'py>(&self, py: Python<'py>) -> (Array<'py>, Array<'py>) {
        plant::bounds(py, &self.inner)
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
        plant::predict(py, &self.inner, params, &data, tol, max_iter, threads)
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
            &self.inner,
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
        plant::fit(py, &self.inner, &data, args, tol, max_iter, threads)
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
            &self.inner,
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

    fn tensions(
        &self,
        py: Python<'_>,
        theta: Arr<'_>,
        tip_wrench: Vec<f64>,
        min_tension: f64,
        threads: usize,
    ) -> PyResult<TensionResult> {
        let t = slice("theta", &theta)?;
        let w: [f64; 6] = tip_wrench.try_into().map_err(|_| {
            CdsmInputError::new_err("`tip_wrench`: expected 6 values [Fx, Fy, Fz, Mx, My, Mz]")
        })?;
        let (tension, feasible) = py
            .detach(|| spatial::tensions(&self.inner, t, &w, min_tension, threads))
            .map_err(err)?;
        Ok(TensionResult::new(py, tension, feasible))
    }
}

/// The `kind` of a robot description: `"planar"` or `"spatial"`.
#[pyfunction]
pub fn robot_kind(text: &str) -> PyResult<String> {
    crate::model::kind_of(text).map_err(err)
}
