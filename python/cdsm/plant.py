"""The real arm as the nominal model plus unmodelled effects: the plant of the
Rust core, its parameter blocks and its effect library. SI units (m, rad, N).
(The virtual prototype that makes measurement data from it:
:mod:`cdsm.calibration.plant`.)

The plant lives in the Rust core (``rust/plant.rs``); its equations are in
``docs/model.md`` ("The plant"). All-zero parameters give the nominal model
exactly. The flat parameter vector is made of blocks (:func:`layout`), and
an *effect* of the diagnosis library is one or more blocks:

=====================  ===========  ================================================
effect                 parameters   meaning
=====================  ===========  ================================================
actuation_scale        1            s: actuators realise L_ref + (1 + s)(r - L_ref)
cable_offset           n            constant length offset of each upper cable, m
hole_height            n            hole-height error of each cable pair, m
link_length            n + 1        base -> joint 1, then joint i -> disk i, m
cable_elasticity       1            compliance 1/(E A), 1/N
hole_clearance         1 + 1        c >= 0 (m): holes shift c·tanh(theta / w) to the
                                    concave side; w = 0.01 rad + clearance_width
frame_misalignment     3            instrument frame: rotation (rad), x, y (m)
tip_offset             2            measured point offset in the end frame, x, y (m)
backlash               n            dead-band half-width of each upper cable, m
cable_friction         1            Coulomb friction mu of every cable in every hole
                                    (1; its change of the tensions stretches the
                                    cables at the robot file's 1/(E A) plus any
                                    cable_elasticity; memory like backlash)
=====================  ===========  ================================================

Rows run in sequence (backlash and friction have memory): give them in execution order.

Elastic arms (:attr:`Robot.is_elastic`: joint springs or displacement cables;
``docs/model.md``, "Elastic arms in the plant") have the same plant with the
settle their frictionless equilibrium, each command warm-started from the
previous one. Their commanded cables (:func:`commanded_cables`,
the width of ``dL``) are the position and displacement cables in file order:
``theta_cmd`` the rest angles and ``dL = -d`` commands the displacements ``d`` (m).
``cable_offset``, ``backlash`` and ``hole_position`` act per commanded cable;
they have no ``cable_elasticity`` or ``hole_clearance`` block (``cable_friction``
is the capstan friction of their statics, fitted only when named:
:data:`ELASTIC_ON_REQUEST`), and two of their own:

=====================  ===========  ================================================
effect                 parameters   meaning
=====================  ===========  ================================================
joint_stiffness        segments     s > -1 per segment (the joints between
                                    consecutive cable terminations): its springs
                                    k -> (1 + s) k, 1
cable_angle            m_c          spatial: every hole of a commanded cable turned
                                    about the backbone axis x of its disk, rad
=====================  ===========  ================================================

A spatial arm (``docs/spatial.md``) goes through the same plant — one plant
over the kind in the Rust core — with the effects that carry over (:data:`SPATIAL_EFFECTS`:
``actuation_scale``, ``cable_offset`` and ``backlash`` on the
position-controlled cables, ``hole_position`` (3-D per hole of those
cables), ``link_length`` (3-D per joint offset and per disk), ``cable_elasticity``,
``frame_misalignment`` (rotation vector and translation) and ``tip_offset``
(3-D)); its observations are ``[x, y, z, rx, ry, rz]``. Every function below
takes either kind (:func:`effects_of`, :func:`width`).
"""

from __future__ import annotations

import warnings
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from . import _cdsm, deprecated
from .inputs import CdsmInputError, as_array, as_batch, as_finite, as_iterations
from .robot import Robot, kind_facts

__all__ = ["EFFECTS", "BLOCKS", "MEMORY_EFFECTS", "EFFECT_BLOCKS", "TYPICAL", "layout", "size",
           "params", "check_params", "MAX_PARAMETER", "effect_indices", "parameter_blocks", "parameter_names",
           "parameter_labels", "bounds", "reading_codes", "predict", "linearise", "settle",
           "SPATIAL_EFFECTS", "ELASTIC_GEOMETRY", "ELASTIC_ON_REQUEST", "effects_of", "check_effects", "width",
           "dims", "commands", "command_lengths", "taut_commands", "READING_CODES", "commanded_cables",
           "check_commands", "plate_twins", "tie_errors", "join_columns"]

