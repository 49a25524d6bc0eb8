"""Registration as a tested hypothesis and the search beyond greedy forward
selection (issue 25 items 5-6), checked on withheld effects: seeded
virtual-prototype data with 10 µm noise; the diagnosis is never told what
is in them. The measured rates over many data sets are the benchmark
``benches/bench_error_rates.py``.
"""

from __future__ import annotations


import numpy as np
import pytest

NOISE = 10e-6


@pytest.fixture(scope="module")
def mods(cdsm):
    from cdsm.calibration import diagnosis, measurements, plant

    return dict(diagnosis=diagnosis, plant=plant, measurements=measurements)


@pytest.fixture(scope="module")
def robot(cdsm):
    return cdsm.Robot.paper()


def _data(plant, robot, effects, seed, rows):
    vp = plant.VirtualPrototype(robot, effects, noise=NOISE, seed=seed)
    th, dl = vp.random_commands(rows)
    return vp.measure(th, dl)


def _tracker(meas, angle=np.radians(30.0), shift=(1.3, -0.5)):
    """The same readings in a tracker frame rotated by ``angle`` and moved by ``shift`` (m)."""
    c, s = np.cos(angle), np.sin(angle)
    out = meas.measured @ np.array([[c, s], [-s, c]]) + np.asarray(shift)
    return type(meas)("absolute", meas.n, meas.dL, out, theta=meas.theta, source="tracker")


MIX = {"actuation_scale": [0.03], "cable_offset": [1.5e-4, -1.2e-4, 2e-4]}


def test_data_near_the_model_are_taken_in_the_base_frame(mods, robot):
    """The issue's case: 60 absolute rows in the base frame mixing a 3 %
    actuation scale and 0.12-0.2 mm cable offsets. Their distance from the
    nominal predictions is far below 5 % of the arm's length, so the frame is
    a candidate, not a registration, and the true pair is found, explained."""
    diagnosis = mods["diagnosis"]
    d = diagnosis.diagnose(robot, _data(mods["plant"], robot, MIX, 0, 60), noise=NOISE)
    assert not d.prep.registered
    assert "frame_misalignment" in [c.name for c in d.singles]
    reg = d.to_json()["registration"]
    assert reg["rule"] == "auto" and not reg["fitted"]
    assert reg["offset_m"] < 0.5 * reg["near_m"]
    assert reg["near_m"] == pytest.approx(diagnosis.NEAR_FRACTION * robot.straight_length)
    assert set(d.best.split("+")) == {"actuation_scale", "cable_offset"} and d.verdict == "explained"


def test_data_in_a_tracker_frame_are_registered(mods, robot):
    """The same readings 1.4 m and 30 degrees away: registered, the frame
    named, and the same pair found beside it."""
    d = mods["diagnosis"].diagnose(robot, _tracker(_data(mods["plant"], robot, MIX, 0, 60)), noise=NOISE)
    assert d.prep.registered and d.registration_named
    assert d.prep.offset > mods["diagnosis"].NEAR_FRACTION * robot.straight_length
    assert d.best.split("+")[0] == "frame_misalignment"
    assert set(d.best.split("+")[1:]) == {"actuation_scale", "cable_offset"} and d.verdict == "explained"


def _translation_only(plant, robot, index, theta, dl, delta=1e-4):
    """Whether changing flat parameter ``index`` by ``delta`` moves every
    predicted tip position by one and the same vector (a rigid translation,
    which a registered frame could not tell from its own)."""
    p = np.zeros(plant.size(robot))
    y0, _ = plant.predict(robot, p, theta, dl)
    p[index] = delta
    y1, _ = plant.predict(robot, p, theta, dl)
    k = plant.dims(robot)
    move = y1[:, :k] - y0[:, :k]
    return bool(np.abs(move - move.mean(axis=0)).max() < 1e-3 * delta)


