//! The Python binding: converts between NumPy arrays and the core's slices,
//! releases the GIL around batch work, and maps `CdsmError` to Python
//! exceptions. No physics here.

use crate::accuracy::{self, HoleErrors, McStats};
use crate::batch::{self, BatchSolution};
use crate::error::CdsmError;
use crate::plant::{self, Observation};
use crate::robot::Robot;
use crate::solve::{CableMethod, SolveOptions};
use numpy::{PyArray1, PyReadonlyArrayDyn};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

create_exception!(
    _cdsm,
    CdsmInputError,
    PyValueError,
    "Bad input: the message names the field and the problem."
);

fn err(e: CdsmError) -> PyErr {
    CdsmInputError::new_err(e.to_string())
}

fn slice<'a>(name: &str, a: &'a PyReadonlyArrayDyn<'_, f64>) -> PyResult<&'a [f64]> {
    a.as_slice().map_err(|_| {
        CdsmInputError::new_err(format!("`{name}`: must be a C-contiguous float64 array"))
    })
}

fn vec1<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

fn options(tol: f64, max_iter: u32, enforce_limits: bool) -> SolveOptions {
    SolveOptions {
        tol,
        max_iter,
        enforce_limits,
    }
}

fn method(name: &str) -> PyResult<CableMethod> {
    match name {
        "auto" => Ok(CableMethod::Auto),
        "newton" => Ok(CableMethod::Newton),
        "closed_form" => Ok(CableMethod::ClosedForm),
        other => Err(CdsmInputError::new_err(format!(
            "`method`: expected 'auto', 'newton' or 'closed_form', got {other:?}"
        ))),
    }
}

type SolutionArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<bool>>,
    Bound<'py, PyArray1<u32>>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<bool>>,
);

type Predictions<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<bool>>,
    Bound<'py, PyArray1<f64>>,
);

fn solution<'py>(py: Python<'py>, s: BatchSolution) -> SolutionArrays<'py> {
    (
        vec1(py, s.theta),
        vec1(py, s.converged),
        vec1(py, s.iterations),
        vec1(py, s.residual),
        vec1(py, s.within_limits),
    )
}

/// A validated robot (SI units); see `cdsm.Robot` for the documented API.
#[pyclass(frozen, module = "cdsm._cdsm")]
struct CoreRobot {
    inner: Robot,
}

type Array<'py> = Bound<'py, PyArray1<f64>>;
type ThetaMap = fn(&Robot, &[f64], usize) -> crate::Result<Vec<f64>>;

impl CoreRobot {
    /// A batched map of `theta (N, n)`, run with the GIL released.
    fn theta_map<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'_, f64>,
        threads: usize,
        f: ThetaMap,
    ) -> PyResult<Array<'py>> {
        let t = slice("theta", &theta)?;
        let out = py.detach(|| f(&self.inner, t, threads)).map_err(err)?;
        Ok(vec1(py, out))
    }
}

#[pymethods]
impl CoreRobot {
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Self> {
        Ok(CoreRobot {
            inner: Robot::from_toml(text).map_err(err)?,
        })
    }

    #[staticmethod]
    fn paper() -> Self {
        CoreRobot {
            inner: Robot::paper(),
        }
    }

