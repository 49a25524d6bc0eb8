"""Manufacturing errors as plant parameters: a Monte Carlo and first-order
sensitivities from the commands, for any arm the plant settles (rigid or
elastic). SI units: m, rad, N.

An error is a vector of the plant's flat parameters
(:mod:`cdsm.calibration.plant`: ``cable_offset`` per commanded cable, m;
``hole_position`` every hole coordinate of a commanded cable, m;
``joint_stiffness`` the relative spring change of each segment, 1; ...).
A sample is such a vector drawn uniformly within ± the tolerance of each
parameter; the Rust core's plant settles it (an elastic arm at the minimum
of its potential, a rigid arm by its cable solve) from the same commands —
joint angles ``theta_cmd`` and the commanded cables' extras ``dL`` (an
elastic arm: ``theta_cmd`` its rest angles, ``dL = -d`` for displacements
``d``), rows in sequence, each from the previous row's answer — and the
tip's deviation from the nominal plant's is reduced to the statistics of
:class:`~cdsm.accuracy.montecarlo.MonteCarlo` in the kind's quantities.

This is the Monte Carlo of an arm commanded by its cables rather than by
its joint angles (an elastic arm's statics is its equilibrium: the core's
:func:`~cdsm.accuracy.montecarlo.monte_carlo` solves rigid arms only).
"""

from __future__ import annotations

from typing import Dict, Mapping, Optional, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from .. import _cdsm
from .. import plant
from ..inputs import CdsmInputError, as_batch, as_count, as_tolerances
from ..progress import Progress
from ..robot import Robot
from ..plant import commanded_cables
from .montecarlo import MonteCarlo, chunk_sizes
from .sampling import METHODS, nearest_neighbours, sobol
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL, rotation_vectors
from .sensitivity import amplification_of
from .workspace import Workspace

__all__ = ["DEFAULT_TOLERANCES", "SENSITIVITY_BLOCKS", "COMMAND_RANGE", "PATH_TOLERANCE", "path_dependent",
           "tolerance_vector", "sample_parameters",
           "deviation_quantities", "pose_deviation", "monte_carlo_commands", "sensitivities_commands",
           "nominal_commands", "error_parameters", "hole_block", "deviation_commands", "sample_commands",
           "hole_columns", "hole_ties", "tie_faces", "position_matrix_commands", "amplification_commands", "equilibria"]

#: The tolerances of a study by plant block: the paper's ±1 mm on each
#: commanded cable's length and ±0.35 mm on every hole coordinate (spatial)
#: or disk's hole height (planar: the plant's ``hole_height``), m; an arm
#: takes the blocks its plant has.
DEFAULT_TOLERANCES: Dict[str, float] = {"cable_offset": PAPER_DL_TOL, "hole_position": PAPER_DH_TOL,
                                        "hole_height": PAPER_DH_TOL}

#: The half-width (m) of the box of commands :func:`sample_commands` samples: ±3 mm on every commanded cable.
COMMAND_RANGE = 3e-3

#: The blocks :func:`sensitivities_commands` differentiates by default (those
#: the arm's plant has: ``hole_position`` spatial, ``hole_height`` planar).
SENSITIVITY_BLOCKS = ("cable_offset", "hole_position", "hole_height", "joint_stiffness")


def tolerance_vector(robot: Robot, tolerances: Optional[Mapping[str, object]] = None) -> np.ndarray:
    """(P,) half-widths of the uniform errors, in the plant's flat vector
    (:func:`cdsm.calibration.plant.layout`): ``tolerances`` {block: a scalar
    or one value per parameter of the block} in the block's unit (m; 1 for
    ``joint_stiffness``), finite and >= 0; default :data:`DEFAULT_TOLERANCES`
    (the blocks this arm has). Other parameters 0 (not drawn). A block the
    arm's plant does not have: :class:`CdsmInputError` naming it."""
    lay = plant.layout(robot)
    given = {b: t for b, t in DEFAULT_TOLERANCES.items() if b in lay} if tolerances is None else dict(tolerances)
    out = np.zeros(plant.size(robot))
    for block, tol in given.items():
        if block not in lay:
            raise CdsmInputError(f"`tolerances`: this arm's plant has no block {block!r}; known: {', '.join(lay)}")
        sl = lay[block]
        out[sl] = as_tolerances(f"tolerances[{block!r}]", tol, sl.stop - sl.start)
    return out