#: What a row of the plant's data sets reads, by code (see ``docs/model.md``):
#: the tip's pose (``"absolute"``), its move since the previous row
#: (``"displacement"``) or nothing (``"unmeasured"``: the row only runs).
READING_CODES = {"absolute": 0, "displacement": 1, "unmeasured": 2}


def commanded_cables(robot) -> List[int]:
    """The cables a row commands (0-based, the robot's order): the position
    cables, and an elastic arm's displacement cables (force cables keep
    their set tension)."""
    return sorted(list(robot.position_cables) + list(robot.displacement_cables))

#: The planar plant's parameter blocks, in the order of its flat vector (the
#: Rust core's layout of the kind, ``kind_facts("planar")["layout"]``:
#: :func:`layout` gives any robot's with its sizes).
BLOCKS: Tuple[str, ...] = kind_facts("planar")["layout"]

#: The blocks an effect of the library fits (default: the block of its name).
EFFECT_BLOCKS: Dict[str, Tuple[str, ...]] = {"hole_clearance": ("hole_clearance", "clearance_width")}


def _library(blocks: Sequence[str]) -> Tuple[str, ...]:
    """The effects of a layout's blocks: each block but those another effect
    fits with its own (:data:`EFFECT_BLOCKS`), in the layout's order."""
    return tuple(b for b in blocks if not any(b in v[1:] for v in EFFECT_BLOCKS.values()))


#: The effects of the diagnosis library of planar arms.
EFFECTS: Tuple[str, ...] = _library(BLOCKS)

#: The effects with memory: what a row shows depends on the direction the
#: cables moved before it (backlash's dead band, friction's sliding state).
MEMORY_EFFECTS: Tuple[str, ...] = ("backlash", "cable_friction")

#: The effects of the diagnosis library of spatial arms (``hole_position``
#: in 3-D where a planar arm has ``hole_height``; ``joint_axis``: each
#: joint's axis tilted by two angles).
SPATIAL_EFFECTS: Tuple[str, ...] = _library(kind_facts("spatial")["layout"])

# A magnitude a real prototype could have, per block (the unit the fit works
# in, and the size of generated test effects): 2 % actuation error, 0.2 mm
# offsets and holes, 0.3 mm links, a polymer-like compliance (E A ~ 50 N),
# 0.15 mm clearance and a 10 mrad transition, 5 mrad / 5 mm frame, 1 mm tip
# offset, 30 µm of backlash, 10 mrad (0.6 deg) of joint-axis tilt, the core's
# typical friction 0.15 (greased steel on metal, docs/model.md "Friction in
# the holes"); elastic arms: 10 % of a segment's joint springs, 20 mrad
# (1.1 deg) of a cable's angle about the backbone.
TYPICAL: Dict[str, float] = {
    "actuation_scale": 0.02, "cable_offset": 2e-4, "hole_height": 2e-4, "hole_position": 2e-4,
    "link_length": 3e-4, "cable_elasticity": 0.02, "hole_clearance": 1.5e-4, "clearance_width": 0.01,
    "frame_misalignment": 5e-3, "tip_offset": 1e-3, "backlash": 3e-5, "joint_axis": 1e-2,
    "cable_friction": _cdsm.FRICTION_TYPICAL, "joint_stiffness": 0.1, "cable_angle": 0.02,
}
assert set(BLOCKS) | set(SPATIAL_EFFECTS) <= set(TYPICAL), "a typical size per parameter block"

#: The largest size of any plant parameter a model takes (SI): a kilometre
#: of length (the robot file's limit), 1000 rad, a 1000-fold scale, a
#: compliance of 1000 /N — beyond the typical sizes above by far more than
#: any prototype (:func:`check_params`).
MAX_PARAMETER = 1e3


#: Blocks of an elastic arm's plant outside its default library: the geometry of
#: every hole, link and joint axis of the lumped joints (FTDCR v4: 1107, 270 and 120
#: numbers), fitted only when named (:func:`check_effects`); a tendon's hole errors
#: are its ``cable_angle`` and ``cable_offset`` in the library.
ELASTIC_GEOMETRY: Tuple[str, ...] = ("hole_position", "link_length", "joint_axis")

#: Every block of an elastic arm's plant fitted only when named: the geometry
#: (:data:`ELASTIC_GEOMETRY`) and friction in the holes (``cable_friction``: a fit
#: with it settles the non-symmetric capstan system, about 20 times the cost of a
#: frictionless fit on FTDCR v4, whose real recordings put mu at 0.0008).
ELASTIC_ON_REQUEST: Tuple[str, ...] = ELASTIC_GEOMETRY + ("cable_friction",)