    #[getter]
    fn n(&self) -> usize {
        self.inner.n()
    }
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }
    #[getter]
    fn link_before<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec1(py, self.inner.link_before.clone())
    }
    #[getter]
    fn link_after<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec1(py, self.inner.link_after.clone())
    }
    #[getter]
    fn thickness<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec1(py, self.inner.thickness.clone())
    }
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec1(py, self.inner.mass.clone())
    }
    #[getter]
    fn lower_tension<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec1(py, self.inner.lower_tension.clone())
    }
    #[getter]
    fn joint_limits<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec1(py, self.inner.joint_limits.concat())
    }
    #[getter]
    fn holes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
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

    fn with_holes(&self, holes: PyReadonlyArrayDyn<'_, f64>) -> PyResult<Self> {
        let h = slice("holes", &holes)?;
        crate::error::check_finite("holes", h).map_err(err)?;
        Ok(CoreRobot {
            inner: self.inner.with_holes(h).map_err(err)?,
        })
    }

    fn hole_height_error<'py>(
        &self,
        py: Python<'py>,
        dh: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
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

    fn fk<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'_, f64>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::fk)
    }

    fn fk_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'_, f64>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::fk_jacobian)
    }

    fn cable_lengths<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'_, f64>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::cable_lengths)
    }

    fn cable_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'_, f64>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, batch::cable_jacobian)
    }

    #[pyo3(signature = (pose, seed, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn ik<'py>(
        &self,
        py: Python<'py>,
        pose: PyReadonlyArrayDyn<'_, f64>,
        seed: Option<PyReadonlyArrayDyn<'_, f64>>,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolutionArrays<'py>> {
        let p = slice("pose", &pose)?;
        let s = match &seed {
            Some(a) => Some(slice("seed", a)?),
            None => None,
        };
        let o = options(tol, max_iter, enforce_limits);
        let out = py
            .detach(|| batch::ik(&self.inner, p, s, &o, threads))
            .map_err(err)?;
        Ok(solution(py, out))
    }

    #[pyo3(signature = (upper, seed, method, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn solve_cables<'py>(
        &self,
        py: Python<'py>,
        upper: PyReadonlyArrayDyn<'_, f64>,
        seed: Option<PyReadonlyArrayDyn<'_, f64>>,
        method: &str,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolutionArrays<'py>> {
        let u = slice("upper", &upper)?;
        let s = match &seed {
            Some(a) => Some(slice("seed", a)?),
            None => None,
        };
        let m = self::method(method)?;
        let o = options(tol, max_iter, enforce_limits);
        let out = py
            .detach(|| batch::solve_cables(&self.inner, u, s, m, &o, threads))
            .map_err(err)?;
        Ok(solution(py, out))
    }

    #[pyo3(signature = (theta0, dl, holes, method, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn deviation<'py>(
        &self,
        py: Python<'py>,
        theta0: PyReadonlyArrayDyn<'_, f64>,
        dl: PyReadonlyArrayDyn<'_, f64>,
        holes: Option<PyReadonlyArrayDyn<'_, f64>>,
        method: &str,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<(Bound<'py, PyArray1<f64>>, SolutionArrays<'py>)> {
        let t = slice("theta0", &theta0)?;
        let d = slice("dl", &dl)?;
        let h = match &holes {
            Some(a) => Some(slice("holes", a)?),
            None => None,
        };
        let m = self::method(method)?;
        let o = options(tol, max_iter, false);
        let (ds, sol) = py
            .detach(|| accuracy::deviation(&self.inner, t, d, h, m, &o, threads))
            .map_err(err)?;
        Ok((vec1(py, ds), solution(py, sol)))
    }

    /// Plant predictions (see `plant.rs`): `params (K, P)`, `theta_cmd (N, n)`,
    /// `dl (N, n)` -> flat `(K, N, 3)` observations, `(K, N)` converged and
    /// `(K, N, n)` settled joint angles.
    #[pyo3(signature = (params, theta_cmd, dl, displacement, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn plant_predict<'py>(
        &self,
        py: Python<'py>,
        params: PyReadonlyArrayDyn<'_, f64>,
        theta_cmd: PyReadonlyArrayDyn<'_, f64>,
        dl: PyReadonlyArrayDyn<'_, f64>,
        displacement: bool,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<Predictions<'py>> {
        let p = slice("params", &params)?;
        let t = slice("theta_cmd", &theta_cmd)?;
        let d = slice("dl", &dl)?;
        let kind = if displacement {
            Observation::Displacement
        } else {
            Observation::Absolute
        };
        let o = options(tol, max_iter, false);
        let out = py
            .detach(|| plant::predict(&self.inner, p, t, d, kind, &o, threads))
            .map_err(err)?;
        Ok((
            vec1(py, out.observation),
            vec1(py, out.converged),
            vec1(py, out.theta),
        ))
    }

    /// Names and sizes of the plant's effects, in parameter order.
    fn plant_effects(&self) -> Vec<(String, usize)> {
        plant::EFFECTS
            .iter()
            .zip(plant::effect_sizes(self.inner.n()))
            .map(|(a, b)| (a.to_string(), b))
            .collect()
    }

    #[pyo3(signature = (theta0, dl, dh, dholes, method, tol, max_iter, check_slack, threads))]
    #[allow(clippy::too_many_arguments)]
    fn monte_carlo<'py>(
        &self,
        py: Python<'py>,
        theta0: PyReadonlyArrayDyn<'_, f64>,
        dl: PyReadonlyArrayDyn<'_, f64>,
        dh: Option<PyReadonlyArrayDyn<'_, f64>>,
        dholes: Option<PyReadonlyArrayDyn<'_, f64>>,
        method: &str,
        tol: f64,
        max_iter: u32,
        check_slack: bool,
        threads: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let t = slice("theta0", &theta0)?;
        let d = slice("dl", &dl)?;
        let holes = match (&dh, &dholes) {
            (None, None) => HoleErrors::None,
            (Some(a), None) => HoleErrors::PerPair(slice("dh", a)?),
            (None, Some(a)) => HoleErrors::Full(slice("dholes", a)?),
            _ => {
                return Err(CdsmInputError::new_err(
                    "`dh`, `dholes`: give at most one of them",
                ))
            }
        };
        let m = self::method(method)?;
        let o = options(tol, max_iter, false);
        let st: McStats = py
            .detach(|| accuracy::monte_carlo(&self.inner, t, d, holes, m, &o, check_slack, threads))
            .map_err(err)?;
        let out = PyDict::new(py);
        out.set_item("count", vec1(py, st.count))?;
        out.set_item("failed", vec1(py, st.failed))?;
        out.set_item("sum", vec1(py, st.sum))?;
        out.set_item("sum_sq", vec1(py, st.sum_sq))?;
        out.set_item("min", vec1(py, st.min))?;
        out.set_item("max", vec1(py, st.max))?;
        out.set_item("hist", vec1(py, st.hist))?;
        out.set_item("slack", vec1(py, st.slack))?;
        Ok(out)
    }
}

