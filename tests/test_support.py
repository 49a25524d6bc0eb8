"""The support test and the adequacy bound of the diagnosis (issue 34): where
the noise is known (given, or estimated from repeats) an effect is supported
by a likelihood-ratio test of nested models beside a held-out guard; where it
is only assumed, by the held-out signed-rank test, and the diagnosis says how
that limits its verdict; a model is adequate when its held-out RMS is within
the bound a correct model reaches on the same rows and folds. Checked on
seeded virtual-prototype data (the diagnosis is never told what is in them)
against independent computations; the statistics themselves are checked in
``tests/test_stats.py``, the measured rates are ``benches/bench_error_rates.py``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

NOISE = 10e-6
LIBRARY = ["actuation_scale", "cable_offset", "hole_height", "link_length", "cable_elasticity",
           "hole_clearance", "frame_misalignment", "tip_offset", "backlash"]


@pytest.fixture(scope="module")
def mods(cdsm):
    from cdsm import cli
    from cdsm.calibration import diagnosis, measurements, plant
    from cdsm.report import diagnosis as report

    return dict(cli=cli, diagnosis=diagnosis, report=report, measurements=measurements, plant=plant)


@pytest.fixture(scope="module")
def robot(cdsm):
    return cdsm.Robot.paper()


def _data(plant, robot, effects, seed, rows, noise=NOISE):
    vp = plant.VirtualPrototype(robot, effects, noise=noise, seed=seed)
    th, dl = vp.random_commands(rows)
    return vp.measure(th, dl)


def _rss(plant, d, c) -> float:
    """The position residuals' sum of squares of candidate ``c``, its rows
    predicted anew by the plant at its fitted parameters (not the fit's own
    predictions)."""
    prep = d.prep
    o = prep.order
    obs, _ = plant.predict(prep.robot, c.fit.p, prep.theta_cmd[o], prep.dL[o], prep.reading_codes[o])
    pred = np.empty_like(obs)
    pred[o] = obs
    k = plant.dims(prep.robot)
    return float(np.sum((pred[prep.rows, :k] - prep.measured[prep.rows, :k]) ** 2))


def _free(plant, robot, c) -> int:
    """The parameters ``c`` fitted that are not at a bound of the physical domain."""
    lo, hi = plant.bounds(robot)
    idx = np.concatenate([plant.effect_indices(robot, e) for e in c.fitted]) if c.fitted else np.zeros(0, int)
    v = c.fit.p[idx]
    return int(np.sum((v > lo[idx]) & (v < hi[idx])))


def test_the_support_statistic_is_the_drop_in_residuals_over_the_noise(mods, robot):
    """30 rows of links and a tip offset, the noise given: every forward
    step is a chi-square likelihood-ratio test whose statistic is the drop
    in the position residuals' sum of squares over sigma^2 (recomputed
    here from the plant at the fitted parameters), its degrees of freedom
    the parameters the step adds, its p-value scipy's chi-square tail."""
    from scipy import stats as sst

    plant, diagnosis = mods["plant"], mods["diagnosis"]
    meas = _data(plant, robot, {"link_length": [4e-4, -3e-4, 3e-4, -2e-4], "tip_offset": [1.5e-3, -8e-4]}, 7, 30)
    d = diagnosis.diagnose(robot, meas, effects=LIBRARY, folds=5, noise=NOISE, frame="base")
    assert set(d.best.split("+")) == {"link_length", "tip_offset"} and d.verdict == "explained"
    forward = [t for t in d.support if t.step.startswith("forward selection")]
    # the steps taken, and the one that stopped the selection (here: a third effect's held-out RMS is worse)
    assert [t.supported for t in forward] == [True] * len(d.steps) + [False] * (len(forward) - len(d.steps))
    assert all(t.test == "chi2" for t in forward)
    for t, big, small in zip(forward, d.steps, [d.baseline] + d.steps[:-1]):
        assert (t.big, t.small) == (big.name, small.name)
        want = (_rss(plant, d, small) - _rss(plant, d, big)) / NOISE ** 2
        assert t.statistic == pytest.approx(want, rel=1e-6)
        assert t.dof == (_free(plant, robot, big) - _free(plant, robot, small),)
        assert t.p_value == pytest.approx(sst.chi2.sf(t.statistic, t.dof[0]), rel=1e-9, abs=1e-300)
        assert t.heldout_big < t.heldout_small and t.guard_passed