def effects_of(robot) -> Tuple[str, ...]:
    """The diagnosis library of a robot: its kind's layout's effects; an elastic
    arm's (:attr:`Robot.is_elastic`) its own layout's (:func:`layout`: without
    ``cable_elasticity`` and ``hole_clearance``, with ``joint_stiffness`` and,
    spatial, ``cable_angle``) but :data:`ELASTIC_ON_REQUEST`."""
    if robot.is_elastic:
        return _library([name for name, k in robot.core.plant_effects() if k and name not in ELASTIC_ON_REQUEST])
    return _library(kind_facts(robot.kind)["layout"])


def check_effects(robot, effects: Sequence[str], field: str = "effects") -> List[str]:
    """``effects`` as a list, each one of the library of ``robot``'s kind (an
    elastic arm's also the :data:`ELASTIC_ON_REQUEST` blocks of its layout);
    :class:`CdsmInputError` naming ``field``, the unknown names and the
    kind's library otherwise."""
    known = effects_of(robot)
    if robot.is_elastic:
        known += tuple(b for b, k in robot.core.plant_effects() if k and b in ELASTIC_ON_REQUEST)
    names = list(effects)
    bad = [e for e in names if e not in known]
    if bad:
        raise CdsmInputError(f"`{field}`: unknown effect(s) {', '.join(map(repr, bad))} for a {robot.kind} arm; "
                             f"known: {', '.join(known)}")
    return names


def width(robot) -> int:
    """Observed components per row: 3 ([x, y, phi]) planar, 6 ([x, y, z, rx, ry, rz]) spatial."""
    return kind_facts(robot.kind)["task"]


def dims(robot) -> int:
    """Position components per row: 2 planar, 3 spatial."""
    return kind_facts(robot.kind)["dim"]


def command_lengths(robot, theta) -> np.ndarray:
    """The nominal lengths (m) of the commanded cables (:func:`commanded_cables`)
    at ``theta`` (N, n) rad."""
    return robot.cable_lengths(theta)[..., commanded_cables(robot)]


def commands(robot) -> int:
    """Commanded cables per row (the width of ``dL``, :func:`commanded_cables`):
    the position-controlled cables of a rigid arm (n upper cables of a planar
    arm), the position and displacement cables of an elastic arm."""
    return len(commanded_cables(robot))



def layout(robot: Robot) -> Dict[str, slice]:
    """Slice of each parameter block in the flat parameter vector."""
    out, off = {}, 0
    for name, sz in robot.core.plant_effects():
        out[name] = slice(off, off + sz)
        off += sz
    return out


def size(robot: Robot) -> int:
    """Length of the flat parameter vector."""
    return sum(s for _, s in robot.core.plant_effects())


def parameter_blocks(robot: Robot, indices: Sequence[int]) -> List[Tuple[str, slice]]:
    """The block (name, slice of the flat vector) of each flat parameter."""
    lay = layout(robot)
    return [next((b, sl) for b, sl in lay.items() if sl.start <= int(i) < sl.stop) for i in indices]


def parameter_names(robot: Robot, indices: Sequence[int]) -> List[str]:
    """Names of flat parameters: the block, with the element in brackets
    for blocks of more than one (``link_length[0]``)."""
    return [f"{b}[{int(i) - sl.start}]" if sl.stop - sl.start > 1 else b
            for i, (b, sl) in zip(indices, parameter_blocks(robot, indices))]


def parameter_labels(robot: Robot) -> List[Tuple[str, str, str]]:
    """Every flat parameter, in vector order, as (block, label, SI unit):
    the label says what it is on this arm (the cable, hole, joint or disk,
    numbered from 1 as in the robot file, and the component:
    ``"cable 3 (to disk 2)"``, ``"cable 1, disk 1 face a, x"``), the unit
    is ``"m"``, ``"rad"``, ``"1"`` or ``"1/N"``. From the Rust core's
    layout, so either kind's labels come from where its blocks are laid out."""
    return [(str(b), str(lab), str(u)) for b, lab, u in robot.core.plant_parameters()]


def bounds(robot: Robot) -> Tuple[np.ndarray, np.ndarray]:
    """(P,) lower and upper bounds of the parameters: the physical domain."""
    return robot.core.plant_bounds()