/// Edges (m) of the Monte-Carlo histogram's regular bins (see `accuracy::hist_edges`).
#[pyfunction]
fn hist_edges<'py>(py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
    vec1(py, accuracy::hist_edges().to_vec())
}

#[pymodule]
fn _cdsm(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<CoreRobot>()?;
    m.add("CdsmInputError", m.py().get_type::<CdsmInputError>())?;
    m.add("PAPER_TOML", crate::robot::PAPER_TOML)?;
    m.add("HIST_LO", accuracy::HIST_LO)?;
    m.add("HIST_PER_DECADE", accuracy::HIST_PER_DECADE)?;
    m.add("HIST_BINS", accuracy::HIST_BINS)?;
    m.add_function(wrap_pyfunction!(hist_edges, m)?)?;
    m.add("QUANTITIES", accuracy::QUANTITIES)?;
    m.add_function(wrap_pyfunction!(statics_tensions, m)?)?;
    m.add_function(wrap_pyfunction!(statics_feasible, m)?)?;
    m.add_function(wrap_pyfunction!(statics_stretch, m)?)?;
    m.add_function(wrap_pyfunction!(statics_solve_elastic, m)?)?;
    m.add_function(wrap_pyfunction!(statics_routing_length, m)?)?;
    m.add_function(wrap_pyfunction!(statics_with_cable, m)?)?;
    m.add_function(wrap_pyfunction!(sensitivity_tip, m)?)?;
    Ok(())
}