def test_a_parameter_at_its_bound_adds_no_degree_of_freedom(mods, robot):
    """Nominal data, backlash the only candidate (three dead bands, each
    >= 0): the dead bands the fit leaves at 0 are not counted; all at 0 add
    nothing, p = 1."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    seen = set()
    for seed in (1, 2, 3, 4):
        d = diagnosis.diagnose(robot, _data(plant, robot, {}, seed, 20), effects=["backlash"], folds=5,
                               noise=NOISE, frame="base")
        (t,) = d.support
        b = d.singles[0].fit.p[plant.effect_indices(robot, "backlash")]
        assert t.dof == (int(np.sum(b > 0)),) and t.test == "chi2"
        if not (b > 0).any():
            assert t.p_value == 1.0 and not t.supported
        seen.add(int(np.sum(b > 0)))
        assert d.best == "none"
    assert len(seen) >= 2   # the count follows the fit, not the effect's size (3)


def test_repeats_give_the_f_test_against_pure_error(mods, robot):
    """30 µm noise, not told, every command measured twice: the support test
    is F against the repeats' pure error, its second degrees of freedom the
    pure error's, its p-value scipy's F tail."""
    from scipy import stats as sst

    plant, diagnosis = mods["plant"], mods["diagnosis"]
    vp = plant.VirtualPrototype(robot, {"hole_height": [3e-4, -2e-4, 2e-4]}, noise=30e-6, seed=34)
    th, dl = vp.random_commands(25)
    d = diagnosis.diagnose(robot, vp.measure(np.repeat(th, 2, axis=0), np.repeat(dl, 2, axis=0)), folds=5,
                           frame="base", effects=LIBRARY)
    ne = d.noise_estimate
    assert ne.source == "repeats" and d.best == "hole_height"
    t = d.support[0]
    assert t.test == "F" and t.dof == (3, ne.dof_pure) and t.supported
    want = ((_rss(plant, d, d.baseline) - _rss(plant, d, d.steps[0])) / 3) / (ne.ss_pure / ne.dof_pure)
    assert t.statistic == pytest.approx(want, rel=1e-6)
    assert t.p_value == pytest.approx(sst.f.sf(t.statistic, *t.dof), rel=1e-9, abs=1e-300)


def test_an_assumed_noise_keeps_the_held_out_test_and_says_how_it_limits_the_verdict(mods, robot, cdsm):
    """Table 3 (nine rows, no repeats, no noise given): the likelihood-ratio
    test would trust an assumed 10 µm; the support test stays the held-out
    signed-rank test, and the JSON and the report say what the assumption
    limits."""
    diagnosis = mods["diagnosis"]
    meas = mods["measurements"].read_for(robot, "table3")
    d = diagnosis.diagnose(robot, meas)
    assert d.noise_estimate.source == "assumed" and (d.best, d.verdict) == ("none", "unexplained")
    assert d.support and all(t.test == "signed-rank" for t in d.support)
    assert all(t.guard == "BIC lower" for t in d.support if t.nested)
    # the ties of the first single effect: tie tests, whatever the noise, each given
    assert {t.small for t in d.support if t.step == "ties of the first single effect"} >= set(d.ties)
    t = d.support[0]
    assert t.dof == (9,) and 0.0 <= t.statistic <= 45.0   # W+ of 9 pairs
    j = d.to_json()
    assert j["support"]["noise_source"] == "assumed" and "assumed" in j["support"]["limits"]
    assert "signed-rank" in j["support"]["rule"] and "signed-rank" in j["selection_test"]["kind"]
    text = " ".join(mods["report"].tests_text(d))
    assert "The noise is assumed" in text and "is judged against the assumed noise" in text


@pytest.mark.parametrize("rows, sets, named, no_gap", [(15, 20, 3, 16), (60, 10, 2, 8)])
def test_nominal_data_answer_no_gap(mods, robot, rows, sets, named, no_gap):
    """Nominal data, the noise given: the likelihood-ratio test at the
    family's level (0.025 over the nine candidates) names an effect in 2.5 %
    of data sets at most, and the nominal model is within its bound and its
    lack of fit in 99 %: no gap in about 96 %. Asked: at most ``named``
    effects named and ``no_gap`` no gaps of ``sets`` (binomial tails below
    0.3 %)."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    answers = []
    for seed in range(sets):
        d = diagnosis.diagnose(robot, _data(plant, robot, {}, 100 + seed, rows), effects=LIBRARY, folds=5,
                               noise=NOISE, frame="base")
        assert d.support[0].test == "chi2" and d.support[0].step == "forward selection, step 1"
        b = d.verdict_detail.nominal_bound
        # no parameter: the held-out RMS is the residuals' RMS, bounded at the chi-square's 0.99 quantile
        assert b.parameters == 0
        assert b.factor == pytest.approx(np.sqrt(_chi2_ppf(0.99, 2 * rows) / (2 * rows)), rel=0.03)
        answers.append((d.best, d.verdict))
    assert sum(best != "none" for best, _ in answers) <= named
    assert sum(a == ("none", "no gap") for a in answers) >= no_gap