def sample_parameters(tol: np.ndarray, samples: int, seed: int, chunk_index: int) -> np.ndarray:
    """(samples, P) plant parameters of one chunk, from the stream (seed,
    chunk_index): each parameter of nonzero tolerance uniform within ±``tol``
    (P,), in the order of the flat vector; the others 0."""
    rng = np.random.default_rng([int(seed), int(chunk_index)])
    drawn = np.flatnonzero(tol)
    out = np.zeros((int(samples), tol.size))
    out[:, drawn] = rng.uniform(-1.0, 1.0, (int(samples), drawn.size)) * tol[drawn]
    return out


def _rotation_matrices(v: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of rotation vectors (..., 3) rad."""
    return Rotation.from_rotvec(v.reshape(-1, 3)).as_matrix().reshape(v.shape + (3,))


def deviation_quantities(robot: Robot, nominal: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """(..., Q) the Monte Carlo's quantities (the kind's, ``robot.kind.quantities``)
    of the plant observations ``moved`` (..., t) against ``nominal`` (..., t):
    the position's components and norm (m), the attitude's change (planar
    ``dphi``, signed) or rotation angle (spatial, rad)."""
    kind = robot.kind
    dim = kind.dim
    dp = moved[..., :dim] - nominal[..., :dim]
    named = {f"d{a.upper()}": dp[..., i] for i, a in enumerate(kind.position_axes)}
    named[kind.quantities[kind.norm]] = np.linalg.norm(dp, axis=-1)
    rest = [q for q in kind.quantities if q not in named]
    named[rest[0]] = _ATTITUDE_ERROR[kind.rotation](nominal[..., dim:], moved[..., dim:])
    return np.stack([named[q] for q in kind.quantities], axis=-1)


def _rotation_change(nominal: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """(..., 3) the rotation from the nominal end frame to the moved one as a
    rotation vector in the base frame, rad (:func:`cdsm.accuracy.scenarios.deviation`'s)."""
    r0 = _rotation_matrices(nominal)
    rel = rotation_vectors(np.swapaxes(r0, -1, -2) @ _rotation_matrices(moved))
    return np.einsum("...ij,...j->...i", r0, rel)


def _angle_delta(nominal: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """(..., 1) the change of a planar attitude angle, rad."""
    return moved - nominal


#: The attitude's deviation by the kind's attitude form (:attr:`cdsm.kinds.Kind.rotation`).
_ATTITUDE_DEVIATION = {"angle": _angle_delta, "vector": _rotation_change}

#: The attitude's error quantity by the kind's attitude form (:attr:`cdsm.kinds.Kind.rotation`): the
#: deviation's signed angle (planar) or the length of its rotation vector (spatial), rad.
_ATTITUDE_ERROR = {"angle": lambda nominal, moved: _angle_delta(nominal, moved)[..., 0],
                   "vector": lambda nominal, moved: np.linalg.norm(_rotation_change(nominal, moved), axis=-1)}


def pose_deviation(robot: Robot, nominal: np.ndarray, moved: np.ndarray) -> np.ndarray:
    """(..., t) the tip deviation of the plant observations ``moved`` from
    ``nominal`` (both (..., t)) as a single-error scenario gives it
    (:class:`cdsm.study.ScenarioResult`): the position's change (m), then
    planar the angle's change, spatial the rotation vector (base frame) from
    the nominal end frame to the moved one (rad)."""
    dim = robot.kind.dim
    return np.concatenate([moved[..., :dim] - nominal[..., :dim],
                           _ATTITUDE_DEVIATION[robot.kind.rotation](nominal[..., dim:], moved[..., dim:])], axis=-1)


def hole_columns(robot: Robot) -> np.ndarray:
    """(k,) the entries of :attr:`Robot.flat_holes` the plant's
    ``hole_position`` block moves, in its order: every coordinate of the
    commanded cables' holes (cable by cable, face by face, x y z)."""
    sizes = [np.asarray(h).size for h in robot.holes]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    return np.concatenate([np.arange(starts[c], starts[c + 1]) for c in commanded_cables(robot)]).astype(np.int64)


def hole_ties(robot: Robot) -> tuple:
    """``(faces_b, faces_a)`` two (t,) index arrays into the plant's
    ``hole_position`` block (:func:`hole_columns` order): the coordinates of
    every face-b hole of a disk of zero thickness and of its face-a twin
    (:func:`cdsm.plant.plate_twins`: one physical hole, one error; drawn per
    face, on FTDCR v4 at ±1 µm the tips were biased 2–6× their spread).
    Empty for an arm without zero-thickness disks, and for a planar arm (its
    plant's holes move by ``hole_height``)."""
    if hole_block(robot) != "hole_position":
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return plant.plate_twins(robot, hole_columns(robot))


def tie_faces(robot: Robot, p: np.ndarray) -> np.ndarray:
    """The plant parameters ``p`` (..., P) with every zero-thickness disk's
    face-b hole error set to its face a's (:func:`hole_ties`): one error per
    physical hole. A copy."""
    b, a = hole_ties(robot)
    if not b.size:
        return np.array(p, dtype=np.float64)
    start = plant.layout(robot)["hole_position"].start
    return plant.tie_errors(p, (start + b, start + a))


def hole_block(robot: Robot) -> str:
    """The plant block of the arm's hole errors: ``hole_position`` (every
    hole coordinate of the commanded cables; spatial arms) or, without it,
    ``hole_height`` (a planar arm's per-disk hole height)."""
    return "hole_position" if "hole_position" in plant.layout(robot) else "hole_height"


def error_parameters(robot: Robot, dL=None, holes=None) -> np.ndarray:
    """(P,) the plant parameters of a manufacturing error: ``dL`` (m_c,) m on
    the commanded cables' lengths (``cable_offset``) and ``holes`` the
    kind's hole error (:attr:`cdsm.kinds.Kind.hole_error_arg`), m: spatial
    ``dholes`` (3 H,) on every hole coordinate in the order of
    :attr:`Robot.flat_holes` (the commanded cables' go to ``hole_position``;
    a move of another cable's hole has no block and is refused), planar
    ``dh`` (n,) per disk's hole height (``hole_height``)."""
    lay = plant.layout(robot)
    p = np.zeros(plant.size(robot))
    if dL is not None:
        p[lay["cable_offset"]] = np.asarray(dL, float).reshape(-1)
    if holes is not None:
        d = np.asarray(holes, float).reshape(-1)
        block = hole_block(robot)
        if block == "hole_height":
            p[lay[block]] = d
            return p
        cols = hole_columns(robot)
        rest = np.ones(d.size, bool)
        rest[cols] = False
        if np.any(d[rest]):
            raise CdsmInputError("`holes`: moves a hole of a cable the plant does not command")
        p[lay[block]] = d[cols]
    return p


def deviation_commands(robot: Robot, p, dL, theta_cmd=None):
    """(N, t) tip deviations (:func:`pose_deviation`) of the plant ``p`` (P,)
    from the nominal plant at the commands ``dL`` (N, m_c) m (rows in
    sequence; ``theta_cmd`` default the rest angles) and (N,) where both
    settle (NaN rows where not)."""
    t, d = nominal_commands(robot, dL, theta_cmd)
    both, conv = plant.predict(robot, np.stack([np.zeros(plant.size(robot)), np.asarray(p, float)]), t, d)
    ok = conv.all(axis=0)
    return np.where(ok[:, None], pose_deviation(robot, both[0], both[1]), np.nan), ok


def sample_commands(robot: Robot, configurations: int = 1000, method: str = "sobol", seed: int = 0, k: int = 6,
                    reach: float = COMMAND_RANGE) -> Workspace:
    """The ``commanded`` protocol's configurations: ``configurations``
    commands ``dL`` (N, m_c) m sampled in the box ±``reach`` on every
    commanded cable (``method`` ``"sobol"``, scrambled with ``seed``, or
    ``"random"``), the nominal plant settled at them in order (each from
    the previous answer: :func:`cdsm.calibration.plant.settle`), with each
    one's ``k`` nearest neighbours in command space, and the commands with
    two equilibria (:func:`path_dependent`: the jump points).
    ``reachable``: the equilibrium converged; ``grid`` and ``theta0`` the
    settled angles (rad), ``poses`` their tips, ``commands`` the commands."""
    count, k = as_count("configurations", configurations, 1), as_count("k", k, 1)
    if count <= k:
        raise CdsmInputError(f"`configurations`: need more than k = {k} configurations, got {count}")
    m = plant.commands(robot)
    if method == "sobol":
        u = sobol(count, m, scramble=True, seed=seed)
    elif method == "random":
        u = np.random.default_rng([int(seed), 0x5A4D]).random((count, m))
    else:
        raise CdsmInputError(f"`method`: expected one of {', '.join(map(repr, METHODS))}, got {method!r}")
    d = np.ascontiguousarray((2.0 * u - 1.0) * float(reach))
    t = np.tile(robot.rest_angles, (count, 1))
    theta, ok = plant.settle(robot, np.zeros(plant.size(robot)), t, d)
    poses = plant.predict(robot, np.zeros(plant.size(robot)), t, d)[0]
    return Workspace("commanded", theta.copy(), poses, theta, np.asarray(ok, bool), nearest_neighbours(d, k),
                     params=dict(method=method, seed=int(seed), k=int(k), reach_m=float(reach)), commands=d,
                     path_dependent=path_dependent(robot, d, theta, ok))


#: Two equilibria of one command count as different beyond this tip distance
#: (m; 0.05 mm, the jump tests' ``min_change``: below what a tracker resolves).
PATH_TOLERANCE = 5e-5


def path_dependent(robot: Robot, dL, theta, settled) -> np.ndarray:
    """(N,) bool: the commands ``dL`` (N, m_c) m whose equilibrium depends on
    where the arm starts — settled along the rows (``theta`` (N, n) rad,
    ``settled`` (N,), as the plant settles a sequence) and again each from
    the rest angles, the two tips more than :data:`PATH_TOLERANCE` apart or
    one settled and the other not: the arm has two equilibria there (a snap
    between them is a jump). Elsewhere the equilibrium is the one minimiser
    of the potential and continuous in the commands (the slack transitions
    make kinks, not jumps)."""
    t, d = nominal_commands(robot, dL)
    cold = equilibria(robot, d, t, sequence=False)
    task = robot.kind.dim
    warm_tip = robot.fk(np.where(np.asarray(settled, bool)[:, None], theta, robot.rest_angles))[:, :task]
    cold_tip = robot.fk(np.where(cold.converged[:, None], cold.theta, robot.rest_angles))[:, :task]
    apart = np.linalg.norm(warm_tip - cold_tip, axis=1) > PATH_TOLERANCE
    return (np.asarray(settled, bool) != cold.converged) | (np.asarray(settled, bool) & cold.converged & apart)


def nominal_commands(robot: Robot, dL, theta_cmd=None):
    """The commands as the plant takes them: ``theta_cmd`` (N, n) rad (default
    the rest angles, :attr:`Robot.rest_angles`) and ``dL`` (N, m_c) m on the
    commanded cables (:func:`cdsm.calibration.plant.commands`), validated."""
    d, _ = as_batch("dL", dL, plant.commands(robot))
    t = np.tile(robot.rest_angles, (len(d), 1)) if theta_cmd is None else as_batch("theta_cmd", theta_cmd, robot.n)[0]
    if len(t) != len(d):
        raise CdsmInputError(f"`theta_cmd`: expected {len(d)} rows (one per row of `dL`), got {len(t)}")
    return t, d


def _chunk(robot: Robot, pp: np.ndarray, t: np.ndarray, d: np.ndarray, nominal: np.ndarray,
           theta0: np.ndarray) -> MonteCarlo:
    """The statistics of the samples ``pp`` (K, P) at every command row."""
    obs, conv = plant.predict(robot, pp, t, d)
    q = deviation_quantities(robot, nominal[None], obs)
    ok = conv & np.isfinite(q).all(axis=-1)
    qz = np.where(ok[..., None], q, 0.0)
    big = np.where(ok[..., None], q, -np.inf)
    small = np.where(ok[..., None], q, np.inf)
    edges = MonteCarlo.hist_edges()
    bins = np.searchsorted(edges, q[..., robot.kind.norm], side="right")
    hist = np.zeros((len(t), _cdsm.HIST_BINS), np.int64)
    for j in range(len(t)):
        hist[j] = np.bincount(bins[ok[:, j], j], minlength=_cdsm.HIST_BINS)
    return MonteCarlo(theta0=theta0, count=ok.sum(axis=0).astype(np.int64), failed=(~ok).sum(axis=0).astype(np.int64),
                      sum=qz.sum(axis=0), sum_sq=(qz * qz).sum(axis=0), min=small.min(axis=0), max=big.max(axis=0),
                      hist=hist, hist_lo=0, quantities=robot.kind.quantities)


def monte_carlo_commands(robot: Robot, dL, theta_cmd=None, samples: int = 200, seed: int = 0,
                         tolerances: Optional[Mapping[str, object]] = None, chunk: int = 50,
                         progress: bool = True, label: str = "monte carlo (plant)") -> MonteCarlo:
    """Random manufacturing errors on the arm commanded by ``dL`` (N, m_c) m
    (and ``theta_cmd`` (N, n) rad, default the rest angles;
    :func:`nominal_commands`): ``samples`` parameter vectors drawn within
    ±:func:`tolerance_vector` (``tolerances`` {plant block: half-width}),
    chunk c of ``chunk`` samples from the stream (seed, c); each sample runs
    the N rows in sequence in the core's plant. Per row: statistics of the
    deviation of the settled tip from the nominal plant's
    (:func:`deviation_quantities`). ``theta0`` of the result is the nominal
    plant's settled angles; a row the nominal plant does not settle counts
    every sample failed. A zero-thickness disk's two faces take one error
    (face a's: :func:`tie_faces`)."""
    t, d = nominal_commands(robot, dL, theta_cmd)
    samples, chunk, seed = as_count("samples", samples, 1), as_count("chunk", chunk, 1), as_count("seed", seed)
    tol = tolerance_vector(robot, tolerances)
    zero = np.zeros(plant.size(robot))
    nominal, ok0 = plant.predict(robot, zero, t, d)
    theta0, _ = plant.settle(robot, zero, t, d)
    out = None
    bar = Progress(samples, label, progress)
    for c, m in enumerate(chunk_sizes(samples, chunk)):
        part = _chunk(robot, tie_faces(robot, sample_parameters(tol, m, seed, c)), t, d, nominal, theta0)
        if out is None:
            out = part
        else:
            out.merge(part)
        bar.update(m)
    names = [n for n, _, _ in plant.parameter_labels(robot)]
    out.params = dict(samples=samples, seed=seed, chunk=chunk, commands=len(t), settled=int(ok0.sum()),
                      tolerances={b: tol[plant.layout(robot)[b]].tolist() for b in sorted(set(
                          names[i] for i in np.flatnonzero(tol)))})
    return out


def sensitivities_commands(robot: Robot, dL, theta_cmd=None,
                           blocks: Optional[Sequence[str]] = None) -> Dict[str, np.ndarray]:
    """First-order sensitivities of the tip to the plant's parameters at the
    commands ``dL`` (N, m_c) m (``theta_cmd`` default the rest angles), by
    the implicit function theorem at the settled configurations (the core's
    plant Jacobian, no finite differences): {block: (N, t, k)} the kind's
    task vector (planar [x, y, phi], spatial [x, y, z, rx, ry, rz]: m, and
    the rotation vector in rad) per parameter of the block (``cable_offset``
    per m of a commanded cable's rest length — a displacement ``d`` pulls
    the cable by ``-offset`` —; ``hole_position`` per m of every hole
    coordinate; ``joint_stiffness`` per unit relative change of a segment's
    springs; planar ``hole_height`` per m of a disk's hole height), for the
    ``blocks`` (default those of :data:`SENSITIVITY_BLOCKS` this arm's plant
    has); also ``"converged"`` (N,) bool (NaN rows where the nominal plant
    does not settle)."""
    t, d = nominal_commands(robot, dL, theta_cmd)
    lay = plant.layout(robot)
    blocks = [b for b in SENSITIVITY_BLOCKS if b in lay] if blocks is None else list(blocks)
    bad = [b for b in blocks if b not in lay]
    if bad:
        raise CdsmInputError(f"`blocks`: this arm's plant has no block {bad[0]!r}; known: {', '.join(lay)}")
    free = np.concatenate([np.arange(lay[b].start, lay[b].stop) for b in blocks]).astype(np.int64)
    _, conv, jac = plant.linearise(robot, np.zeros(plant.size(robot)), free, t, d)
    jac = np.where(conv[:, None, None], jac, np.nan)
    out: Dict[str, np.ndarray] = {"converged": conv}
    start = 0
    for b in blocks:
        k = lay[b].stop - lay[b].start
        out[b] = jac[:, :, start:start + k]
        start += k
    return out


def position_matrix_commands(robot: Robot, dL, theta_cmd=None) -> np.ndarray:
    """(N, d, m_c + k) the linear map from every error — the commanded
    cables' lengths (``cable_offset``), then every coordinate of their holes
    (``hole_position``) — to the tip position (d = the kind's position
    axes), m/m, at the commands ``dL`` (N, m_c) m: the columns of
    :func:`cdsm.accuracy.sensitivity.position_matrix` for an arm commanded
    by its cables (:func:`sensitivities_commands`), one error per physical
    hole (a zero-thickness disk's face-b column added to face a's and set to
    0, :func:`hole_ties`). NaN rows where the nominal plant does not settle."""
    holes = hole_block(robot)
    s = sensitivities_commands(robot, dL, theta_cmd, blocks=("cable_offset", holes))
    d = robot.kind.dim
    h = plant.join_columns(s[holes][:, :d, :], hole_ties(robot))  # one error per physical hole
    return np.concatenate([s["cable_offset"][:, :d, :], h], axis=2)


def amplification_commands(robot: Robot, ws: Workspace) -> dict:
    """:func:`cdsm.accuracy.sensitivity.amplification_maps` of a workspace
    of commands (``ws.commands``, :func:`sample_commands`): per configuration
    the tip and the worst-case and RMS amplification (mm of tip per mm) of
    the commanded cables' lengths and of every hole coordinate, from the
    plant's implicit-function sensitivities; NaN where not settled."""
    ok = np.asarray(ws.reachable, bool)
    m = plant.commands(robot)
    holes = plant.layout(robot)[hole_block(robot)]
    mat = np.full((len(ok), robot.kind.dim, m + holes.stop - holes.start), np.nan)
    if ok.any():
        mat[ok] = position_matrix_commands(robot, ws.commands[ok])
    ok = ok & np.isfinite(mat).all(axis=(1, 2))
    return amplification_of(robot, ws, mat[:, :, :m], mat[:, :, m:], ok)


def equilibria(robot: Robot, dL, theta_cmd=None, sequence: bool = True):
    """:meth:`Robot.equilibrium` of the plant's commands ``dL`` (N, m_c) m (the
    position cables their lengths at ``theta_cmd`` + dL, the displacement
    cables ``-dL``), the rows in sequence from the rest angles as the plant
    settles them (``sequence=False``: each row from the rest angles): an
    :class:`~cdsm.elastic.Equilibrium` (tensions of every cable, slack and
    capped flags)."""
    t, d = nominal_commands(robot, dL, theta_cmd)
    cmd = commanded_cables(robot)
    pos = [i for i, c in enumerate(cmd) if c in set(robot.position_cables)]
    dis = [i for i, c in enumerate(cmd) if c in set(robot.displacement_cables)]
    lengths = (plant.command_lengths(robot, t) + d)[:, pos] if pos else None
    return robot.equilibrium(lengths=lengths, displacements=-d[:, dis] if dis else None, seed=robot.rest_angles,
                             sequence=sequence)
