"""The scripts in ``examples/`` run, on small sizes, and say what they should."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(name, argv, capsys, monkeypatch):
    monkeypatch.setattr(sys, "argv", [name] + argv)
    runpy.run_path(str(EXAMPLES / name), run_name="__main__")
    return capsys.readouterr().out


def test_monte_carlo(cdsm, tmp_path, capsys, monkeypatch):
    out = tmp_path / "mc.npz"
    text = _run("monte_carlo.py", ["--samples", "40", "--chunk", "16", "--step", "15", "--out", str(out)],
                capsys, monkeypatch)
    assert "125 configurations x 40 samples" in text
    from cdsm.accuracy import montecarlo

    mc, params = montecarlo.load_npz(out)
    assert mc.count.sum() + mc.failed.sum() == 125 * 40 and params["samples"] == 40


def test_diagnose_measurements(cdsm, capsys, monkeypatch):
    text = _run("diagnose_measurements.py", ["--rows", "30"], capsys, monkeypatch)
    assert "verdict: explained" in text and "hole_height" in text


def test_tolerances(cdsm, capsys, monkeypatch):
    text = _run("tolerances.py", ["--samples", "100", "--step", "15"], capsys, monkeypatch)
    assert "cable length tolerance (mm)" in text and "target 1.0 mm" in text


def test_describe_robot(cdsm, capsys, monkeypatch):
    text = _run("describe_robot.py", [], capsys, monkeypatch)
    assert "'two-section example arm': planar arm, 4 joints" in text and "taut" in text
    r = cdsm.Robot.from_toml(EXAMPLES / "two_section_arm.toml")
    assert r.n == 4 and np.allclose(r.gravity, [0, -9.80665]) and r.routing_length == 0.4


def test_a_bad_robot_file_names_the_field(cdsm, tmp_path, capsys, monkeypatch):
    bad = tmp_path / "bad.toml"
    bad.write_text((EXAMPLES / "two_section_arm.toml").read_text().replace("thickness = 0.008", "thickness = -1", 1))
    with pytest.raises(cdsm.CdsmInputError, match=r"linkage\[0\]\.thickness"):
        _run("describe_robot.py", [str(bad)], capsys, monkeypatch)


def test_walkthrough_from_a_robot_file_to_a_diagnosis(cdsm, tmp_path, capsys, monkeypatch):
    """The walkthrough: describe and draw the arm, Monte Carlo, measurements
    through a CSV file, diagnosis (the hidden hole heights found), next
    measurements, compensation."""
    text = _run("walkthrough.py", ["--out", str(tmp_path), "--rows", "30", "--samples", "30"], capsys, monkeypatch)
    assert "two-section example arm" in text and "joints:" in text
    assert (tmp_path / "arm.png").stat().st_size > 10_000 and (tmp_path / "measurements.csv").exists()
    assert "verdict: explained; best: hole_height" in text
    assert "next measurements: 4 commands" in text and "compensated 5 of 5 targets" in text
