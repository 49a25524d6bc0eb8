"""cdsm 0.3 renames (issue 33, "names that mean one thing"): every old public
name still works for one release, warns with a DeprecationWarning naming the
new one, and gives the same thing as the new name."""

from __future__ import annotations

import sys
import warnings

import numpy as np
import pytest


def test_model_is_fitted_plant_with_a_warning(cdsm, monkeypatch):
    import cdsm.calibration as calibration
    import cdsm.calibration.model as model

    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        new = cdsm.FittedPlant  # the new name: no warning
    assert new is model.FittedPlant is calibration.FittedPlant
    for where, path in ((cdsm, "cdsm"), (calibration, "cdsm.calibration"), (model, "cdsm.calibration.model")):
        with pytest.warns(DeprecationWarning, match=rf"{path}\.Model is deprecated.*{path}\.FittedPlant"):
            assert where.Model is new
    with pytest.warns(DeprecationWarning, match="FittedPlant"):
        from cdsm.calibration.model import Model
    assert Model is new
    with pytest.raises(AttributeError):
        model.NoSuchName  # noqa: B018
    # the 0.1 module path serves it under the old name too
    monkeypatch.delitem(sys.modules, "cdsm.model", raising=False)
    with pytest.warns(DeprecationWarning, match="cdsm.calibration.model"):
        import cdsm.model as old_module
    assert old_module.Model is new
    # what the old name builds is what the new name builds
    robot = cdsm.Robot.paper()
    with pytest.warns(DeprecationWarning):
        old = cdsm.Model.from_effects(robot, {"actuation_scale": [0.01]})
    assert old == new.from_effects(robot, {"actuation_scale": [0.01]})
    assert "Model" not in cdsm.__all__ and "FittedPlant" in cdsm.__all__


def test_scenario_kind_is_error_with_a_warning(cdsm):
    from cdsm.study import Scenario, scenario_set

    robot = cdsm.Robot.paper()
    for sc in scenario_set(robot):
        with pytest.warns(DeprecationWarning, match=r"Scenario\.kind is deprecated.*Scenario\.error"):
            old = sc.kind
        assert old == sc.error and old in ("cable", "hole")
    # the old constructor keyword builds the same scenario
    with pytest.warns(DeprecationWarning, match=r"Scenario\(kind=\.\.\.\).*Scenario\(error=\.\.\.\)"):
        old = Scenario("disk1+", "label", np.zeros(3), kind="hole", cable=0)
    new = Scenario("disk1+", "label", np.zeros(3), error="hole", cable=0)
    assert old.error == new.error == "hole" and (old.key, old.cable) == (new.key, new.cable)
    with pytest.raises(TypeError, match="error="), pytest.warns(DeprecationWarning):
        Scenario("disk1+", "label", np.zeros(3), kind="hole", error="hole")


def test_error_budget_kinds_is_group_types_with_a_warning(cdsm):
    from cdsm.accuracy.sensitivity import error_budget

    robot = cdsm.Robot.paper()
    budget = error_budget(robot, np.radians([[10.0, -5.0, 20.0], [0.0, 15.0, -10.0]]), 1e-3, 3.5e-4, samples=64)
    assert budget.group_types == ("length",) * 3 + ("holes",) * 3
    with pytest.warns(DeprecationWarning, match=r"ErrorBudget\.kinds is deprecated.*ErrorBudget\.group_types"):
        assert budget.kinds == budget.group_types


def test_reading_codes_and_their_old_names(cdsm):
    import cdsm.calibration.measurements as measurements
    import cdsm.calibration.plant as cal
    import cdsm.plant as plant

    assert plant.READING_CODES == {"absolute": 0, "displacement": 1, "unmeasured": 2}
    assert cal.READING_CODES is measurements.READING_CODES is plant.READING_CODES
    for mod in (plant, cal, measurements):
        with pytest.warns(DeprecationWarning, match=rf"{mod.__name__}\.KIND_CODES is deprecated.*READING_CODES"):
            assert mod.KIND_CODES is plant.READING_CODES
    for mod in (plant, cal):
        with pytest.warns(DeprecationWarning, match=rf"{mod.__name__}\.kind_codes is deprecated.*reading_codes"):
            assert mod.kind_codes is plant.reading_codes
    np.testing.assert_array_equal(plant.reading_codes(["displacement", "unmeasured"], 2), [1, 2])
    with pytest.raises(cdsm.CdsmInputError, match="`reading`: expected one of"):
        plant.reading_codes("absolut", 2)


