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