def _chi2_ppf(q, dof):
    from scipy import stats as sst

    return float(sst.chi2.ppf(q, dof))


def test_fifteen_rows_find_the_offsets_beside_the_links(mods, cdsm):
    """15 rows of cable offsets (0.23-0.34 mm) beside link-length errors
    (0.3-0.54 mm) on two_universal, the noise given (data set 0 of the
    error-rate benchmark's cell). The offsets' change beside the links is
    7-8 sigma (benches/identifiability.md), but the held-out signed-rank
    test at the family's level needs 14 of 15 rows to gain: it stopped at
    the links, partly explained. The likelihood ratio has the power: both
    effects, explained."""
    plant, diagnosis = mods["plant"], mods["diagnosis"]
    spatial = cdsm.Robot.from_toml("two_universal")
    hidden = {"cable_offset": [-0.00024015, -0.00023022, -0.00034313, -0.0003415],
              "link_length": [-0.00035558, 0.00032898, 0.00034076, -0.0004787, -0.00049005, 0.00039065,
                              -0.00051052, 0.00035464, -0.00048616, -0.000539, -0.00043238, 0.00030192,
                              0.00050273, 0.00043125, 0.00030955, -0.00042346, 0.00042444, 0.00046879]}
    vp = plant.VirtualPrototype(spatial, hidden, noise=NOISE, seed=1862103045)
    th, dl = vp.random_commands(15, seed=577396957)
    d = diagnosis.diagnose(spatial, vp.measure(th, dl), noise=NOISE,
                           effects=["cable_offset", "link_length", "tip_offset"])
    assert set(d.best.split("+")) == {"cable_offset", "link_length"} and d.verdict == "explained"
    t = next(t for t in d.support if t.step == "forward selection, step 2")
    assert t.test == "chi2" and t.dof == (4,) and t.p_value < t.alpha < 0.025 and t.guard_passed