@pytest.mark.parametrize("name", ["paper", "two_universal"])
def test_the_first_link_is_not_a_translation(cdsm, mods, name):
    """The base-to-first-joint link changes the cable routes and with them the
    joint angles the cables realise: its effect on the tip is not a rigid
    translation (in either kind), so a registered frame cannot absorb it
    and registered data determine it (finite standard deviation)."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    robot = cdsm.Robot.paper() if name == "paper" else cdsm.Robot.from_toml(name)
    vp = plant.VirtualPrototype(robot, {}, noise=NOISE, seed=3)
    th, dl = vp.random_commands(30, limit=0.4)
    first = plant.effect_indices(robot, "link_length")[:plant.dims(robot) if robot.kind == "spatial" else 1]
    for i in first:
        assert not _translation_only(plant, robot, i, th, dl)
    if robot.kind == "planar":
        hidden = {"link_length": [4e-4, -3e-4, 2e-4, -2e-4]}
        meas = _tracker(_data(plant, robot, hidden, 3, 40))
        d = diagnosis.diagnose(robot, meas, effects=["link_length"], noise=NOISE)
        assert d.prep.registered and d.best == "frame_misalignment+link_length"
        fit = d.final().fit.params_by_effect(robot)["link_length"]
        std = d.final().fit.std_by_effect(robot)["link_length"]
        assert np.isfinite(std).all() and abs(fit[0] - 4e-4) < 4 * std[0] + 2e-6


def test_backward_elimination_drops_an_effect_the_model_does_not_need(mods, robot):
    """Base-frame data with link lengths and a tip offset hidden: forward
    selection takes the frame first (it mimics part of the first link), then
    the two hidden effects; with them in, the frame no longer helps and is
    dropped. The answer is the hidden pair, explained."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    hidden = {"link_length": [4e-4, -3e-4, 2e-4, -2e-4], "tip_offset": [1e-3, -5e-4]}
    d = diagnosis.diagnose(robot, _data(plant, robot, hidden, 0, 60), noise=NOISE)
    assert not d.prep.registered
    assert d.steps[0].name == "frame_misalignment" and d.dropped == ["frame_misalignment"]
    assert set(d.best.split("+")) == {"link_length", "tip_offset"} and d.verdict == "explained"
    assert d.to_json()["dropped"] == ["frame_misalignment"]


def test_frame_base_is_never_registered(mods, robot):
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    meas = _tracker(_data(plant, robot, MIX, 2, 20))
    assert not diagnosis.prepare(robot, meas, frame="base").registered
    assert diagnosis.prepare(robot, meas, frame="auto").registered


def test_the_search_finds_the_pair_greedy_selection_misses(mods, robot):
    """Forward selection alone stops at a model that is not adequate here
    (actuation scale first, then a hole effect that mimics part of the
    offsets); the search over all pairs and triples finds the hidden pair,
    adequate, under the family-corrected test, and says so in the JSON."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    d = diagnosis.diagnose(robot, _data(plant, robot, MIX, 0, 60), noise=NOISE)
    s = d.search
    assert s is not None and s.reason.startswith("forward selection ended with a model that is not adequate")
    greedy = d.steps[-1]
    assert set(greedy.effects) != {"actuation_scale", "cable_offset"}
    assert s.replaced and set(s.picked.split("+")) == {"actuation_scale", "cable_offset"}
    library = len(d.singles)
    assert s.family == library * (library - 1) // 2 + 10  # every pair, triples among the best five
    assert s.alpha == pytest.approx(diagnosis.ALPHA / s.family)
    j = d.to_json()["search"]
    assert j["picked"] == s.picked and j["replaced_greedy"] and len(j["linearised_heldout_rms_m"]) == s.family
    assert d.verdict == "explained" and d.final().heldout_rms <= 1.5 * d.noise_floor


@pytest.mark.parametrize("seed", [0, 2])
def test_fifteen_rows_of_backlash_and_cable_offsets(mods, robot, seed):
    """15 rows of backlash + cable offsets (the issue's case that ended
    'unexplained' with only the frame named): found, in the base frame and
    in a tracker frame."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    hidden = {"backlash": [6e-5, 4e-5, 3e-5], "cable_offset": [3e-4, -2e-4, 1e-4]}
    meas = _data(plant, robot, hidden, seed, 15)
    for m in (meas, _tracker(meas)):
        d = diagnosis.diagnose(robot, m, noise=NOISE)
        names = [e for e in d.best.split("+") if e != "frame_misalignment"]
        assert set(names) == {"backlash", "cable_offset"} and d.verdict == "explained"


