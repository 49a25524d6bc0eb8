"""Type stub of the Rust extension ``cdsm._cdsm`` (SI units: m, rad, N, kg).

Batch arrays cross the boundary flat and C-contiguous (float64); the Python
front (``cdsm.Robot`` and friends) checks shapes, converts dtypes and reshapes.
Results come back as the named classes below.
"""

from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
Bool = NDArray[np.bool_]
U8 = NDArray[np.uint8]
U32 = NDArray[np.uint32]
U64 = NDArray[np.uint64]

class CdsmInputError(ValueError):
    """Bad input: the message names the field and the problem."""

PAPER_TOML: str
HIST_LO: float
HIST_PER_DECADE: int
HIST_BINS: int
QUANTITIES: int
REASONS: List[str]
ELASTIC_REASONS: List[str]
ELASTIC_XTOL: float
PLANT_REASONS: List[str]
CLEARANCE_WIDTH: float
FRICTION_TYPICAL: float
FRICTION_MAX: float

def check_friction(name: str, mu: float) -> None: ...

def hist_edges() -> F64: ...
def simd_instruction_set() -> str: ...

class SolveResult:
    theta: F64
    converged: Bool
    iterations: U32
    residual: F64
    within_limits: Bool
    reason: U8

class DeviationResult:
    ds: F64
    solution: SolveResult

class MonteCarloStats:
    quantities: int
    count: U64
    failed: U64
    sum: F64
    sum_sq: F64
    min: F64
    max: F64
    hist: U32  # (N * hist_width,) bins hist_lo .. hist_lo + hist_width
    hist_lo: int
    hist_width: int
    slack: U64

class SensitivityResult:
    cable: F64
    groups: F64
    coords: Optional[F64]
    ok: Bool

class ElasticResult:
    solution: SolveResult
    tension: F64
    feasible: Bool

class EquilibriumResult:
    theta: F64
    tension: F64
    slack: Bool
    capped: Bool
    converged: Bool
    reason: U8
    iterations: U32
    gradient: F64
    energy: F64

class EquilibriumDerivatives:
    theta_lengths: F64
    theta_displacements: F64
    theta_wrench: F64
    task_lengths: F64
    task_displacements: F64
    task_wrench: F64
    tension_lengths: F64
    tension_displacements: F64
    tension_wrench: F64
    definite: Bool

class PlantPrediction:
    observation: F64
    converged: Bool
    theta: F64
    reason: U8
    jacobian: Optional[F64]

class PlantFit:
    p: F64
    converged: bool
    iterations: int
    cost: float
    m: int
    r_factor: F64
    reason: int
    prediction: PlantPrediction

class CompensationResult:
    command: F64
    nominal: F64
    converged: Bool
    residual: F64
    theta: F64
    seen: F64
    seen_nominal: F64

class TensionResult:
    tension: F64
    feasible: Bool

