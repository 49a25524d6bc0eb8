"""Both arm kinds through the same doors (issue 22): a robot is named the
same way everywhere, the command line checks effects against the robot's own
library before it reads any data, nothing refused is refused late, and no
RuntimeWarning reaches the user. Each test reproduces a reported bug."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

ROBOTS = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "robots"


def _all_position_two_universal(cdsm):
    """``two_universal`` with every force cable made position-controlled (8
    position cables on 4 joints)."""
    text = (ROBOTS / "two_universal.toml").read_text()
    text, count = re.subn(r'mode = "force"\ntension = [0-9.]+\n', 'mode = "position"\n', text)
    assert count == 4
    return cdsm.Robot.from_toml_str(text)


# ---------------------------------------------------------------------------
# one rule for naming a robot
# ---------------------------------------------------------------------------
def test_a_packaged_name_is_a_robot_everywhere(cdsm, tmp_path):
    r = cdsm.Robot.from_toml("two_universal")
    assert r.kind == "spatial" and r.n == 4
    assert cdsm.Robot.from_toml(ROBOTS / "paper.toml").n == 3
    with pytest.raises(cdsm.CdsmInputError) as exc:
        cdsm.Robot.from_toml("two_universall")
    msg = str(exc.value)
    assert "two_universall" in msg and "two_universal" in msg.split("packaged:")[1] and "paper" in msg
    # a file of that name in the working directory wins over the packaged robot
    (tmp_path / "two_universal").write_text((ROBOTS / "paper.toml").read_text())
    assert cdsm.Robot.from_toml(tmp_path / "two_universal").kind == "planar"


# ---------------------------------------------------------------------------
# the command line checks what it can before reading the data
# ---------------------------------------------------------------------------
def _cli(capsys, argv):
    from cdsm import cli

    rc = cli.main(argv)
    return rc, capsys.readouterr().err


def test_cli_effects_follow_the_robots_kind(cdsm, tmp_path, capsys):
    """``hole_position`` is a spatial effect, ``hole_height`` a planar one:
    each refused for the other kind, named, before the data file is read."""
    absent = str(tmp_path / "no-such-data.csv")
    rc, err = _cli(capsys, ["diagnose", absent, "--robot", "two_universal", "--effects", "hole_height"])
    assert rc == 2 and "hole_height" in err and "spatial" in err and "no-such-data" not in err
    rc, err = _cli(capsys, ["diagnose", absent, "--effects", "hole_position"])
    assert rc == 2 and "hole_position" in err and "planar" in err and "no-such-data" not in err
    # accepted for its own kind: the next complaint is the missing file
    rc, err = _cli(capsys, ["diagnose", absent, "--robot", "two_universal", "--effects", "hole_position"])
    assert rc == 2 and "no-such-data" in err


def test_cli_suggest_on_a_spatial_arm_is_refused_before_the_diagnosis(cdsm, tmp_path, capsys):
    from cdsm.calibration import plant

    robot = cdsm.Robot.packaged("two_universal")
    vp = plant.VirtualPrototype(robot, {"actuation_scale": [0.02]}, noise=1e-5, seed=0)
    th, dl = vp.random_commands(8)
    m = vp.measure(th, dl)
    cols = ([f"theta_{i + 1}" for i in range(4)] + [f"dL_{i + 1}" for i in range(4)] + ["x", "y", "z"])
    rows = np.hstack([th, dl, m.measured[:, :3]])
    data = tmp_path / "d.csv"
    data.write_text(",".join(cols) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    out = tmp_path / "d.json"
    rc, err = _cli(capsys, ["diagnose", str(data), "--robot", "two_universal", "--suggest", "2", "--json", str(out),
                            "--quiet"])
    assert rc == 2 and "--suggest" in err and not out.exists()


# ---------------------------------------------------------------------------
# no RuntimeWarning reaches the user
# ---------------------------------------------------------------------------
def test_a_spatial_diagnosis_with_undetermined_fits_warns_nothing(cdsm):
    """The all-position arm: elasticity fits that cannot be evaluated (the
    review saw an overflow in the correlation, an SVD that did not converge
    and an All-NaN slice in the features) end as failed candidates, quietly."""
    from cdsm.calibration import diagnosis, plant

    robot = _all_position_two_universal(cdsm)
    vp = plant.VirtualPrototype(robot, {"tip_offset": [1e-3, 0.0, -1e-3]}, noise=1e-5, seed=2)
    th, dl = vp.random_commands(20)
    m = vp.measure(th, dl)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        d = diagnosis.diagnose(robot, m, effects=["cable_elasticity", "tip_offset"], folds=3, noise=1e-5)
    assert d.best is not None and "tip_offset" in d.best