def test_the_search_does_not_explain_an_effect_outside_the_library(mods, robot):
    """A quadratic actuator (see test_diagnose): forward selection chooses
    nothing adequate, the search runs, and the verdict is still not
    'explained'."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    vp = plant.VirtualPrototype(robot, {}, noise=NOISE, seed=4)
    th, dl = vp.random_commands(60)
    l_ref = robot.upper_lengths(np.zeros(robot.n))
    real = vp.measure(th, dl + 0.3 * (robot.upper_lengths(th) + dl - l_ref) ** 2)
    meas = mods["measurements"].Measurements("absolute", robot.n, dl, real.measured, theta=th, source="quadratic")
    d = diagnosis.diagnose(robot, meas, noise=NOISE)
    assert d.search is not None and not d.explained


@pytest.fixture(scope="module")
def spatial(cdsm):
    return cdsm.Robot.from_toml("two_universal")


def test_hole_positions_contain_the_actuation_scale_and_the_cable_offsets(mods, spatial, robot):
    """On a spatial arm the 48 hole coordinates reproduce, to first order, an
    actuation scale (every hole moved radially scales every moment arm) and
    a cable's length offset (the hole it is anchored in moved along its
    disk): the data cannot tell those effects from hole positions, and no
    other pair of the library is nested so. The planar paper arm has no
    such pair."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    for arm, want in ((spatial, {("hole_position", "actuation_scale"), ("hole_position", "cable_offset")}),
                      (robot, set())):
        prep = diagnosis.prepare(arm, _data(plant, arm, {}, 1, 60))
        library = list(plant.effects_of(arm))
        got = {pair for e in library for pair in diagnosis.nested(prep, [e], library, NOISE)}
        assert got == want


def test_the_search_runs_when_the_greedy_model_holds_a_containing_effect(mods, spatial):
    """60 rows of an actuation scale and hole clearance on a spatial arm:
    forward selection takes the hole positions first (48 parameters that
    contain the scale) and stops, adequate, at hole positions + clearance.
    The search compares the combinations built on the contained effect and
    picks the hidden pair (3 parameters, lower held-out RMS)."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    meas = _data(plant, spatial, {"actuation_scale": [0.03], "hole_clearance": [2e-4]}, 1, 60)
    d = diagnosis.diagnose(spatial, meas, effects=["actuation_scale", "hole_position", "hole_clearance", "tip_offset"],
                           noise=NOISE)
    assert [c.name for c in d.steps][0] == "hole_position"
    assert d.search is not None and "`hole_position` contains `actuation_scale`" in d.search.reason
    assert set(d.best.split("+")) == {"actuation_scale", "hole_clearance"} and d.verdict == "explained"


def test_a_scale_and_offsets_are_not_named_as_the_hole_positions_that_contain_them(mods, spatial):
    """60 rows of an actuation scale and cable offsets on a spatial arm: the
    48 hole coordinates contain both, so hole positions alone are adequate
    and forward selection stops there. One effect is no smaller than two
    when it holds them: the search on the contained effects picks by BIC
    the hidden pair (5 parameters against 48)."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    hidden = {"actuation_scale": [0.027], "cable_offset": [2e-4, -3.3e-4, -3e-4, 3.1e-4]}
    d = diagnosis.diagnose(spatial, _data(plant, spatial, hidden, 1, 60), noise=NOISE,
                           effects=["actuation_scale", "cable_offset", "hole_position", "tip_offset"])
    assert [c.name for c in d.steps] == ["hole_position"]
    assert d.search is not None and d.search.replaced
    assert set(d.best.split("+")) == {"actuation_scale", "cable_offset"} and d.verdict == "explained"


