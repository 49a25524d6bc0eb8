"""cdsm 0.3 renames (issue 33, "names that mean one thing"): every old public
name still works for one release, warns with a DeprecationWarning naming the
new one, and gives the same thing as the new name."""

from __future__ import annotations

import sys
import warnings

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