def test_the_json_and_the_report_give_every_test_and_the_bound(mods, robot, tmp_path, capsys):
    plant = mods["plant"]
    meas = _data(plant, robot, {"actuation_scale": [0.02]}, 2, 16)
    rows = [[*meas.theta[i], *meas.dL[i], *meas.measured[i]] for i in range(16)]
    csv = tmp_path / "d.csv"
    csv.write_text("theta_1,theta_2,theta_3,dL_1,dL_2,dL_3,x,y\n"
                   + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    out, rep = tmp_path / "d.json", tmp_path / "rep"
    assert mods["cli"].main(["diagnose", str(csv), "--effects", "actuation_scale,tip_offset", "--folds", "4",
                             "--frame", "base", "--noise", "1e-5", "--json", str(out), "--report", str(rep),
                             "--quiet"]) == 0
    capsys.readouterr()
    j = json.load(open(out))
    assert j["best"] == "actuation_scale" and j["verdict"] == "explained"
    assert j["support"]["noise_source"] == "given" and j["support"]["limits"] is None
    t = j["support"]["tests"][0]
    assert {"big", "small", "step", "test", "statistic", "dof", "p_value", "alpha", "supported"} <= set(t)
    assert (t["big"], t["small"], t["test"], t["dof"], t["supported"]) == ("actuation_scale", "none", "chi2", [1],
                                                                           True)
    a = j["adequacy"]
    assert a["quantile"] == 0.99 and "bootstrap" in a["method"]
    assert a["final"]["parameters"] == 1 and a["final"]["bound_m"] == j["verdict_detail"]["adequacy_bound_m"]
    assert j["chosen"]["heldout_rms_m"] <= a["final"]["bound_m"]
    assert a["nominal"]["parameters"] == 0 and j["baseline"]["heldout_rms_m"] > a["nominal"]["bound_m"]
    md = (rep / "report.md").read_text(encoding="utf-8")
    assert "The tests behind the verdict" in md and "χ² (LR)" in md and "adequacy bound" in md.lower()


def test_the_bound_tracks_a_full_parametric_bootstrap_on_the_plant(mods, robot):
    """15 rows of links and a tip offset (6 parameters against 30
    components): the linearised bound of the chosen model against a full
    parametric bootstrap run here — 40 data sets measured on a virtual
    prototype with the fitted parameters and the noise, at the same
    commands, each refitted in full on the same folds from the same start.
    The medians agree within 6 %, and the bound (the 0.99 quantile) is
    exceeded by at most 2 of the 40. The fixed 1.5x the floor of before
    refused 2 of them: it did not count six parameters fitted on 10 rows."""
    from cdsm.calibration.fit import fit_folds

    plant, diagnosis = mods["plant"], mods["diagnosis"]
    meas = _data(plant, robot, {"link_length": [4e-4, -3e-4, 3e-4, -2e-4], "tip_offset": [1.5e-3, -8e-4]}, 12, 15)
    d = diagnosis.diagnose(robot, meas, effects=["link_length", "tip_offset", "cable_offset"], folds=5,
                           noise=NOISE, frame="base")
    c = d.chosen
    assert set(c.effects) == {"link_length", "tip_offset"} and d.verdict == "explained"
    b = d.verdict_detail.bound
    assert b.parameters == 6 and b.bound == pytest.approx(d.to_json()["adequacy"]["final"]["bound_m"])
    rows = d.prep.rows
    scored = np.zeros((len(c.folds), len(d.prep.theta_cmd)), bool)
    for f, t in enumerate(c.folds):
        scored[f, rows] = True
        scored[f, t] = False
    full = []
    for seed in range(40):
        vp = plant.VirtualPrototype(robot, c.fit.params_by_effect(robot), noise=NOISE, seed=1000 + seed)
        prep = diagnosis.prepare(robot, vp.measure(d.prep.theta_cmd, d.prep.dL), frame="base")
        assert (prep.rows == rows).all()
        fits = fit_folds(prep, c.fitted, scored, np.zeros(plant.size(robot)))
        err = np.concatenate([np.linalg.norm(fits[f].prediction[t, :2] - prep.measured[t, :2], axis=1)
                              for f, t in enumerate(c.folds)])
        full.append(float(np.sqrt(np.mean(err ** 2))))
    full = np.array(full)
    assert np.median(full) == pytest.approx(b.median, rel=0.06)
    assert np.sum(full > b.bound) <= 2
    # the fixed 1.5x the floor of before refused 2 of these 40 correct models (5 %); the bound is 1.73x
    assert np.sum(full > 1.5 * d.noise_floor) >= 1 and b.factor > 1.7