def test_a_pair_fitted_under_a_triple_is_a_candidate(mods, spatial):
    """60 rows of a 3 % actuation scale and 0.2-0.34 mm cable offsets on a
    spatial arm (a tip gap of 1 mm: the plant is far from linear over it).
    Forward selection stops at hole positions, not adequate; the linearised
    screen ranks the hidden pair outside the combinations it fits, but the
    pair is fitted in full to check the triples above it. Found so, it is
    a candidate too: the search names it, explained (before: a triple with
    the frame and the links, partly explained)."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    hidden = {"actuation_scale": [0.02957114], "cable_offset": [2.3461e-4, -2.6776e-4, 3.3804e-4, -2.0416e-4]}
    vp = plant.VirtualPrototype(spatial, hidden, noise=NOISE, seed=1349029139)
    th, dl = vp.random_commands(60, seed=895883486)
    d = diagnosis.diagnose(spatial, vp.measure(th, dl), noise=NOISE, effects=[
        "actuation_scale", "cable_offset", "hole_position", "link_length", "frame_misalignment"])
    assert d.search is not None and d.search.reason.startswith("forward selection ended")
    ranked = [set(k.split("+")) for k in sorted(d.search.screened, key=d.search.screened.get)]
    assert ranked.index({"actuation_scale", "cable_offset"}) >= diagnosis.SEARCH_FULL
    assert set(d.best.split("+")) == {"actuation_scale", "cable_offset"} and d.verdict == "explained"


def test_what_an_inadequate_container_holds_is_fitted_in_full(mods, spatial):
    """60 rows of a 2.2 % actuation scale and 0.34-0.40 mm cable offsets on
    a spatial arm (data set 4 of the error-rate benchmark's cell). Forward
    selection stops at hole positions, which contain both effects but are
    not adequate here: 48 coordinates fitted from a 1 mm gap do not reach
    the floor. The search, told that the hole positions contain the scale
    and the offsets, fits the pair built from them in full whatever its
    linearised screen, and names it, explained (before: hole positions,
    partly explained)."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    hidden = {"actuation_scale": [0.02249], "cable_offset": [-3.3523e-4, 3.9995e-4, 3.6133e-4, 3.9594e-4]}
    vp = plant.VirtualPrototype(spatial, hidden, noise=NOISE, seed=557077730)
    th, dl = vp.random_commands(60, seed=114582531)
    d = diagnosis.diagnose(spatial, vp.measure(th, dl), noise=NOISE, effects=[
        "actuation_scale", "cable_offset", "hole_position", "link_length", "tip_offset", "frame_misalignment"])
    assert [c.name for c in d.steps] == ["hole_position"]
    assert d.search is not None and d.search.reason.startswith("forward selection ended with a model that is not")
    assert "`hole_position` contains `actuation_scale`" in d.search.reason
    assert set(d.best.split("+")) == {"actuation_scale", "cable_offset"} and d.verdict == "explained"


def test_a_container_within_the_fixed_bound_but_not_its_own_is_searched(mods, spatial):
    """60 rows of a 3 % actuation scale and a 1-2 mm tip offset on a spatial
    arm (data set 3 of the error-rate benchmark's cell): a gap of 2.6 mm.
    Forward selection ends at links + hole positions + tip offset (69
    parameters); the hole positions contain the scale. Its held-out RMS, 24
    µm, was within the fixed 1.5x the floor (26 µm), so the search once
    fitted only what its screen put within a margin of that and the
    hidden pair needed the container's members fitted whatever their screen.
    Its own bound (what a correct model with 69 parameters reaches on these
    rows and folds, 23 µm) refuses it: the search runs on every combination
    as for a model that is not adequate, and names the hidden pair, the one
    adequate, explained."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    hidden = {"actuation_scale": [-0.030123], "tip_offset": [0.0012477, -0.0018848, 0.0010094]}
    vp = plant.VirtualPrototype(spatial, hidden, noise=NOISE, seed=1018740078)
    th, dl = vp.random_commands(60, seed=1004663677)
    d = diagnosis.diagnose(spatial, vp.measure(th, dl), noise=NOISE,
                           effects=["actuation_scale", "tip_offset", "link_length", "hole_position"])
    greedy = d.steps[-1]
    assert greedy.name == "link_length+hole_position+tip_offset"
    s = d.search
    assert s is not None and s.reason.startswith("forward selection ended with a model that is not adequate")
    assert "`hole_position` contains `actuation_scale`" in s.reason
    assert s.bounds[greedy.name] < greedy.heldout_rms <= 1.5 * d.noise_floor
    assert s.adequate == ["tip_offset+actuation_scale"]
    assert set(d.best.split("+")) == {"actuation_scale", "tip_offset"} and d.verdict == "explained"


def test_a_tie_beside_a_container_names_both_reasons(mods, spatial):
    """60 rows of a 3 % actuation scale and cable offsets on a spatial arm
    (data set 7 of the error-rate benchmark's cell): the first single
    effect, the links, ties with the hole positions, and the model forward
    selection ends with (links + hole positions + scale) holds the hole
    positions, which contain the offsets. The search's family is the one
    built on what they contain, and its reason says both (before: the tie
    alone); it names the hidden pair."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    hidden = {"actuation_scale": [-0.033327], "cable_offset": [-0.00029817, -0.00032642, 0.00027094, -0.00020563]}
    vp = plant.VirtualPrototype(spatial, hidden, noise=NOISE, seed=868818143)
    th, dl = vp.random_commands(60, seed=100502371)
    d = diagnosis.diagnose(spatial, vp.measure(th, dl), noise=NOISE,
                           effects=["actuation_scale", "cable_offset", "link_length", "hole_position"])
    s = d.search
    assert s is not None and s.reason.startswith("single effects tie with `link_length`: hole_position; ")
    assert "`hole_position` contains `cable_offset`" in s.reason
    assert all(("actuation_scale" in k or "cable_offset" in k) and "hole_position" not in k for k in s.screened)
    assert set(d.best.split("+")) == {"actuation_scale", "cable_offset"} and d.verdict == "explained"