class CoreRobot:
    """An arm of either kind (the one model); planar-only calls raise
    CdsmInputError on a spatial arm."""
    @staticmethod
    def from_toml(text: str) -> "CoreRobot": ...
    @staticmethod
    def from_data(data: dict) -> "CoreRobot": ...
    @staticmethod
    def paper() -> "CoreRobot": ...
    def to_toml(self) -> str: ...
    @property
    def kind(self) -> str: ...
    def structure(self) -> Dict[str, Any]: ...
    @property
    def n(self) -> int: ...
    @property
    def name(self) -> str: ...
    @property
    def joint_limits(self) -> F64: ...
    @property
    def axes(self) -> F64: ...
    @property
    def gravity(self) -> F64: ...
    @property
    def straight_length(self) -> float: ...
    @property
    def cables(self) -> int: ...
    @property
    def position_cables(self) -> List[int]: ...
    @property
    def cable_ends(self) -> List[int]: ...
    @property
    def cable_tensions(self) -> F64: ...
    @property
    def flat_holes(self) -> F64: ...
    @property
    def radii(self) -> F64: ...
    @property
    def mass(self) -> F64: ...
    @property
    def offsets(self) -> F64: ...
    @property
    def joint_disks(self) -> List[int]: ...
    @property
    def disk_link_after(self) -> F64: ...
    @property
    def disk_thickness(self) -> F64: ...
    @property
    def com(self) -> F64: ...
    @property
    def youngs_modulus(self) -> float: ...
    @property
    def cable_diameter(self) -> float: ...
    @property
    def routing_length(self) -> float: ...
    @property
    def stretch_feed_forward(self) -> bool: ...
    @property
    def cable_stated(self) -> bool: ...
    @property
    def redundant_settle(self) -> Optional[str]: ...
    @property
    def axial_stiffness(self) -> float: ...
    @property
    def holes(self) -> F64: ...
    def with_holes(self, holes: F64, within_disks: bool = True) -> "CoreRobot": ...
    def with_cable(self, youngs_modulus: float, diameter: float, routing_length: float,
                   stretch_feed_forward: Optional[bool] = None) -> "CoreRobot": ...
    def with_loads(self, lower_tension: F64, gravity: F64) -> "CoreRobot": ...
    def hole_height_error(self, dh: F64) -> F64: ...
    def fk(self, theta: F64, threads: int) -> F64: ...
    def fk_matrix(self, theta: F64, threads: int) -> F64: ...
    def disk_frames(self, theta: F64, threads: int) -> F64: ...
    def fk_jacobian(self, theta: F64, threads: int) -> F64: ...
    def cable_lengths(self, theta: F64, threads: int) -> F64: ...
    def cable_jacobian(self, theta: F64, threads: int) -> F64: ...
    def within_limits(self, theta: F64, threads: int) -> Bool: ...
    def ik(self, target: F64, seed: Optional[F64], mask: Union[str, Sequence[float]], method: str, tol: float,
           max_iter: int, enforce_limits: bool, threads: int) -> SolveResult: ...
    def solve_cables(self, lengths: F64, seed: Optional[F64], method: str, tol: float, max_iter: int,
                     enforce_limits: bool, threads: int) -> SolveResult: ...
    def deviation(self, theta0: F64, dl: F64, holes: Optional[F64], method: str, tol: float,
                  max_iter: int, threads: int) -> DeviationResult: ...
    def monte_carlo(self, theta0: F64, dl: F64, dh: Optional[F64], dholes: Optional[F64], method: str,
                    tol: float, max_iter: int, check_slack: bool, threads: int) -> MonteCarloStats: ...
    def sensitivity(self, theta: F64, coords: bool, threads: int) -> SensitivityResult: ...
    def rms_amplification(self, theta: F64, tol: F64, h: float, threads: int) -> Tuple[F64, F64]: ...
    def tensions(self, theta: F64, force: Optional[F64], tip_wrench: Optional[F64],
                 gravity: Optional[Sequence[float]], min_tension: float, threads: int,
                 friction: Optional[float] = None, pulling: bool = True) -> TensionResult: ...
    def solve_elastic(self, lengths: F64, seed: Optional[F64], force: Optional[F64], tip_wrench: Optional[F64],
                      gravity: Optional[Sequence[float]], min_tension: float, tol: float, max_iter: int,
                      threads: int) -> ElasticResult: ...
    @property
    def joint_stiffness(self) -> F64: ...
    @property
    def rest_angles(self) -> F64: ...
    @property
    def displacement_cables(self) -> List[int]: ...
    @property
    def cable_modes(self) -> List[str]: ...
    @property
    def actuators(self) -> Tuple[F64, F64, F64]: ...
    def elastic_cables(self) -> Tuple[F64, F64]: ...
    def equilibrium(self, lengths: F64, displacements: F64, tip_wrench: F64, seed: Optional[F64], sequence: bool,
                    xtol: float, max_iter: int, threads: int) -> EquilibriumResult: ...
    def equilibrium_derivatives(self, lengths: F64, displacements: F64, tip_wrench: F64, theta: F64,
                                threads: int) -> EquilibriumDerivatives: ...
    def plant_effects(self) -> List[Tuple[str, int]]: ...
    def plant_parameters(self) -> List[Tuple[str, str, str]]: ...
    def plant_bounds(self) -> Tuple[F64, F64]: ...
    def plant_predict(self, params: F64, theta_cmd: F64, dl: F64, reading: Sequence[int], tol: float,
                      max_iter: int, threads: int) -> PlantPrediction: ...
    def plant_linearise(self, params: F64, free: Sequence[int], theta_cmd: F64, dl: F64, reading: Sequence[int],
                        tol: float, max_iter: int, threads: int) -> PlantPrediction: ...
    def plant_fit(self, theta_cmd: F64, dl: F64, reading: Sequence[int], measured: F64, scored: Sequence[bool],
                  free: Sequence[int], scale: Sequence[float], start: F64, tol: float, max_iter: int,
                  fit_iter: int, threads: int) -> List[PlantFit]: ...
    def compensate(self, params: F64, theta_cmd: F64, targets: F64, weights: Sequence[float],
                   start: Optional[F64], tol: float, settle_tol: float, max_iter: int,
                   threads: int) -> CompensationResult: ...

def robot_kind(text: str) -> str: ...
def kind_info(name: str) -> Dict[str, Any]: ...