def check_params(robot: Robot, p, field: str = "p") -> np.ndarray:
    """``p`` as the (P,) flat parameters of a physical plant of ``robot``:
    finite, within the physical domain (:func:`bounds`: ``cable_friction``
    within [0, 1], ``backlash`` >= 0, ...) and within ±:data:`MAX_PARAMETER`;
    :class:`CdsmInputError` naming ``field``, the parameter, its value and
    its bounds otherwise."""
    arr = as_array(field, p).reshape(-1)
    if arr.size != size(robot):
        raise CdsmInputError(f"`{field}`: expected {size(robot)} plant parameters, got {arr.size}")
    domain = bounds(robot)
    lo, hi = np.maximum(domain[0], -MAX_PARAMETER), np.minimum(domain[1], MAX_PARAMETER)
    bad = np.flatnonzero(~(np.isfinite(arr) & (arr >= lo) & (arr <= hi)))
    if bad.size:
        i = int(bad[0])
        why = "its physical domain" + ("" if np.isfinite(domain[0][i]) and np.isfinite(domain[1][i]) else
                                       f", at most {MAX_PARAMETER:g} in size: a kilometre of length")
        raise CdsmInputError(f"`{field}`: {parameter_names(robot, [i])[0]} must be within [{lo[i]:g}, {hi[i]:g}] "
                             f"(SI; {why}), got {float(arr[i])!r}")
    return arr


def effect_indices(robot: Robot, effect: str) -> np.ndarray:
    """Indices into the flat vector of the parameters an effect fits."""
    lay = layout(robot)
    if effect not in effects_of(robot) and effect not in lay:
        raise CdsmInputError(f"`effects`: unknown effect {effect!r}; known: {', '.join(effects_of(robot))}")
    blocks = EFFECT_BLOCKS.get(effect, (effect,))
    return np.concatenate([np.arange(lay[b].start, lay[b].stop) for b in blocks])


def params(robot: Robot, effects: Optional[Mapping[str, Sequence[float]]] = None) -> np.ndarray:
    """Flat parameter vector from ``{effect or block: values}`` (others zero);
    SI units. An effect of several blocks takes the values of its first block
    or of all of them (``hole_clearance``: ``[c]`` or ``[c, clearance_width]``)."""
    lay = layout(robot)
    p = np.zeros(size(robot))
    for name, val in (effects or {}).items():
        v = np.atleast_1d(as_array(f"effects[{name!r}]", val))
        idx = effect_indices(robot, name)
        first = lay[EFFECT_BLOCKS.get(name, (name,))[0]]
        if v.size == first.stop - first.start:
            p[first] = v
        elif v.size == len(idx):
            p[idx] = v
        else:
            raise CdsmInputError(f"`effects[{name!r}]`: needs {first.stop - first.start} or {len(idx)} values, "
                                 f"got {v.size}")
    if not np.isfinite(p).all():
        raise CdsmInputError("`effects`: non-finite values")
    return p


def reading_codes(reading, rows: int) -> np.ndarray:
    """(N,) uint8 :data:`READING_CODES` of the rows from one reading's name
    for every row, or per-row codes or names."""
    if isinstance(reading, str):
        if reading not in READING_CODES:
            raise CdsmInputError(f"`reading`: expected one of {', '.join(READING_CODES)}, got {reading!r}")
        return np.full(rows, READING_CODES[reading], np.uint8)
    arr = np.asarray(reading)
    if arr.dtype.kind in "US":
        bad = [k for k in set(arr.tolist()) if k not in READING_CODES]
        if bad:
            raise CdsmInputError(f"`reading`: unknown row readings {bad}")
        arr = np.array([READING_CODES[k] for k in arr.tolist()])
    if arr.shape != (rows,):
        raise CdsmInputError(f"`reading`: expected {rows} row readings, got shape {arr.shape}")
    return arr.astype(np.uint8)


