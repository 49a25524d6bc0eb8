//! `CoreRobot`: a validated arm of either kind (the one model) and every
//! batch call of the core on it, with the GIL released around the work. A
//! call that only a planar arm has yet says so for a spatial one. The
//! documented API is `cdsm.Robot` and the Python modules that call these
//! methods.

use super::convert::{
    err, ik_method, method, opt_slice, options, robot_table, slice, vec1, Arr, Array,
    CdsmInputError,
};
use super::plant::{self, Data, FitArgs};
use super::results::{
    CompensationResult, DeviationResult, ElasticResult, EquilibriumDerivatives, EquilibriumResult,
    MonteCarloStats, PlantFit, PlantPrediction, SensitivityResult, SolveResult, TensionResult,
};
use crate::accuracy;
use crate::arm::{self, Loads};
use crate::error::CdsmError;
use crate::friction::Sliding;
use crate::ik::{self, Mask};
use crate::kinds::Kind;
use crate::model::{Mode, Model};
use crate::robot::{CableMaterial, PlanarView};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// A validated arm (SI units); see `cdsm.Robot` for the documented API.
#[pyclass(frozen, module = "cdsm._cdsm")]
pub struct CoreRobot {
    model: Model,
}

type ThetaMap = fn(&Model, &[f64], usize) -> crate::Result<Vec<f64>>;

/// A pose-IK mask from Python: a name or weights over the task
/// coordinates ([`Mask::parse`] reads it for the arm's kind).
#[derive(FromPyObject)]
enum MaskArg {
    Name(String),
    Weights(Vec<f64>),
}

impl MaskArg {
    fn core(&self) -> ik::MaskArg<'_> {
        match self {
            MaskArg::Name(n) => ik::MaskArg::Name(n),
            MaskArg::Weights(w) => ik::MaskArg::Weights(w),
        }
    }
}

impl CoreRobot {
    fn of(model: Model) -> Self {
        CoreRobot { model }
    }

    /// An error naming `call` for an elastic arm (joint springs, rest
    /// angles or displacement cables): the rigid solves and statics do not
    /// model them; its statics is `equilibrium` (`crate::elastic`).
    fn rigid(&self, call: &str) -> PyResult<()> {
        if self.model.is_elastic() {
            return Err(CdsmInputError::new_err(format!(
                "`{call}`: available for rigid arms only (this arm has joint springs or \
                 displacement cables: its statics is `equilibrium`)"
            )));
        }
        Ok(())
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
        let out = py.detach(|| f(&self.model, t, threads)).map_err(err)?;
        Ok(vec1(py, out))
    }
}

#[pymethods]
impl CoreRobot {
    #[staticmethod]
    fn from_toml(text: &str) -> PyResult<Self> {
        Ok(CoreRobot::of(Model::from_toml(text).map_err(err)?))
    }

    /// The arm of a robot file's data (a dict of the file's structure),
    /// validated as the file would be; no text in between.
    #[staticmethod]
    fn from_data(data: &Bound<'_, PyDict>) -> PyResult<Self> {
        Ok(CoreRobot::of(
            Model::from_table(robot_table(data)?).map_err(err)?,
        ))
    }

    #[staticmethod]
    fn paper() -> Self {
        CoreRobot::of(Model::from_planar(&PlanarView::paper()))
    }

    /// A robot file (TOML, SI units) that rebuilds this arm exactly.
    fn to_toml(&self) -> String {
        self.model.to_toml()
    }

