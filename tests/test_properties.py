"""Property-based tests (hypothesis) of the public API, robot files of both
kinds (valid and mutated), measurement CSVs (issue 21), friction, CASPR
import, the MJCF and URDF exports, output directories and model files
(issue 32, item 9).

The invariant everywhere: a call either raises :class:`cdsm.CdsmInputError`
naming the field it refuses, or returns a finite result whose failed
elements are flagged — and what it returns survives its round trip
(``to_toml`` -> ``from_toml``, ``FittedPlant.save`` -> ``FittedPlant.load``, export ->
XML parser). No other exception type, no crash, no silent truncation.

Every run draws new examples: the seed is ``CDSM_HYPOTHESIS_SEED`` when set,
else a fresh random one; a failure prints it (``CDSM_HYPOTHESIS_SEED=<seed>``
reruns the whole module's draws) and hypothesis' ``@reproduce_failure`` blob
of the failing example. Example counts keep the module within a few seconds
of CI time (about 10 s on 2 cores); ``CDSM_PROPERTY_EXAMPLES`` multiplies
them for a longer local run. hypothesis is part of the ``[test]`` extra: a
missing one fails the tests, it does not skip them.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import secrets
import warnings
import xml.etree.ElementTree as ET
from xml.sax.saxutils import quoteattr

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, note, seed, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import cdsm
import caspr_reference as caspr
from cdsm import files
from cdsm.accuracy import statics
from cdsm.calibration import measurements, plant
from cdsm.calibration.model import FittedPlant
from conftest import reference

SEED = int(os.environ.get("CDSM_HYPOTHESIS_SEED") or secrets.randbelow(2**32))
REPRODUCE = f"reproduce every draw of this module with CDSM_HYPOTHESIS_SEED={SEED}"
SCALE = float(os.environ.get("CDSM_PROPERTY_EXAMPLES", "1"))


def prop(examples: int):
    """A property test's settings: ``examples`` draws (times
    ``CDSM_PROPERTY_EXAMPLES``), seeded by :data:`SEED`, no deadline (CI
    machines stall), the reproduction blob printed on failure."""
    opts = settings(max_examples=max(1, int(examples * SCALE)), deadline=None, print_blob=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.function_scoped_fixture])

    def wrap(fn):
        return seed(SEED)(opts(fn))
    return wrap


PAPER = cdsm.Robot.paper()
SPATIAL = cdsm.Robot.from_toml("two_universal")
#: a refusal names what it refuses: `name` (API) or field `path` (files)
NAMED = re.compile(r"`[^`]+`|field `|column|row \d|\.csv|<csv>|model file|CASPR model|link \d|cable \d")


def refused_clearly(exc: BaseException) -> None:
    assert isinstance(exc, cdsm.CdsmInputError), f"{type(exc).__name__}: {exc}"
    assert NAMED.search(str(exc)), f"the message names no field: {exc}"


# ---------------------------------------------------------------------------
# arrays and options thrown at the public API
# ---------------------------------------------------------------------------
NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64),
                    st.sampled_from([0.0, 0.3, -0.3, 1e-300, 1e308, -1e308]))


def arrays(width: int):
    """Arrays near the right shape (N, width) or (width,), of any dtype a
    user might pass, with any float value."""
    shapes = st.one_of(st.just((width,)), st.tuples(st.integers(0, 4), st.just(width)),
                       hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=4))
    dtypes = st.sampled_from([np.float64, np.float32, np.int64, np.complex128, np.bool_])
    def elements(dt):
        if dt == np.float32:
            return st.floats(allow_nan=True, allow_infinity=True, width=32)
        return NUMBERS if np.dtype(dt).kind == "f" else None

    return dtypes.flatmap(lambda dt: shapes.flatmap(lambda sh: hnp.arrays(dt, sh, elements=elements(dt))))


OPTIONS = st.one_of(st.integers(-3, 2**41), st.floats(allow_nan=True, allow_infinity=True), st.booleans(),
                    st.none(), st.just("7"), st.just(1.7), st.just(3.0))


def check_solution(sol, robot) -> None:
    ok = np.asarray(sol.converged, bool)
    theta = np.atleast_2d(sol.theta)
    assert np.isfinite(theta[ok]).all()
    reasons = np.atleast_1d(sol.reason)
    assert (reasons[ok] == "converged").all() and (reasons[~ok] != "converged").all()
    assert np.isfinite(np.atleast_1d(sol.residual)[ok]).all()


CALLS = {
    "fk": (lambda r, a, o: r.fk(a), "n"),
    "cable_lengths": (lambda r, a, o: r.cable_lengths(a), "n"),
    "cable_jacobian": (lambda r, a, o: r.cable_jacobian(a), "n"),
    "solve_cables": (lambda r, a, o: r.solve_cables(a, max_iter=o), "m"),
    "solve_cables_tol": (lambda r, a, o: r.solve_cables(a, tol=o), "m"),
    "tensions": (lambda r, a, o: r.tensions(a, min_tension=o), "n"),
    "ik": (lambda r, a, o: r.ik(a, max_iter=o), "task"),
    "deviation": (lambda r, a, o: cdsm.accuracy.deviation(r, a, max_iter=o), "n"),
    "monte_carlo": (lambda r, a, o: cdsm.accuracy.monte_carlo(r, a, samples=o, progress=False), "n"),
}


@prop(40)
@given(robot=st.sampled_from([PAPER, SPATIAL]), call=st.sampled_from(sorted(CALLS)), data=st.data())
def test_the_api_refuses_clearly_or_returns_a_flagged_finite_result(robot, call, data):
    note(REPRODUCE)
    fn, width = CALLS[call]
    w = {"n": robot.n, "m": len(robot.position_cables), "task": 6 if robot.kind == "spatial" else 3}[width]
    a = data.draw(arrays(w), label="array")
    o = data.draw(OPTIONS, label="option")
    if (call == "monte_carlo" and isinstance(o, (int, float)) and not isinstance(o, bool) and o > 3
            and float(o).is_integer() and o <= 2**53):
        o = 3  # a valid count: keep the example fast (a huge one would just run long)
    try:
        out = fn(robot, a, o)
    except Exception as exc:  # noqa: BLE001 — the property is about the type
        refused_clearly(exc)
        return
    if hasattr(out, "converged") and hasattr(out, "reason"):
        check_solution(out, robot)
    elif hasattr(out, "dS"):
        ok = np.asarray(out.ok, bool)
        assert np.isfinite(out.dS[ok]).all()
    elif hasattr(out, "count"):
        assert (out.count + out.failed >= 0).all()
    elif isinstance(out, tuple):
        pass
    else:
        assert np.isfinite(np.asarray(out)).all() or call == "tensions"


# ---------------------------------------------------------------------------
# robot files of both kinds, valid and mutated
# ---------------------------------------------------------------------------
LENGTH = st.floats(1e-3, 0.1)


@st.composite
def planar_files(draw) -> str:
    n = draw(st.integers(1, 4))
    lines = ['name = "generated"', f"n = {n}"]
    if draw(st.booleans()):
        lines.append(f"gravity = [0.0, {-draw(st.floats(0.0, 9.81))!r}]")
    for i in range(n):
        lim = draw(st.floats(0.05, 1.5))
        lines += ["[[linkage]]", f"link_before = {draw(LENGTH)!r}", f"link_after = {draw(LENGTH)!r}",
                  f"thickness = {draw(LENGTH)!r}", f"hole_height = {draw(LENGTH)!r}",
                  f"mass = {draw(st.floats(0.0, 0.1))!r}", f"lower_tension = {draw(st.floats(0.0, 2.0))!r}",
                  f"joint_limits = [{-lim!r}, {lim!r}]"]
    return "\n".join(lines) + "\n"


@st.composite
def spatial_files(draw) -> str:
    sections = draw(st.integers(1, 3))
    radius = draw(st.floats(0.01, 0.05))
    lines = ['kind = "spatial"', 'name = "generated spatial"', "gravity = [0.0, 0.0, -9.81]", "",
             "[base]", f"radius = {radius!r}"]
    for _ in range(sections):
        lines += ["[[linkage]]", "joints = [",
                  f"  {{ axis = [0.0, 1.0, 0.0], offset = [{draw(LENGTH)!r}, 0.0, 0.0], limits = [-0.6, 0.6] }},",
                  "  { axis = [0.0, 0.0, 1.0], offset = [0.0, 0.0, 0.0], limits = [-0.6, 0.6] },", "]",
                  f"link_after = [{draw(LENGTH)!r}, 0.0, 0.0]", f"thickness = {draw(LENGTH)!r}",
                  f"radius = {radius!r}", f"mass = {draw(st.floats(0.0, 0.05))!r}"]
    for s in range(sections):
        for k in range(4):
            mode = "position" if k < 2 else "force"
            lines += ["[[cables]]", f"end = {s + 1}", f'mode = "{mode}"',
                      f"radius = {draw(st.floats(0.1, 0.99)) * radius!r}", f"angle = {k * math.pi / 2!r}"]
            if mode == "force":
                lines.append(f"tension = {draw(st.floats(0.05, 2.0))!r}")
    return "\n".join(lines) + "\n"


MUTATIONS = ["none", "drop_line", "twice", "to_string", "to_bool", "extra_element", "negate", "nan", "huge",
             "unknown_key", "truncate"]


@st.composite
def mutated(draw, files):
    text = draw(files)
    how = draw(st.sampled_from(MUTATIONS))
    lines = text.splitlines()
    keyed = [i for i, ln in enumerate(lines) if re.match(r"^\s*[a-z_]+ = ", ln)]
    i = draw(st.sampled_from(keyed))
    key, _, value = lines[i].partition(" = ")
    if how == "drop_line":
        del lines[i]
    elif how == "twice":
        lines.insert(i, lines[i])
    elif how == "to_string":
        lines[i] = f'{key} = "{value}"'
    elif how == "to_bool":
        lines[i] = f"{key} = true"
    elif how == "extra_element" and value.startswith("["):
        lines[i] = f"{key} = {value[:-1]}, 1.0]"
    elif how == "negate" and re.match(r"^[0-9.e+-]+$", value):
        lines[i] = f"{key} = -{value}"
    elif how == "nan" and re.match(r"^[0-9.e+-]+$", value):
        lines[i] = f"{key} = nan"
    elif how == "huge" and re.match(r"^[0-9.e+-]+$", value):
        lines[i] = f"{key} = 1e308"
    elif how == "unknown_key":
        lines.insert(i, "colour = 3")
    elif how == "truncate":
        return "\n".join(lines)[: draw(st.integers(0, len(text)))]
    return "\n".join(lines) + "\n"


@prop(40)
@given(text=st.one_of(mutated(planar_files()), mutated(spatial_files())))
def test_a_robot_file_is_refused_by_field_or_round_trips(text):
    note(REPRODUCE)
    try:
        robot = cdsm.Robot.from_toml_str(text)
    except Exception as exc:  # noqa: BLE001
        refused_clearly(exc)
        return
    written = robot.to_toml()
    again = cdsm.Robot.from_toml_str(written)
    assert again.to_toml() == written
    theta = np.zeros((1, robot.n))
    np.testing.assert_array_equal(again.cable_lengths(theta), robot.cable_lengths(theta))
    assert np.isfinite(robot.fk(theta)).all() and np.isfinite(robot.cable_lengths(theta)).all()


# ---------------------------------------------------------------------------
# measurement CSVs
# ---------------------------------------------------------------------------
CELLS = st.one_of(st.floats(-0.5, 0.5).map(repr), st.just(""), st.just("nan"), st.just("inf"), st.just("x"),
                  st.just("1e400"), st.just(" 0.1 "))


@st.composite
def measurement_csvs(draw) -> str:
    cols = ["theta_1", "theta_2", "theta_3", "dL_1", "dL_2", "dL_3"] + draw(
        st.sampled_from([["dx", "dy"], ["x", "y"], ["x", "y", "phi"], ["dx", "dy", "dphi"]]))
    if draw(st.booleans()):
        cols.append("point")
    cols = draw(st.permutations(cols))
    how = draw(st.sampled_from(["none", "drop_column", "twice", "bom", "extra_cell"]))
    if how == "drop_column":
        cols = cols[1:]
    elif how == "twice":
        cols = cols + [cols[0]]
    rows = []
    for _ in range(draw(st.integers(1, 6))):
        cells = [draw(st.floats(-0.3, 0.3).map(repr)) for _ in cols]
        if draw(st.integers(0, 3)) == 0:
            cells[draw(st.integers(0, len(cells) - 1))] = draw(CELLS)
        if how == "extra_cell":
            cells.append("0.0")
        rows.append(",".join(cells))
    text = ",".join(cols) + "\n" + "\n".join(rows) + "\n"
    return ("\ufeff" + text) if how == "bom" else text


@prop(40)
@given(text=measurement_csvs())
def test_a_measurement_csv_is_refused_by_row_and_column_or_read_whole(text):
    note(REPRODUCE)
    try:
        m = measurements.parse_csv(text, 3)
    except Exception as exc:  # noqa: BLE001
        refused_clearly(exc)
        return
    rows = [ln for ln in text.lstrip("\ufeff").splitlines()[1:] if ln.strip()]
    assert len(m) == len(rows)
    seen = m.observed
    assert np.isfinite(m.measured[seen]).all() and np.isnan(m.measured[~seen]).all()
    assert np.isfinite(m.dL).all() and np.isfinite(m.theta).all()


# ---------------------------------------------------------------------------
# friction: the statics' bounding states and the plant's friction parameter
# ---------------------------------------------------------------------------
@st.composite
def planar_robots(draw):
    """A valid planar robot of :func:`planar_files` (massless disks and all)."""
    text = draw(planar_files())
    try:
        return cdsm.Robot.from_toml_str(text)
    except cdsm.CdsmInputError:
        assume(False)


def within_limits(draw, robot, rows: int) -> np.ndarray:
    lim = np.asarray(robot.joint_limits)
    return np.array([[draw(st.floats(lo, hi)) for lo, hi in lim] for _ in range(rows)]).reshape(rows, robot.n)


@prop(50)
@given(robot=planar_robots(), mu=st.floats(0.0, 1.0), sliding=st.sampled_from(["pull", "release"]),
       data=st.data())
def test_friction_statics_equal_the_reference_and_vanish_at_mu_zero(robot, mu, sliding, data):
    """The bounding sliding states' tensions (Rust core) equal the NumPy
    reference's balance with the capstan gap factors, on random planar arms
    and poses, for any mu in [0, 1]; mu = 0 is the frictionless statics."""
    note(REPRODUCE)
    th = within_limits(data.draw, robot, 3)
    got = robot.tensions(th, friction=mu, sliding=sliding)
    zp, zf = reference.friction.PULL if sliding == "pull" else reference.friction.RELEASE
    z = np.concatenate([np.full(2 * (c // 2 + 1), zp if c % 2 == 0 else zf) for c in range(2 * robot.n)])
    gap, _ = reference.friction_factors(robot, th, np.tile(z, (len(th), 1)), mu)
    want = reference.tensions(robot, th, lower=robot.lower_tension, gravity=np.asarray(robot.gravity, float),
                              mass=robot.mass, gap=gap)
    assert (np.isnan(got) == np.isnan(want)).all()
    ok = ~np.isnan(want)
    assert np.all(np.abs(got[ok] - want[ok]) <= 1e-10 * np.maximum(1.0, np.abs(want[ok])))
    np.testing.assert_array_equal(robot.tensions(th, friction=0.0, sliding=sliding), robot.tensions(th))


BAD_NUMBERS = st.one_of(st.floats(1.0, 1e308, exclude_min=True), st.floats(-1e308, 0.0, exclude_max=True),
                        st.sampled_from([math.nan, math.inf, -math.inf, True, False, "0.1", 0.1j, [0.1],
                                         np.array([0.1, 0.2])]))


@prop(40)
@given(mu=BAD_NUMBERS, sliding=st.one_of(st.sampled_from(["pull", "release"]), st.text(max_size=8),
                                         st.sampled_from([None, 1, np.array(["pull", "release"]), ["pull"]])))
def test_friction_outside_zero_to_one_or_not_a_number_is_refused(mu, sliding):
    note(REPRODUCE)
    th = np.zeros((2, 3))
    for call in (PAPER.tensions, PAPER.feasible):
        with pytest.raises(cdsm.CdsmInputError, match="`friction`|`sliding`"):
            call(th, friction=mu, sliding=sliding)
    if isinstance(mu, float) and math.isfinite(mu):
        with pytest.raises(cdsm.CdsmInputError, match=r"cable_friction must be within \[0, 1\]"):
            FittedPlant.from_effects(PAPER, {"cable_friction": [mu]})


@prop(10)
@given(mu=st.floats(0.0, 1.0), data=st.data())
def test_the_friction_loop_is_zero_without_friction_and_never_negative(mu, data):
    """The hysteresis of a cable cycle through the plant (cable_friction mu,
    the robot file's stiffness): a width >= 0 wherever the cycle settled, 0
    at mu = 0 exactly."""
    note(REPRODUCE)
    th = within_limits(data.draw, PAPER, 2)
    for m, fm in ((mu, statics.friction_map(PAPER, th, mu=mu)), (0.0, statics.friction_map(PAPER, th, mu=0.0))):
        done = ~np.isnan(fm.loop)
        assert (fm.loop[done] >= 0).all()
        if m == 0.0:
            assert (fm.loop[done] == 0.0).all()


# ---------------------------------------------------------------------------
# model files with friction
# ---------------------------------------------------------------------------
@st.composite
def model_effects(draw):
    """Effects of the paper's arm within their physical domain, friction
    always among them, and 1-sigma lists with undetermined (NaN) values."""
    lo, hi = plant.bounds(PAPER)
    lay = plant.layout(PAPER)
    names = ["cable_friction"] + draw(st.lists(st.sampled_from(
        ["actuation_scale", "cable_offset", "hole_height", "backlash", "cable_elasticity", "tip_offset"]),
        unique=True, max_size=3))
    effects, std = {}, {}
    for e in names:
        sl = lay[e]
        vals = [draw(st.floats(max(lo[i], -1e-2), min(hi[i], 1e-2) if e != "cable_friction" else 1.0))
                for i in range(sl.start, sl.stop)]
        effects[e] = vals
        std[e] = [draw(st.one_of(st.floats(0.0, 1e-3), st.just(math.nan))) for _ in vals]
    return effects, std


@prop(40)
@given(es=model_effects())
def test_a_model_with_friction_round_trips_bit_for_bit(tmp_path_factory, es):
    note(REPRODUCE)
    effects, std = es
    m = FittedPlant.from_effects(PAPER, effects, std=std)
    path = tmp_path_factory.mktemp("model") / "m.json"
    m.save(path)
    back = FittedPlant.load(path)
    assert back == m and back.effects == list(effects)
    np.testing.assert_array_equal(back.p, m.p)
    for e, v in std.items():
        np.testing.assert_array_equal(back.std[e], v)  # NaN (null in the file) where undetermined
    assert back.params_by_effect()["cable_friction"] == effects["cable_friction"]


FILE_MUTATIONS = ["flat_out_of_domain", "flat_huge", "flat_bool", "flat_null", "flat_text", "std_negative",
                  "std_extra_effect", "std_extra_value", "std_null", "effects_unknown", "drop_key", "layout_short"]


@prop(50)
@given(es=model_effects(), how=st.sampled_from(FILE_MUTATIONS), data=st.data())
def test_a_damaged_model_file_is_refused_naming_the_field(tmp_path_factory, es, how, data):
    note(REPRODUCE)
    effects, std = es
    d = FittedPlant.from_effects(PAPER, effects, std=std).to_dict()
    d = json.loads(json.dumps(d))  # NaN std written as null, as in the file
    lo, hi = plant.bounds(PAPER)
    flat, i = d["params"]["flat"], data.draw(st.integers(0, len(d["params"]["flat"]) - 1))
    e = data.draw(st.sampled_from(sorted(std)))
    if how == "flat_out_of_domain":
        assume(np.isfinite(lo[i]) or np.isfinite(hi[i]))
        flat[i] = float(lo[i] - data.draw(st.floats(1e-6, 1e3))) if np.isfinite(lo[i]) else \
            float(hi[i] + data.draw(st.floats(1e-6, 1e3)))
    elif how == "flat_huge":
        flat[i] = data.draw(st.sampled_from([1e308, -1e308, 1e4, -2e3]))
    elif how == "flat_bool":
        flat[i] = True
    elif how == "flat_null":
        flat[i] = None
    elif how == "flat_text":
        flat[i] = "0.1"
    elif how == "std_negative":
        d["params"]["std"][e][0] = -data.draw(st.floats(1e-12, 1.0))
    elif how == "std_extra_effect":
        d["params"]["std"]["link_length"] = [0.0] * 4
    elif how == "std_extra_value":
        d["params"]["std"][e].append(0.0)
    elif how == "std_null":
        d["params"]["std"][e] = None
    elif how == "effects_unknown":
        d["effects"].append("gremlins")
    elif how == "drop_key":
        del d[data.draw(st.sampled_from(["params", "robot", "effects", "format"]))]
    elif how == "layout_short":
        d["params"]["layout"]["cable_friction"] = [0, 0]
    path = tmp_path_factory.mktemp("model") / "m.json"
    path.write_text(json.dumps(d), encoding="utf-8")
    with pytest.raises(cdsm.CdsmInputError) as exc:
        FittedPlant.load(path)
    refused_clearly(exc.value)
    assert "m.json" in str(exc.value)


# ---------------------------------------------------------------------------
# CASPR import
# ---------------------------------------------------------------------------
JOINTS = {"R_X": 1, "R_Y": 1, "R_Z": 1, "R_AXIS": 1, "U_XY": 2, "U_XZ": 2, "U_YZ": 2}
#: characters XML 1.0 takes in text and attributes (names of links, cables, sets)
XML_TEXT = st.text(st.characters(codec="utf-8", exclude_categories=["Cs", "Cc"]) | st.sampled_from("\t \n<>&\"'"),
                   max_size=12)


def unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


@st.composite
def caspr_models(draw):
    """``(bodies XML, cables XML)`` of a random CASPR chain that cdsm can
    represent: 1-3 links along one direction, any revolute joint type,
    off-axis parent locations, 1-2 attachments per link, both attachment
    orders and references, names of any XML text."""
    d = unit(draw(st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: np.linalg.norm(v) > 0.2)))
    a = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 1.0, 0])
    u = unit(np.cross(d, a))
    w = np.cross(d, u)
    K = draw(st.integers(1, 3))
    kinds = [draw(st.sampled_from(sorted(JOINTS))) for _ in range(K)]
    lengths = [draw(st.floats(0.02, 0.08)) for _ in range(K)]
    set_id = draw(XML_TEXT)
    body = ['<?xml version="1.0" encoding="utf-8"?>', "<bodies_system>", "  <links>"]
    prev = np.zeros(3)
    for k, (jt, length) in enumerate(zip(kinds, lengths), start=1):
        nq = JOINTS[jt]
        lim = [(-draw(st.floats(0.1, 1.0)), draw(st.floats(0.1, 1.0))) for _ in range(nq)]
        axis = f' axis="{" ".join(repr(x) for x in unit(draw(st.tuples(*[st.floats(0.1, 1)] * 3))))}"' \
            if jt == "R_AXIS" else ""
        across = draw(st.floats(-0.003, 0.003)) * u + draw(st.floats(-0.003, 0.003)) * w
        loc = prev + across
        body += [f"    <link_rigid num=\"{k}\" name={quoteattr(draw(XML_TEXT))}>",
                 f'      <joint type="{jt}"{axis} q_initial="{" ".join("0" for _ in lim)}" '
                 f'q_min="{" ".join(repr(lo) for lo, _ in lim)}" q_max="{" ".join(repr(hi) for _, hi in lim)}"/>',
                 f"      <physical><mass>{draw(st.floats(0.001, 0.1))!r}</mass>",
                 f"        <com_location>{_v(0.4 * length * d + 0.001 * u)}</com_location>",
                 f"        <end_location>{_v(length * d)}</end_location>",
                 "      </physical>",
                 f"      <parent><num>{k - 1}</num><location>{_v(loc)}</location></parent>",
                 "    </link_rigid>"]
        prev = length * d
    body += ["  </links>", "</bodies_system>"]
    joints = sum(JOINTS[j] for j in kinds)
    cab = ['<?xml version="1.0" encoding="utf-8"?>', f"<cables default_cable_set={quoteattr(set_id)}>",
           f"  <cable_set id={quoteattr(set_id)}>"]
    for c in range(joints + draw(st.integers(0, 2))):
        end = draw(st.integers(1, K))
        angle, r = draw(st.floats(0, 2 * math.pi)), draw(st.floats(0.005, 0.02))

        def hole(k, along, turn=0.0):
            return k, along * d + r * (math.cos(angle + turn) * u + math.sin(angle + turn) * w)

        pts = [hole(0, -0.004)]
        for k in range(1, end + 1):
            pts.append(hole(k, 0.2 * lengths[k - 1]))
            if draw(st.booleans()):
                pts.append(hole(k, 0.85 * lengths[k - 1], draw(st.floats(-0.1, 0.1))))
        ref = draw(st.sampled_from(["joint", "com"]))
        if draw(st.booleans()):
            pts = pts[::-1]
        cab += [f"    <cable_ideal name={quoteattr(draw(XML_TEXT))} attachment_reference=\"{ref}\">",
                "      <attachments>"]
        for k, p in pts:
            if ref == "com" and k > 0:
                p = p - (0.4 * lengths[k - 1] * d + 0.001 * u)
            cab.append(f"        <attachment><link>{k}</link><location>{_v(p)}</location></attachment>")
        cab += ["      </attachments>", "    </cable_ideal>"]
    cab += ["  </cable_set>", "</cables>"]
    return "\n".join(body) + "\n", "\n".join(cab) + "\n"


def _v(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def import_caspr(folder, stem: str, model, cables_stem: str = ""):
    folder.mkdir(parents=True, exist_ok=True)
    b, c = folder / f"{stem}_bodies.xml", folder / f"{cables_stem or stem}_cables.xml"
    b.write_text(model[0], encoding="utf-8")
    c.write_text(model[1], encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # what is not kept
        return cdsm.Robot.from_caspr(b, c), b, c


def without_name(toml: str) -> str:
    # split at "\n" only: str.splitlines also breaks at U+0085, U+2028, ...,
    # which a name may hold raw (TOML escapes only C0 controls and DEL)
    return "\n".join(ln for ln in toml.split("\n") if not ln.startswith("name = "))


@prop(40)
@given(model=caspr_models(), data=st.data())
def test_a_caspr_model_imports_with_caspr_lengths_or_is_refused(tmp_path_factory, model, data):
    """Cable lengths of the imported robot equal CASPR's model evaluated
    from the same files (``tests/caspr_reference.py``) at random
    configurations within the limits; the robot file round-trips; the names
    in the files (any XML text) change nothing but the robot's name."""
    note(REPRODUCE)
    folder = tmp_path_factory.mktemp("caspr")
    try:
        robot, b, c = import_caspr(folder, "M", model)
    except cdsm.CdsmInputError as exc:
        refused_clearly(exc)
        return
    links = caspr.bodies(b)
    _, cables = caspr.cables(c, links=links)
    theta = within_limits(data.draw, robot, 4)
    theirs = caspr.lengths(links, cables, theta)
    assert np.abs(robot.cable_lengths(theta) - theirs).max() <= 1e-12
    written = robot.to_toml()
    assert cdsm.Robot.from_toml_str(written).to_toml() == written
    plain = re.sub(r'name="[^"]*"', 'name="x"', re.sub(r"'[^']*'", "'x'", model[0])), re.sub(
        r'(name|id|default_cable_set)="[^"]*"', r'\1="x"', model[1])
    other, _, _ = import_caspr(folder / "plain", "M", plain)
    assert without_name(other.to_toml()) == without_name(written)


#: a file name's characters (no "/", no NUL, no line break: the test below adds one)
FILE_TEXT = st.text(st.characters(codec="utf-8", exclude_categories=["Cs"], exclude_characters="/\x00\n\r"),
                    min_size=1, max_size=20)


@prop(10)
@given(model=caspr_models(), head=FILE_TEXT)
def test_a_caspr_file_name_changes_nothing_but_the_robot_name(tmp_path_factory, model, head):
    note(REPRODUCE)
    folder = tmp_path_factory.mktemp("caspr")
    try:
        plain, _, _ = import_caspr(folder / "plain", "M", model)
    except cdsm.CdsmInputError:
        assume(False)
    stem = f"{head}\ncable.youngs_modulus = 1.0\ncable.diameter = 0.00018\n#"
    try:
        robot, _, _ = import_caspr(folder, stem, model, cables_stem="M")
    except cdsm.CdsmInputError as exc:
        refused_clearly(exc)
        return
    assert without_name(robot.to_toml()) == without_name(plain.to_toml())


# ---------------------------------------------------------------------------
# exports: MJCF and URDF
# ---------------------------------------------------------------------------
def robot_named(text: str, name: str):
    return cdsm.Robot.from_toml_str(re.sub(r'^name = .*$', lambda _: f"name = {json.dumps(name)}", text,
                                           count=1, flags=re.M))


def check_exports(robot) -> None:
    """Both exports parse as XML and say what the robot is (name, joints,
    limits, masses, cables); MJCF refuses a disk without mass, or with a
    mass or inertia MuJoCo rejects (below mjMINVAL), naming it."""
    urdf = ET.fromstring(robot.to_urdf())
    assert urdf.get("name") == robot.name
    joints = [j for j in urdf.findall("joint") if j.get("type") == "revolute"]
    assert len(joints) == robot.n
    lim = np.array([[float(j.find("limit").get("lower")), float(j.find("limit").get("upper"))] for j in joints])
    np.testing.assert_array_equal(lim, robot.joint_limits)
    masses = [float(m.get("value")) for m in urdf.findall("link/inertial/mass")]
    np.testing.assert_array_equal(masses, robot.mass[robot.mass > 0])
    try:
        text = robot.to_mjcf()
    except cdsm.CdsmInputError as exc:
        # refused naming the disk: no mass, or a mass or inertia below MuJoCo's mjMINVAL (1e-15; the exact
        # boundary is checked against MuJoCo in test_interop_export.py)
        hit = re.search(r"disk (\d+) has no mass|disk (\d+) \(body 'disk\d+'\): .* (is|are) below 1e-15", str(exc))
        assert hit, exc
        if hit.group(1):
            assert robot.mass[int(hit.group(1)) - 1] <= 0, exc
        else:
            m = robot.mass[int(hit.group(2)) - 1]
            dims = re.search(r"radius (\S+) m, thickness (\S+) m", str(exc))
            r, t = (float(dims.group(1)), float(dims.group(2))) if dims else (np.inf, np.inf)
            assert min(m, m * r * r / 2, m * (3 * r * r + t * t) / 12) < 1e-15, exc
        return
    mjcf = ET.fromstring(text)
    assert mjcf.tag == "mujoco" and mjcf.get("model") == robot.name
    hinges = mjcf.findall(".//worldbody//joint")
    assert len(hinges) == robot.n
    rng = np.array([[float(x) for x in j.get("range").split()] for j in hinges])
    np.testing.assert_array_equal(rng, robot.joint_limits)
    assert len(mjcf.findall("./tendon/spatial")) == robot.cables


@prop(60)
@given(text=st.one_of(planar_files(), spatial_files()), name=XML_TEXT)
def test_exports_are_well_formed_and_say_what_the_robot_is(text, name):
    note(REPRODUCE)
    try:
        robot = robot_named(text, name)
    except cdsm.CdsmInputError as exc:
        refused_clearly(exc)
        return
    check_exports(robot)


#: characters XML 1.0 forbids anywhere in a document
XML_FORBIDDEN = st.sampled_from([chr(c) for c in range(0x20) if chr(c) not in "\t\n\r"] + ["\ufffe", "\uffff"])


@prop(10)
@given(text=st.one_of(planar_files(), spatial_files()), head=XML_TEXT, bad=XML_FORBIDDEN)
def test_a_name_xml_forbids_is_refused_or_exported_well_formed(text, head, bad):
    note(REPRODUCE)
    try:
        robot = robot_named(text, head + bad)
    except cdsm.CdsmInputError as exc:
        refused_clearly(exc)
        return
    check_exports(robot)


# ---------------------------------------------------------------------------
# output directories: files written whole, run manifests
# ---------------------------------------------------------------------------
FILE_NAMES = st.text("abcdefghijklmnopqrstuvwxyz0123456789_-", min_size=1, max_size=8)


@prop(40)
@given(text=st.text(max_size=200), old=st.binary(max_size=50), fail=st.booleans())
def test_a_file_is_written_whole_or_not_at_all(tmp_path_factory, text, old, fail):
    """``write_text`` lands the exact UTF-8 bytes (line endings as given) or
    refuses naming the file; a write that fails midway leaves the old
    content and no temporary file behind."""
    note(REPRODUCE)
    folder = tmp_path_factory.mktemp("out")
    path = folder / "f.txt"
    path.write_bytes(old)
    if fail:
        with pytest.raises(RuntimeError):
            with files.atomic_file(path, "test") as fh:
                fh.write(text.encode("utf-8", "surrogatepass"))
                raise RuntimeError("killed midway")
        assert path.read_bytes() == old
    else:
        try:
            files.write_text(path, text, "test")
        except cdsm.CdsmInputError as exc:
            assert "f.txt" in str(exc) and any(0xD800 <= ord(ch) <= 0xDFFF for ch in text)
            assert path.read_bytes() == old
        else:
            assert path.read_bytes() == text.encode("utf-8")
    assert sorted(os.listdir(folder)) == ["f.txt"]


@prop(25)
@given(tree=st.dictionaries(st.lists(FILE_NAMES, min_size=1, max_size=3).map("/".join), st.binary(max_size=64),
                            min_size=1, max_size=6),
       data=st.data())
def test_a_run_manifest_lists_every_file_with_its_hash(tmp_path_factory, tree, data):
    """A run (``files.run_directory``) that writes files and finishes: the
    manifest is complete and lists exactly those files (sorted,
    '/'-separated) with the SHA-256 of the bytes written; a file of the run
    changed or removed makes it incomplete, a file beside them does not."""
    note(REPRODUCE)
    out = tmp_path_factory.mktemp("run")
    # a run's files are top-level names or <subdir>/<file>: fold deeper paths into one subdirectory level
    flat = {}
    for rel, blob in tree.items():
        parts = rel.split("/")
        flat[parts[0] if len(parts) == 1 else parts[0] + "/" + "_".join(parts[1:])] = blob
    flat = {k: v for k, v in flat.items() if not any(o.startswith(k + "/") for o in flat)}
    names = [k for k in flat if "/" not in k]
    subdirs = sorted({k.split("/")[0] for k in flat if "/" in k})
    with files.run_directory(out, "test", names, subdirs=subdirs) as run:
        for rel, blob in flat.items():
            run.write(rel, blob, "test")
        assert not files.run_complete(out)
        man = json.loads(open(run.finish(), encoding="utf-8").read())
    assert man["complete"] is True and list(man["files"]) == sorted(flat)
    assert all(man["files"][k] == hashlib.sha256(v).hexdigest() for k, v in flat.items())
    assert files.run_complete(out)
    (out / "beside.txt").write_text("not the run's")
    assert files.run_complete(out)
    victim = out / data.draw(st.sampled_from(sorted(flat)))
    if data.draw(st.booleans()):
        victim.unlink()
    else:
        victim.write_bytes(victim.read_bytes() + b"!")
    assert not files.run_complete(out)
    assert files.run_complete(out, verify=False)