def plate_twins(robot, coords) -> Tuple[np.ndarray, np.ndarray]:
    """``(face_b, face_a)``: positions in ``coords`` — indices into
    :attr:`Robot.flat_holes` of the hole coordinates that some errors move,
    one error each — of every coordinate of a face-b hole on a disk of zero
    thickness whose face-a twin is in ``coords`` too, and of that twin. On
    such a plate (FTDCR v4's via plates) the two faces are one physical
    hole: a manufacturing error moves both by the same vector. Drawn for
    each face alone, the cable would zigzag through the plate by
    ``|δb − δa|`` (not differentiable at 0, always a lengthening): every
    plate would lengthen the cable (``docs/model.md``, "Elastic arms in the
    plant"). Empty for an arm without zero-thickness disks."""
    coords = np.asarray(coords, np.int64)
    plate = np.asarray(robot.disk_thickness) == 0.0
    if not plate.any():
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    where = {int(k): i for i, k in enumerate(coords)}
    b, a, start = [], [], 0
    for end, holes in zip(robot.cable_ends, robot.holes_by_cable()):
        for d in range(1, end + 1):  # rows 2d - 1, 2d: disk d's faces a, b (row 0: the base)
            if plate[d - 1]:
                for k in range(3):
                    fa, fb = start + 3 * (2 * d - 1) + k, start + 3 * (2 * d) + k
                    if fa in where and fb in where:
                        a.append(where[fa])
                        b.append(where[fb])
        start += np.asarray(holes).size
    return np.asarray(b, np.int64), np.asarray(a, np.int64)