    // ---- description (both kinds) ---------------------------------------
    /// `"planar"` or `"spatial"`.
    #[getter]
    fn kind(&self) -> &'static str {
        self.model.kind.name()
    }
    /// The facts of this arm's structure (`model::Structure`): `position`,
    /// `force` (cable indices by control mode), `pairs` (upper/lower pairs
    /// per disk), `hole_groups` (each a dict of `coords`, indices into the
    /// flat holes, `coefs` and `coherent`).
    fn structure<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.model.structure();
        let d = PyDict::new(py);
        d.set_item("position", s.position)?;
        d.set_item("force", s.force)?;
        d.set_item("pairs", s.pairs)?;
        let groups = PyList::empty(py);
        for g in s.hole_groups {
            let gd = PyDict::new(py);
            gd.set_item("coords", g.coords)?;
            gd.set_item("coefs", g.coefs)?;
            gd.set_item("coherent", g.coherent)?;
            groups.append(gd)?;
        }
        d.set_item("hole_groups", groups)?;
        Ok(d)
    }
    #[getter]
    fn n(&self) -> usize {
        self.model.n()
    }
    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }
    /// `(n*2)` joint limits, rad.
    #[getter]
    fn joint_limits<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(
            py,
            self.model.joints.iter().flat_map(|j| j.limits).collect(),
        )
    }
    /// `(n*3)` unit joint axes (each in its joint's frame).
    #[getter]
    fn axes<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.joints.iter().flat_map(|j| j.axis).collect())
    }
    /// `(3,)` gravity, m/s², base frame.
    #[getter]
    fn gravity<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.gravity.to_vec())
    }
    /// Distance of the straight arm's tip from the base (m).
    #[getter]
    fn straight_length(&self) -> f64 {
        crate::chain::straight_length(&self.model)
    }
    /// Number of cables.
    #[getter]
    fn cables(&self) -> usize {
        self.model.cables.len()
    }
    /// Indices of the position-controlled cables.
    #[getter]
    fn position_cables(&self) -> Vec<usize> {
        self.model.position_cables()
    }
    /// The disk (1-based) each cable ends at.
    #[getter]
    fn cable_ends(&self) -> Vec<usize> {
        self.model.cables.iter().map(|c| c.end).collect()
    }
    /// Set tensions of the cables (N; 0 for position-controlled ones).
    #[getter]
    fn cable_tensions<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(
            py,
            self.model
                .cables
                .iter()
                .map(|c| {
                    if c.mode == Mode::Force {
                        c.tension
                    } else {
                        0.0
                    }
                })
                .collect(),
        )
    }
    /// Every hole, flat (cable by cable, `[x, y, z]` per face), m.
    #[getter]
    fn flat_holes<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.flat_holes())
    }
    /// Disk radii (base first), m.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Array<'py> {
        let mut r = vec![self.model.base_radius];
        r.extend(self.model.disks.iter().map(|d| d.radius));
        vec1(py, r)
    }
    /// `(disks,)` disk masses, kg.
    #[getter]
    fn mass<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.disks.iter().map(|d| d.mass).collect())
    }
    /// `(n*3)` joint offsets (m): previous frame -> joint, in the previous frame.
    #[getter]
    fn offsets<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(
            py,
            self.model.joints.iter().flat_map(|j| j.offset).collect(),
        )
    }
    /// The disk (1-based) each joint belongs to.
    #[getter]
    fn joint_disks(&self) -> Vec<usize> {
        (0..self.model.n())
            .map(|j| self.model.joint_disk(j))
            .collect()
    }
    /// `(disks*3)` last joint -> proximal face of each disk (m, joint frame).
    #[getter]
    fn disk_link_after<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(
            py,
            self.model.disks.iter().flat_map(|d| d.link_after).collect(),
        )
    }
    /// `(disks,)` disk thickness along its local x axis (m).
    #[getter]
    fn disk_thickness<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.disks.iter().map(|d| d.thickness).collect())
    }
    /// `(disks*3)` centres of mass (m, proximal-face frame).
    #[getter]
    fn com<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.disks.iter().flat_map(|d| d.com).collect())
    }
    #[getter]
    fn youngs_modulus(&self) -> f64 {
        self.model.cable.youngs_modulus
    }
    #[getter]
    fn cable_diameter(&self) -> f64 {
        self.model.cable.diameter
    }
    #[getter]
    fn routing_length(&self) -> f64 {
        self.model.cable.routing_length
    }

    #[getter]
    fn stretch_feed_forward(&self) -> bool {
        self.model.cable.stretch_feed_forward
    }

    #[getter]
    fn axial_stiffness(&self) -> f64 {
        let d = self.model.cable.diameter;
        self.model.cable.youngs_modulus * std::f64::consts::PI * d * d / 4.0
    }

    /// The same arm with other holes: planar `(2n, n+1, 2, 2)` flat, spatial
    /// every `[x, y, z]` flat (as `flat_holes`), m. `within_disks`: refuse a
    /// spatial hole outside its disk, as a robot file does.
    #[pyo3(signature = (holes, within_disks=true))]
    fn with_holes(&self, holes: Arr<'_>, within_disks: bool) -> PyResult<Self> {
        let h = slice("holes", &holes)?;
        Ok(CoreRobot::of(
            self.model.with_holes(h, within_disks).map_err(err)?,
        ))
    }

    /// The same arm with another cable material / routing length (validated)
    /// and controller premise (`None`: this arm's).
    #[pyo3(signature = (youngs_modulus, diameter, routing_length, stretch_feed_forward=None))]
    fn with_cable(
        &self,
        youngs_modulus: f64,
        diameter: f64,
        routing_length: f64,
        stretch_feed_forward: Option<bool>,
    ) -> PyResult<Self> {
        let cable = CableMaterial {
            youngs_modulus,
            diameter,
            routing_length,
            stretch_feed_forward: stretch_feed_forward
                .unwrap_or(self.model.cable.stretch_feed_forward),
            stated: true,
        };
        Ok(CoreRobot::of(self.model.with_cable(cable).map_err(err)?))
    }

    // ---- description (planar arms) ---------------------------------------
    /// `(2n, n+1, 2, 2)` flat: a planar arm's holes.
    #[getter]
    fn holes<'py>(&self, py: Python<'py>) -> PyResult<Array<'py>> {
        Ok(vec1(py, self.model.pair_holes().map_err(err)?.to_vec()))
    }

    /// The same robot with other loads: the force-controlled cables' tensions
    /// (N, file order) and gravity (the kind's `dim` components, m/s²).
    fn with_loads(&self, lower_tension: Arr<'_>, gravity: Arr<'_>) -> PyResult<Self> {
        let lo = slice("lower_tension", &lower_tension)?;
        let g = slice("gravity", &gravity)?;
        Ok(CoreRobot::of(self.model.with_loads(lo, g).map_err(err)?))
    }

    fn hole_height_error<'py>(&self, py: Python<'py>, dh: Arr<'_>) -> PyResult<Array<'py>> {
        let d = slice("dh", &dh)?;
        Ok(vec1(
            py,
            arm::hole_height_error(&self.model, d).map_err(err)?,
        ))
    }

    // ---- kinematics ----------------------------------------------------
    fn fk<'py>(&self, py: Python<'py>, theta: Arr<'_>, threads: usize) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, arm::fk)
    }

    fn fk_matrix<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, arm::fk_matrix)
    }

    fn disk_frames<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, arm::disk_frames)
    }

    fn fk_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, arm::fk_jacobian)
    }

    fn cable_lengths<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, arm::cable_lengths)
    }

    fn cable_jacobian<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Array<'py>> {
        self.theta_map(py, theta, threads, arm::cable_jacobian)
    }

    fn within_limits<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let t = slice("theta", &theta)?;
        let out = py
            .detach(|| arm::within_limits(&self.model, t, threads))
            .map_err(err)?;
        Ok(vec1(py, out))
    }

    // ---- solves --------------------------------------------------------
    /// Pose IK of targets `(N, TASK)`; `mask`: three weights (planar) or
    /// `"position"`, `"pointing"`, `"pose"` (spatial).
    #[pyo3(signature = (target, seed, mask, method, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn ik(
        &self,
        py: Python<'_>,
        target: Arr<'_>,
        seed: Option<Arr<'_>>,
        mask: MaskArg,
        method: &str,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolveResult> {
        let p = slice("target", &target)?;
        let s = opt_slice("seed", &seed)?;
        let mask = Mask::parse(self.model.kind, mask.core()).map_err(err)?;
        let how = ik_method(method)?;
        let o = options(tol, max_iter, enforce_limits)?;
        let out = py
            .detach(|| ik::solve_batch(&self.model, p, s, mask, how, &o, threads))
            .map_err(err)?;
        Ok(SolveResult::new(py, out))
    }

    /// Position-cable lengths `(N, m_pos)` to joint angles.
    #[pyo3(signature = (lengths, seed, method, tol, max_iter, enforce_limits, threads))]
    #[allow(clippy::too_many_arguments)]
    fn solve_cables(
        &self,
        py: Python<'_>,
        lengths: Arr<'_>,
        seed: Option<Arr<'_>>,
        method: &str,
        tol: f64,
        max_iter: u32,
        enforce_limits: bool,
        threads: usize,
    ) -> PyResult<SolveResult> {
        self.rigid("solve_cables")?;
        let u = slice("lengths", &lengths)?;
        let s = opt_slice("seed", &seed)?;
        let m = self::method(method)?;
        let o = options(tol, max_iter, enforce_limits)?;
        let out = py
            .detach(|| arm::solve_cables(&self.model, u, s, m, &o, threads))
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
        self.rigid("deviation")?;
        let t = slice("theta0", &theta0)?;
        let d = slice("dl", &dl)?;
        let h = opt_slice("holes", &holes)?;
        let m = self::method(method)?;
        let o = options(tol, max_iter, false)?;
        let (ds, sol) = py
            .detach(|| accuracy::deviation(&self.model, t, d, h, m, &o, threads))
            .map_err(err)?;
        DeviationResult::new(py, ds, sol)
    }

    /// Monte Carlo (`accuracy::monte_carlo`): per-disk `dh` (planar) or
    /// every-coordinate `dholes` errors (the kind's hole layout), the kind's
    /// quantities, the optional slack check.
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
        self.rigid("monte_carlo")?;
        let t = slice("theta0", &theta0)?;
        let d = slice("dl", &dl)?;
        let (dh, dholes) = (opt_slice("dh", &dh)?, opt_slice("dholes", &dholes)?);
        let m = self::method(method)?;
        let o = options(tol, max_iter, false)?;
        let st = py
            .detach(|| {
                let holes = accuracy::HoleErrors::of(&self.model, dh, dholes)?;
                accuracy::monte_carlo(&self.model, t, d, holes, m, &o, check_slack, threads)
            })
            .map_err(err)?;
        Ok(MonteCarloStats::new(py, st))
    }

    /// First-order sensitivities, either kind: `cable (N*task*m_pos)`,
    /// `groups (N*task*G)` per coherent hole group, `coords (N*task*3H)` over
    /// `flat_holes` when asked.
    #[pyo3(signature = (theta, coords, threads))]
    fn sensitivity(
        &self,
        py: Python<'_>,
        theta: Arr<'_>,
        coords: bool,
        threads: usize,
    ) -> PyResult<SensitivityResult> {
        self.rigid("sensitivity")?;
        let t = slice("theta", &theta)?;
        let s = py
            .detach(|| crate::sensitivity::sensitivities(&self.model, t, coords, threads))
            .map_err(err)?;
        Ok(SensitivityResult::new(py, s, coords))
    }

    /// The linear RMS of the tip position error (m) at `theta (N, n)` for
    /// uniform errors within `tol` (m; planar 2n: cables then disks; any
    /// other arm per position cable then per hole coordinate) and its
    /// gradient `(N, n)` in theta (central differences of `h` rad, in the core).
    #[pyo3(signature = (theta, tol, h, threads))]
    fn rms_amplification<'py>(
        &self,
        py: Python<'py>,
        theta: Arr<'_>,
        tol: Arr<'_>,
        h: f64,
        threads: usize,
    ) -> PyResult<(Array<'py>, Array<'py>)> {
        self.rigid("rms_amplification")?;
        let t = slice("theta", &theta)?;
        let tl = slice("tol", &tol)?;
        let (v, g) = py
            .detach(|| crate::sensitivity::rms_amplification(&self.model, t, tl, h, threads))
            .map_err(err)?;
        Ok((vec1(py, v), vec1(py, g)))
    }

    // ---- statics -------------------------------------------------------
    /// Position-cable tensions `(N, m_pos)` N and feasibility `(N,)`: the
    /// balance under gravity (`gravity` (3,), default the file's), the force
    /// cables' tensions (`force`, default the file's) and the tip wrench
    /// (`[F, M]`: 4 planar `Fx, Fy, Fz, Mz`, 6 spatial), shared or per row.
    /// With `friction` (the coefficient in the holes) the balance of the
    /// bounding sliding state, pulling (`pulling`) or releasing, and the
    /// routing's tensions (`docs/model.md`, "Friction in the holes").
    #[pyo3(signature = (theta, force, tip_wrench, gravity, min_tension, threads, friction=None, pulling=true))]
    #[allow(clippy::too_many_arguments)]
    fn tensions(
        &self,
        py: Python<'_>,
        theta: Arr<'_>,
        force: Option<Arr<'_>>,
        tip_wrench: Option<Arr<'_>>,
        gravity: Option<Vec<f64>>,
        min_tension: f64,
        threads: usize,
        friction: Option<f64>,
        pulling: bool,
    ) -> PyResult<TensionResult> {
        self.rigid("tensions")?;
        let t = slice("theta", &theta)?;
        let gravity = match gravity {
            None => None,
            Some(g) => Some(<[f64; 3]>::try_from(g.as_slice()).map_err(|_| {
                CdsmInputError::new_err(format!(
                    "`gravity`: expected 3 values (m/s^2), got {}",
                    g.len()
                ))
            })?),
        };
        let loads = Loads {
            gravity,
            force: opt_slice("force", &force)?,
            wrench: opt_slice("tip_wrench", &tip_wrench)?,
        };
        let (tension, feasible) = py
            .detach(|| {
                let sliding = friction.map(|mu| {
                    if pulling {
                        Sliding::pulling(mu)
                    } else {
                        Sliding::releasing(mu)
                    }
                });
                arm::tensions(&self.model, t, &loads, min_tension, sliding, threads)
            })
            .map_err(err)?;
        Ok(TensionResult::new(py, tension, feasible))
    }

    /// The coupled elastic cable solve of position-cable lengths `(N, m)`:
    /// loads as `tensions` (force tensions, tip wrench `[F, M]`, gravity (3,)).
    #[pyo3(signature = (lengths, seed, force, tip_wrench, gravity, min_tension, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn solve_elastic(
        &self,
        py: Python<'_>,
        lengths: Arr<'_>,
        seed: Option<Arr<'_>>,
        force: Option<Arr<'_>>,
        tip_wrench: Option<Arr<'_>>,
        gravity: Option<Vec<f64>>,
        min_tension: f64,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<ElasticResult> {
        self.rigid("solve_elastic")?;
        let u = slice("lengths", &lengths)?;
        let s = opt_slice("seed", &seed)?;
        let gravity = match gravity {
            None => None,
            Some(g) => Some(<[f64; 3]>::try_from(g.as_slice()).map_err(|_| {
                CdsmInputError::new_err(format!(
                    "`gravity`: expected 3 values (m/s^2), got {}",
                    g.len()
                ))
            })?),
        };
        let loads = crate::plant::LoadRows {
            force: opt_slice("force", &force)?,
            wrench: opt_slice("tip_wrench", &tip_wrench)?,
            gravity,
        };
        let o = options(tol, max_iter, false)?;
        let out = py
            .detach(|| {
                crate::plant::solve_elastic(&self.model, u, s, &loads, min_tension, &o, threads)
            })
            .map_err(err)?;
        ElasticResult::new(py, out)
    }

    // ---- elastic arms (crate::elastic) ----------------------------------
    /// Every joint's spring stiffness (N m/rad; 0: free).
    #[getter]
    fn joint_stiffness<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.joints.iter().map(|j| j.stiffness).collect())
    }

    /// Every joint's rest angle (rad).
    #[getter]
    fn rest_angles<'py>(&self, py: Python<'py>) -> Array<'py> {
        vec1(py, self.model.joints.iter().map(|j| j.rest).collect())
    }

    /// Indices of the displacement cables (file order).
    #[getter]
    fn displacement_cables(&self) -> Vec<usize> {
        self.model.displacement_cables()
    }

    /// Every cable's mode: "position", "force" or "displacement".
    #[getter]
    fn cable_modes(&self) -> Vec<&'static str> {
        self.model
            .cables
            .iter()
            .map(|c| match c.mode {
                Mode::Position => "position",
                Mode::Force => "force",
                Mode::Displacement => "displacement",
            })
            .collect()
    }

    /// How the plant settles this rigid arm with more position cables than
    /// joints: "potential" (its cable stated), "least_squares" (not); None
    /// for any other arm (`docs/model.md`, "Settling").
    #[getter]
    fn redundant_settle(&self) -> Option<&'static str> {
        self.model.redundant_settle().map(|s| s.name())
    }

    /// Whether the robot states its cable (a `[cable]` table or
    /// `with_cable`), else cdsm's default cable applies.
    #[getter]
    fn cable_stated(&self) -> bool {
        self.model.cable.stated
    }

    /// Per cable: actuator stiffness (N/m, inf: rigid), pretension (N), cap
    /// (N, inf: none); the defaults for cables other than displacement ones,
    /// but a position cable's pretension (`docs/model.md`, "Settling").
    #[getter]
    fn actuators<'py>(&self, py: Python<'py>) -> (Array<'py>, Array<'py>, Array<'py>) {
        let a: Vec<_> = self.model.cables.iter().map(|c| c.actuator).collect();
        (
            vec1(py, a.iter().map(|x| x.stiffness).collect()),
            vec1(py, a.iter().map(|x| x.pretension).collect()),
            vec1(py, a.iter().map(|x| x.max_tension).collect()),
        )
    }

    /// Every cable's rest length (m, at the rest angles) and series
    /// stiffness (N/m; NaN but for displacement cables).
    fn elastic_cables<'py>(&self, py: Python<'py>) -> (Array<'py>, Array<'py>) {
        let e = crate::elastic::Elastic::new(&self.model);
        (
            vec1(py, e.rest_lengths().to_vec()),
            vec1(py, e.series_stiffness().to_vec()),
        )
    }

    /// Frictionless equilibria (`crate::elastic::equilibria`): commands
    /// `lengths (N*m_pos)`, `displacements (N*m_d)` m, `tip_wrench` (the
    /// kind's rows, one or per row; empty: none), `seed (n)` or `(N*n)` rad.
    #[pyo3(signature = (lengths, displacements, tip_wrench, seed, sequence, xtol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn equilibrium(
        &self,
        py: Python<'_>,
        lengths: Arr<'_>,
        displacements: Arr<'_>,
        tip_wrench: Arr<'_>,
        seed: Option<Arr<'_>>,
        sequence: bool,
        xtol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<EquilibriumResult> {
        let batch = crate::elastic::Batch {
            lengths: slice("lengths", &lengths)?,
            displacements: slice("displacements", &displacements)?,
            wrench: slice("tip_wrench", &tip_wrench)?,
        };
        let s = opt_slice("seed", &seed)?;
        let out = py
            .detach(|| {
                crate::elastic::equilibria(
                    &self.model,
                    &batch,
                    s,
                    sequence,
                    xtol,
                    max_iter,
                    threads,
                )
            })
            .map_err(err)?;
        Ok(EquilibriumResult::new(py, out))
    }

    /// Derivatives of equilibria `theta (N*n)` rad by the implicit function
    /// theorem (`crate::elastic::derivatives`); commands as `equilibrium`.
    #[pyo3(signature = (lengths, displacements, tip_wrench, theta, threads))]
    fn equilibrium_derivatives(
        &self,
        py: Python<'_>,
        lengths: Arr<'_>,
        displacements: Arr<'_>,
        tip_wrench: Arr<'_>,
        theta: Arr<'_>,
        threads: usize,
    ) -> PyResult<EquilibriumDerivatives> {
        let batch = crate::elastic::Batch {
            lengths: slice("lengths", &lengths)?,
            displacements: slice("displacements", &displacements)?,
            wrench: slice("tip_wrench", &tip_wrench)?,
        };
        let t = slice("theta", &theta)?;
        let out = py
            .detach(|| crate::elastic::derivatives(&self.model, &batch, t, threads))
            .map_err(err)?;
        Ok(EquilibriumDerivatives::new(py, out))
    }

    // ---- the plant -----------------------------------------------------
    /// Names and sizes of the plant's effects, in parameter order.
    fn plant_effects(&self) -> Vec<(String, usize)> {
        plant::effects(&self.model)
    }

    /// Every parameter of the plant, in vector order: (block, label, SI unit).
    fn plant_parameters(&self) -> Vec<(String, String, String)> {
        plant::parameters(&self.model)
    }

    /// Lower and upper bounds of the plant's parameters (the physical domain).
    fn plant_bounds<'py>(&self, py: Python<'py>) -> (Array<'py>, Array<'py>) {
        plant::bounds(py, &self.model)
    }

    #[pyo3(signature = (params, theta_cmd, dl, reading, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn plant_predict(
        &self,
        py: Python<'_>,
        params: Arr<'_>,
        theta_cmd: Arr<'_>,
        dl: Arr<'_>,
        reading: Vec<u8>,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<PlantPrediction> {
        let data = Data::of(&theta_cmd, &dl, &reading)?;
        plant::predict(py, &self.model, params, &data, tol, max_iter, threads)
    }

    #[pyo3(signature = (params, free, theta_cmd, dl, reading, tol, max_iter, threads))]
    #[allow(clippy::too_many_arguments)]
    fn plant_linearise(
        &self,
        py: Python<'_>,
        params: Arr<'_>,
        free: Vec<usize>,
        theta_cmd: Arr<'_>,
        dl: Arr<'_>,
        reading: Vec<u8>,
        tol: f64,
        max_iter: u32,
        threads: usize,
    ) -> PyResult<PlantPrediction> {
        let data = Data::of(&theta_cmd, &dl, &reading)?;
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
    /// every fold's scored rows (`scored (F, N)`), folds in parallel. Several
    /// candidates in one call: `free` holds their free parameters one after
    /// another (`widths`: how many each; default one candidate) and
    /// `candidate (F,)` says which each fold's fit fits (default the first).
    #[pyo3(signature = (theta_cmd, dl, reading, measured, scored, free, scale, start, tol, max_iter, fit_iter, threads, widths=None, candidate=None))]
    #[allow(clippy::too_many_arguments)]
    fn plant_fit(
        &self,
        py: Python<'_>,
        theta_cmd: Arr<'_>,
        dl: Arr<'_>,
        reading: Vec<u8>,
        measured: Arr<'_>,
        scored: Vec<bool>,
        free: Vec<usize>,
        scale: Vec<f64>,
        start: Arr<'_>,
        tol: f64,
        max_iter: u32,
        fit_iter: u32,
        threads: usize,
        widths: Option<Vec<usize>>,
        candidate: Option<Vec<usize>>,
    ) -> PyResult<Vec<PlantFit>> {
        let data = Data::of(&theta_cmd, &dl, &reading)?;
        let widths = widths.unwrap_or_else(|| vec![free.len()]);
        let fits = scored.len() / reading.len().max(1);
        let candidate = candidate.unwrap_or_else(|| vec![0; fits]);
        let args = FitArgs {
            measured: slice("measured", &measured)?,
            scored: &scored,
            free: &free,
            scale: &scale,
            widths: &widths,
            candidate: &candidate,
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
        self.rigid("compensate")?;
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

/// The facts of the arm kind `name` (`kinds::KindInfo`): `name`, `dim`,
/// `task`, `task_axes` and `task_units`, `rotation` (`"angle"` or
/// `"vector"`), `quantities` and `quantity_units` (a Monte-Carlo study's),
/// `hole_grouping`, `layout` (the plant's blocks in order, each its effect's
/// name).
#[pyfunction]
pub fn kind_info<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyDict>> {
    let kind = Kind::named(name).ok_or_else(|| {
        err(CdsmError::Option {
            name: "kind".into(),
            problem: format!("must be \"planar\" or \"spatial\", got {name:?}"),
        })
    })?;
    let info = kind.info();
    let d = PyDict::new(py);
    d.set_item("name", info.name)?;
    d.set_item("dim", info.dim)?;
    d.set_item("task", info.task)?;
    d.set_item(
        "task_axes",
        info.task_axes.iter().map(|a| a.0).collect::<Vec<_>>(),
    )?;
    d.set_item(
        "task_units",
        info.task_axes.iter().map(|a| a.1).collect::<Vec<_>>(),
    )?;
    d.set_item("rotation", info.rotation.name())?;
    d.set_item(
        "quantities",
        info.quantities.iter().map(|q| q.0).collect::<Vec<_>>(),
    )?;
    d.set_item(
        "quantity_units",
        info.quantities.iter().map(|q| q.1).collect::<Vec<_>>(),
    )?;
    d.set_item("hole_grouping", info.holes.name())?;
    d.set_item(
        "layout",
        info.layout.iter().map(|b| b.0.name()).collect::<Vec<_>>(),
    )?;
    Ok(d)
}

/// The `kind` of a robot description: `"planar"` or `"spatial"`.
#[pyfunction]
pub fn robot_kind(text: &str) -> PyResult<String> {
    crate::model::kind_of(text).map_err(err)
}

/// Edges (m) of the Monte-Carlo histogram's regular bins (see `accuracy::hist_edges`).
/// `None` if `mu` is a friction coefficient of the physical domain (`[0,
/// FRICTION_MAX]`); an error naming the field `name` otherwise.
#[pyfunction]
pub fn check_friction(name: &str, mu: f64) -> PyResult<()> {
    crate::friction::check_mu(name, mu).map_err(err)
}

#[pyfunction]
pub fn hist_edges<'py>(py: Python<'py>) -> Array<'py> {
    vec1(py, accuracy::hist_edges().to_vec())
}

/// The SIMD instruction set the kernels dispatch to on this machine.
#[pyfunction]
pub fn simd_instruction_set() -> String {
    crate::simd::instruction_set()
}