def test_the_plant_functions_take_kind_as_reading_with_a_warning(cdsm):
    from cdsm import plant

    robot = cdsm.Robot.paper()
    p = plant.params(robot, {"backlash": [1e-5, 2e-5, 3e-5], "actuation_scale": [0.01]})
    theta = np.radians([[10.0, -5.0, 20.0], [12.0, -4.0, 18.0], [0.0, 15.0, -10.0]])
    dL = np.full((3, 3), 2e-4)
    reading = ["absolute", "displacement", "unmeasured"]
    calls = {
        "predict": (lambda **kw: plant.predict(robot, p, theta, dL, **kw)),
        "linearise": (lambda **kw: plant.linearise(robot, p, [0, 1], theta, dL, **kw)),
        "settle": (lambda **kw: plant.settle(robot, p, theta, dL, **kw)),
        "check_commands": (lambda **kw: plant.check_commands(robot, theta, dL, **kw)),
        "taut_commands": (lambda **kw: plant.taut_commands(robot, theta, dL, **kw)),
    }
    for name, call in calls.items():
        new = call(reading=reading)
        with pytest.warns(DeprecationWarning, match=rf"cdsm\.plant\.{name}\(kind=\.\.\.\).*\(reading=\.\.\.\)"):
            old = call(kind=reading)
        for a, b in zip(new if isinstance(new, tuple) else (new,), old if isinstance(old, tuple) else (old,)):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    # the old keyword really is read: another reading gives other observations
    with pytest.warns(DeprecationWarning):
        disp, _ = plant.predict(robot, p, theta, dL, kind="displacement")
    assert np.isfinite(disp).all() and not np.array_equal(disp, plant.predict(robot, p, theta, dL)[0])


def test_measurements_prepared_suggestion_read_their_reading_under_the_old_names(cdsm):
    from cdsm.calibration import diagnosis, experiment
    from cdsm.calibration.measurements import Measurements
    from cdsm.calibration.plant import VirtualPrototype

    robot = cdsm.Robot.paper()
    vp = VirtualPrototype(robot, {"actuation_scale": [0.02]}, noise=10e-6, seed=3)
    th, dl = vp.random_commands(12, reading="displacement")
    with pytest.warns(DeprecationWarning, match=r"VirtualPrototype\.random_commands\(kind=\.\.\.\)"):
        old_th, old_dl = vp.random_commands(12, kind="displacement")
    np.testing.assert_array_equal(th, old_th)
    np.testing.assert_array_equal(dl, old_dl)
    meas = vp.measure(th, dl, reading="displacement")
    with pytest.warns(DeprecationWarning, match=r"VirtualPrototype\.measure\(kind=\.\.\.\)"):
        old = vp.measure(th, dl, kind="displacement")
    np.testing.assert_array_equal(old.measured, meas.measured)
    assert old.reading == meas.reading == "displacement"
    with pytest.warns(DeprecationWarning, match=r"Measurements\.kind is deprecated.*Measurements\.reading"):
        assert meas.kind == "displacement"
    with pytest.warns(DeprecationWarning, match=r"Measurements\.kind_codes\(\).*Measurements\.reading_codes\(\)"):
        np.testing.assert_array_equal(meas.kind_codes(), meas.reading_codes())
    np.testing.assert_array_equal(meas.reading_codes(), np.ones(12))
    with pytest.warns(DeprecationWarning, match=r"Measurements\(kind=\.\.\.\)"):
        built = Measurements(kind="displacement", n=3, dL=dl, measured=meas.measured, theta=th)
    assert built.reading == "displacement"

    prep = diagnosis.prepare(robot, meas)
    assert prep.reading == "displacement"
    with pytest.warns(DeprecationWarning, match=r"Prepared\.kind is deprecated.*Prepared\.reading"):
        assert prep.kind == "displacement"
    with pytest.warns(DeprecationWarning, match=r"Prepared\.kinds is deprecated.*Prepared\.reading_codes"):
        assert prep.kinds is prep.reading_codes

    d = diagnosis.diagnose(robot, meas, effects=["actuation_scale", "cable_offset"], folds=3)
    sug = experiment.suggest(d, 2, pool=40)
    assert sug.reading == "displacement" and "# reading: displacement" in sug.csv_text()
    with pytest.warns(DeprecationWarning, match=r"Suggestion\.kind is deprecated.*Suggestion\.reading"):
        assert sug.kind == sug.reading
    pool = experiment.candidate_pool(robot, "displacement", size=30, seed=2)
    with pytest.warns(DeprecationWarning, match=r"candidate_pool\(kind=\.\.\.\)"):
        old_pool = experiment.candidate_pool(robot, kind="displacement", size=30, seed=2)
    for a, b in zip(pool, old_pool):
        np.testing.assert_array_equal(a, b)


def test_fitted_plant_predict_takes_kind_as_reading_with_a_warning(cdsm):
    robot = cdsm.Robot.paper()
    fitted = cdsm.FittedPlant.from_effects(robot, {"actuation_scale": [0.01]})
    theta = np.radians([[10.0, -5.0, 20.0], [0.0, 15.0, -10.0]])
    new = fitted.predict(theta, reading="displacement")
    with pytest.warns(DeprecationWarning, match=r"FittedPlant\.predict\(kind=\.\.\.\).*\(reading=\.\.\.\)"):
        old = fitted.predict(theta, kind="displacement")
    np.testing.assert_array_equal(new[0], old[0])
    assert np.isfinite(new[0]).all() and not np.array_equal(new[0], fitted.predict(theta)[0])