// ---------------------------------------------------------------------------
// Statics and cable elasticity (issue 4): free functions over a CoreRobot
// (`crate::statics`), wrapped by `cdsm.Robot.tensions`, `feasible`, `stretch`,
// `solve_cables_elastic` and `with_cable`.
// ---------------------------------------------------------------------------

fn opt_slice<'a>(
    name: &str,
    a: &'a Option<PyReadonlyArrayDyn<'_, f64>>,
) -> PyResult<Option<&'a [f64]>> {
    match a {
        Some(a) => Ok(Some(slice(name, a)?)),
        None => Ok(None),
    }
}

fn batch_loads<'a>(
    lower: &'a Option<PyReadonlyArrayDyn<'_, f64>>,
    tip_wrench: &'a Option<PyReadonlyArrayDyn<'_, f64>>,
    gravity: &'a Option<PyReadonlyArrayDyn<'_, f64>>,
) -> PyResult<crate::statics::BatchLoads<'a>> {
    Ok(crate::statics::BatchLoads {
        lower: opt_slice("lower", lower)?,
        tip_wrench: opt_slice("tip_wrench", tip_wrench)?,
        gravity: opt_slice("gravity", gravity)?,
    })
}

/// Upper-cable tensions (N), flat `(N, n)`.
#[pyfunction]
#[pyo3(signature = (robot, theta, lower, tip_wrench, gravity, threads))]
fn statics_tensions<'py>(
    py: Python<'py>,
    robot: PyRef<'py, CoreRobot>,
    theta: PyReadonlyArrayDyn<'_, f64>,
    lower: Option<PyReadonlyArrayDyn<'_, f64>>,
    tip_wrench: Option<PyReadonlyArrayDyn<'_, f64>>,
    gravity: Option<PyReadonlyArrayDyn<'_, f64>>,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let r = &robot.inner;
    let t = slice("theta", &theta)?;
    let loads = batch_loads(&lower, &tip_wrench, &gravity)?;
    let out = py
        .detach(|| crate::statics::tensions(r, t, &loads, threads))
        .map_err(err)?;
    Ok(vec1(py, out))
}

/// Every upper tension `> min_tension` (N), `(N,)` bool.
#[pyfunction]
#[pyo3(signature = (robot, theta, lower, tip_wrench, gravity, min_tension, threads))]
#[allow(clippy::too_many_arguments)]
fn statics_feasible<'py>(
    py: Python<'py>,
    robot: PyRef<'py, CoreRobot>,
    theta: PyReadonlyArrayDyn<'_, f64>,
    lower: Option<PyReadonlyArrayDyn<'_, f64>>,
    tip_wrench: Option<PyReadonlyArrayDyn<'_, f64>>,
    gravity: Option<PyReadonlyArrayDyn<'_, f64>>,
    min_tension: f64,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let r = &robot.inner;
    let t = slice("theta", &theta)?;
    let loads = batch_loads(&lower, &tip_wrench, &gravity)?;
    let out = py
        .detach(|| crate::statics::feasibility(r, t, &loads, min_tension, threads))
        .map_err(err)?;
    Ok(vec1(py, out))
}

/// Upper-cable elongation (m) under the statics tensions, flat `(N, n)`.
#[pyfunction]
#[pyo3(signature = (robot, theta, lower, tip_wrench, gravity, threads))]
fn statics_stretch<'py>(
    py: Python<'py>,
    robot: PyRef<'py, CoreRobot>,
    theta: PyReadonlyArrayDyn<'_, f64>,
    lower: Option<PyReadonlyArrayDyn<'_, f64>>,
    tip_wrench: Option<PyReadonlyArrayDyn<'_, f64>>,
    gravity: Option<PyReadonlyArrayDyn<'_, f64>>,
    threads: usize,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let r = &robot.inner;
    let t = slice("theta", &theta)?;
    let loads = batch_loads(&lower, &tip_wrench, &gravity)?;
    let out = py
        .detach(|| crate::statics::stretches(r, t, &loads, threads))
        .map_err(err)?;
    Ok(vec1(py, out))
}