def tie_errors(errors, twins: Tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``errors`` (..., k) drawn one per coordinate, with each face-b twin of
    :func:`plate_twins` (``twins`` = its ``(face_b, face_a)``) given its
    face-a coordinate's error: one error per physical hole. A copy."""
    out = np.array(errors, dtype=np.float64)
    b, a = twins
    out[..., b] = out[..., a]
    return out


def join_columns(matrix, twins: Tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """A linear map ``matrix`` (..., k) of the errors of :func:`tie_errors`
    (one column per coordinate) as the tied errors see it: each face-b
    twin's column added to its face-a coordinate's and set to 0. A copy."""
    out = np.array(matrix, dtype=np.float64)
    b, a = twins
    out[..., a] += out[..., b]
    out[..., b] = 0.0
    return out


def check_commands(robot: Robot, theta_cmd, dL=None, reading="absolute", *, kind=None):
    """The commands as the plant takes them, validated: ``theta_cmd`` (N, n)
    rad, ``dL`` (N, m_c) m (zeros when None) and the rows' reading codes (N,)
    (:func:`reading_codes`); a bad field is named. ``kind``: the deprecated
    name of ``reading`` (one release)."""
    reading = deprecated.old_keyword("cdsm.plant.check_commands", "kind", "reading", kind, reading)
    t, _ = as_batch("theta_cmd", theta_cmd, robot.n)
    w = commands(robot)
    d = np.zeros((len(t), w)) if dL is None else as_batch("dL", dL, w)[0]
    if len(d) != len(t):
        raise CdsmInputError(f"`dL`: expected {len(t)} rows, got {len(d)}")
    return t, d, reading_codes(reading, len(t)).tolist()


def predict(robot: Robot, p, theta_cmd, dL=None, reading="absolute", tol: float = 1e-12,
            max_iter: int = 100, *, kind=None) -> Tuple[np.ndarray, np.ndarray]:
    """Observations of the plant(s) ``p`` ((P,) or (K, P)) for the rows of a
    data set in execution order: commands ``theta_cmd`` (N, n) rad and ``dL``
    (N, n) m, ``reading`` one name for every row (``"absolute"``,
    ``"displacement"``) or one per row (``"unmeasured"`` rows only run;
    :data:`READING_CODES`; ``kind``: its deprecated name, one release).
    Returns (N, 3) or (K, N, 3) — [x, y, phi] (absolute, instrument frame) or
    [dx, dy, dphi] (displacement), NaN for unmeasured rows and rows that do
    not settle — and the converged flags (N,) or (K, N). A parameter set
    outside the physical domain (:func:`bounds`) predicts no row."""
    reading = deprecated.old_keyword("cdsm.plant.predict", "kind", "reading", kind, reading)
    obs, conv, _ = _predict_all(robot, p, theta_cmd, dL, reading, tol, max_iter)
    return obs, conv


def _predict_all(robot, p, theta_cmd, dL, reading, tol, max_iter):
    pp, single = as_batch("params", p, size(robot))
    t, d, k = check_commands(robot, theta_cmd, dL, reading)
    res = robot.core.plant_predict(pp, t, d, k, as_finite("tol", tol), as_iterations("max_iter", max_iter),
                                   robot.threads)
    shape = (len(pp), len(t))
    out = (res.observation.reshape(shape + (width(robot),)), res.converged.reshape(shape),
           res.theta.reshape(shape + (robot.n,)))
    return tuple(a[0] for a in out) if single else out


def linearise(robot: Robot, p, free, theta_cmd, dL=None, reading="absolute", tol: float = 1e-12,
              max_iter: int = 100, *, kind=None) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predictions (N, w), converged (N,) and their exact Jacobian (N, w, k)
    with respect to the parameters ``free`` (indices into the flat vector) of
    the plant ``p`` (P,) — implicit function theorem at the settled
    configurations, forward-mode jets in the Rust core (no finite
    differences). ``w`` = :func:`width` (3 planar, 6 spatial). ``reading``
    as :func:`predict` (``kind``: its deprecated name, one release)."""
    reading = deprecated.old_keyword("cdsm.plant.linearise", "kind", "reading", kind, reading)
    pp = np.ascontiguousarray(as_batch("params", p, size(robot))[0][0])
    t, d, k = check_commands(robot, theta_cmd, dL, reading)
    fr = [int(i) for i in np.atleast_1d(free)]
    res = robot.core.plant_linearise(pp, fr, t, d, k, as_finite("tol", tol), as_iterations("max_iter", max_iter),
                                     robot.threads)
    w = width(robot)
    return (res.observation.reshape(-1, w), np.asarray(res.converged, bool),
            res.jacobian.reshape(len(t), w, len(fr)))


def settle(robot: Robot, p, theta_cmd, dL=None, reading="absolute", tol: float = 1e-12,
           max_iter: int = 100, *, kind=None) -> Tuple[np.ndarray, np.ndarray]:
    """Joint angles (N, n) rad the plant ``p`` (P,) settles at for each row's
    (last) command — every effect of the plant included — and the converged
    flags (N,); NaN rows where not. ``reading`` as :func:`predict`
    (``kind``: its deprecated name, one release)."""
    reading = deprecated.old_keyword("cdsm.plant.settle", "kind", "reading", kind, reading)
    _, conv, theta = _predict_all(robot, p, theta_cmd, dL, reading, tol, max_iter)
    return theta, conv


def taut_commands(robot: Robot, theta_cmd, dL=None, reading="absolute", min_tension: float = 0.0, *,
                  kind=None) -> np.ndarray:
    """(N,) bool: the commands (``theta_cmd`` (N, n) or (n,) rad, ``dL`` (N, m) m on
    the position-controlled cables, ``reading`` as :func:`predict`, ``kind``
    its deprecated name) at which the
    nominal model keeps every position cable taut: the nominal plant settles,
    and its statics (:meth:`Robot.feasible`: the robot file's force-cable
    tensions and gravity) holds the arm with every position-cable tension
    above ``min_tension`` (N) both at ``theta_cmd`` and at the angles the
    nominal plant settles at for the command's lengths + dL. With
    ``min_tension = 0`` these are the rows the diagnosis can use (it flags
    the others as needing a slack cable)."""
    reading = deprecated.old_keyword("cdsm.plant.taut_commands", "kind", "reading", kind, reading)
    t, _ = as_batch("theta_cmd", theta_cmd, robot.n)
    reached, settles = settle(robot, np.zeros(size(robot)), t, dL, reading)
    ok = settles & robot.feasible(t, min_tension)
    if settles.any():
        ok[settles] &= robot.feasible(reached[settles], min_tension)
    return ok


#: Names of the 0.1 module ``cdsm.plant`` (an alias of ``cdsm.calibration.plant``
#: until this module took its place) that live in :mod:`cdsm.calibration.plant`.
_MOVED_UP = ("VirtualPrototype", "EXAMPLES_N3")


#: Names of cdsm 0.2 renamed in place (cdsm 0.3: a row's measurement is its reading).
RENAMED = {"KIND_CODES": "READING_CODES", "kind_codes": "reading_codes"}


def __getattr__(name: str):
    """``cdsm.plant.VirtualPrototype`` and ``EXAMPLES_N3`` (cdsm 0.1 paths):
    forwarded to :mod:`cdsm.calibration.plant`, and the 0.2 names of
    :data:`RENAMED`, each with a :class:`DeprecationWarning` (one release)."""
    if name in RENAMED:
        deprecated.warn_renamed(f"cdsm.plant.{name}", f"cdsm.plant.{RENAMED[name]}")
        return globals()[RENAMED[name]]
    if name in _MOVED_UP:
        import importlib

        warnings.warn(f"cdsm.plant.{name} is deprecated and will be removed in the next release; use "
                      f"cdsm.calibration.plant.{name}", DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module("cdsm.calibration.plant"), name)
    raise AttributeError(f"module 'cdsm.plant' has no attribute {name!r}")