type ElasticArrays<'py> = (
    SolutionArrays<'py>,
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<bool>>,
);

/// Coupled elastic cable solve: (solution arrays, tensions flat (N, n), feasible (N,)).
#[pyfunction]
#[pyo3(signature = (robot, upper, seed, lower, tip_wrench, gravity, min_tension, tol, max_iter, threads))]
#[allow(clippy::too_many_arguments)]
fn statics_solve_elastic<'py>(
    py: Python<'py>,
    robot: PyRef<'py, CoreRobot>,
    upper: PyReadonlyArrayDyn<'_, f64>,
    seed: Option<PyReadonlyArrayDyn<'_, f64>>,
    lower: Option<PyReadonlyArrayDyn<'_, f64>>,
    tip_wrench: Option<PyReadonlyArrayDyn<'_, f64>>,
    gravity: Option<PyReadonlyArrayDyn<'_, f64>>,
    min_tension: f64,
    tol: f64,
    max_iter: u32,
    threads: usize,
) -> PyResult<ElasticArrays<'py>> {
    let r = &robot.inner;
    let u = slice("upper", &upper)?;
    let s = opt_slice("seed", &seed)?;
    let loads = batch_loads(&lower, &tip_wrench, &gravity)?;
    let o = options(tol, max_iter, false);
    let out = py
        .detach(|| crate::statics::solve_elastic(r, u, s, &loads, min_tension, &o, threads))
        .map_err(err)?;
    Ok((
        solution(py, out.solution),
        vec1(py, out.tension),
        vec1(py, out.feasible),
    ))
}

/// Length of the cable path behind the base disk (m).
#[pyfunction]
fn statics_routing_length(robot: PyRef<'_, CoreRobot>) -> f64 {
    robot.inner.cable.routing_length
}

/// The same robot with another cable material / routing length (validated).
#[pyfunction]
#[pyo3(signature = (robot, youngs_modulus, diameter, routing_length))]
fn statics_with_cable(
    robot: PyRef<'_, CoreRobot>,
    youngs_modulus: f64,
    diameter: f64,
    routing_length: f64,
) -> PyResult<CoreRobot> {
    let mut r = robot.inner.clone();
    r.cable = crate::robot::CableMaterial {
        youngs_modulus,
        diameter,
        routing_length,
    };
    r.validate().map_err(err)?;
    Ok(CoreRobot { inner: r })
}

// ---------------------------------------------------------------------------
// Tip sensitivities (issue 7): `crate::sensitivity`, wrapped by
// `cdsm.tolerance.sensitivities`.
// ---------------------------------------------------------------------------

type SensitivityArrays<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray1<f64>>,
    Option<Bound<'py, PyArray1<f64>>>,
    Bound<'py, PyArray1<bool>>,
);

/// d[x, y, phi]/d(upper cable lengths) flat `(N, 3, n)`, d/d(hole height per
/// disk) flat `(N, 3, n)`, d/d(every hole coordinate) flat `(N, 3, H)` (only
/// with `holes`), and `(N,)` ok (cable Jacobian invertible).
#[pyfunction]
#[pyo3(signature = (robot, theta, holes, threads))]
fn sensitivity_tip<'py>(
    py: Python<'py>,
    robot: PyRef<'py, CoreRobot>,
    theta: PyReadonlyArrayDyn<'_, f64>,
    holes: bool,
    threads: usize,
) -> PyResult<SensitivityArrays<'py>> {
    let r = &robot.inner;
    let t = slice("theta", &theta)?;
    let s = py
        .detach(|| crate::sensitivity::sensitivities(r, t, holes, threads))
        .map_err(err)?;
    let h = if holes { Some(vec1(py, s.holes)) } else { None };
    Ok((vec1(py, s.cable), vec1(py, s.pair), h, vec1(py, s.ok)))
}
