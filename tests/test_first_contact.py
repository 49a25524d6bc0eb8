"""First contact with the command line (issue 23, item 5): packaged robots
and data by name and listed, errors in the command's own usage, help that
says names are accepted, a robot file in mm flagged, progress that ends
where it says."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _cli(capsys, argv):
    from cdsm import cli

    try:
        rc = cli.main(argv)
    except SystemExit as exc:  # argparse errors exit
        rc = exc.code
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_list_names_every_packaged_robot_and_table(cdsm, capsys):
    from cdsm.calibration import measurements

    rc, out, _ = _cli(capsys, ["list"])
    assert rc == 0
    for name in cdsm.robot.packaged_robots():
        assert f"  {name} " in out
    for name in measurements.packaged_names():
        assert f"  {name} " in out
    assert "sjtu_snake" in out and "table3" in out


def test_a_packaged_table_is_data_by_name_and_a_file_wins(cdsm, capsys, tmp_path, monkeypatch):
    rc, out, _ = _cli(capsys, ["diagnose", "table3", "--quiet"])
    assert rc == 0 and "Verdict: unexplained" in out
    rc, _, err = _cli(capsys, ["diagnose", "table4", "--quiet"])
    assert rc == 2 and "table4" in err and "table3" in err
    # a file named like a packaged table is read as the file
    monkeypatch.chdir(tmp_path)
    (tmp_path / "table3").write_text("theta_1,theta_2,theta_3,dL_1,dx,dy\n0,0,0,0.001,1e-4\n")
    rc, _, err = _cli(capsys, ["diagnose", "table3", "--quiet"])
    assert rc == 2 and "table3" in err and "row 1" in err


def test_an_unknown_option_shows_the_commands_usage(cdsm, capsys):
    rc, _, err = _cli(capsys, ["paper", "--out-dri", "x"])
    assert rc == 2 and "usage: cdsm paper" in err and "--out-dri" in err


@pytest.mark.parametrize("command", ["paper", "diagnose", "montecarlo", "tolerance", "export"])
def test_help_says_a_robot_may_be_a_packaged_name(cdsm, capsys, command):
    rc, out, _ = _cli(capsys, [command, "--help"])
    assert rc == 0 and "packaged robot" in " ".join(out.split())


def test_compensate_help_names_the_model_format_diagnose_writes(cdsm, capsys):
    from cdsm.calibration.model import FORMAT

    rc, out, _ = _cli(capsys, ["compensate", "--help"])
    assert rc == 0 and FORMAT in "".join(out.split())  # argparse may wrap at the hyphen


def test_a_robot_file_in_millimetres_is_flagged(cdsm):
    text = (EXAMPLES / "two_section_arm.toml").read_text()
    mm = text.replace("link_before = 0.02 ", "link_before = 20 ").replace("link_after = 0.02 ", "link_after = 20 ")
    with pytest.warns(cdsm.CdsmDataWarning, match="in mm"):
        cdsm.Robot.from_toml_str(mm)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        cdsm.Robot.from_toml_str(text)


def test_progress_ends_at_its_total_without_a_negative_estimate(cdsm, monkeypatch):
    from cdsm import progress

    buf = io.StringIO()
    monkeypatch.setattr(progress.sys, "stderr", buf)
    bar = progress.Progress(3, "work", True, force=True)
    for _ in range(3):
        bar.update(1)
    text = buf.getvalue()
    assert "3/3" in text and "-0.0s" not in text and "4/3" not in text


def test_the_diagnosis_progress_counts_its_steps(cdsm, monkeypatch):
    from cdsm import progress
    from cdsm.calibration import diagnosis, measurements

    seen = []
    real = progress.Progress

    class Spy(real):
        def __init__(self, total, label, enabled=True, force=False, **kw):
            super().__init__(total, label, False, False, **kw)
            seen.append(self)

    monkeypatch.setattr(diagnosis, "Progress", Spy)
    diagnosis.diagnose(cdsm.Robot.paper(), measurements.packaged("table3"))
    assert seen and all(b.done == b.total for b in seen)


def test_the_terminal_says_the_verdicts_reason_the_next_step_and_the_assumed_noise(cdsm, capsys):
    rc, out, _ = _cli(capsys, ["diagnose", "table3", "--quiet"])
    lines = out.splitlines()
    # the answer first, with its reason; the next measurements; no Markdown marks
    assert lines[0].startswith("Verdict: unexplained — no effect of the library reduces the gap")
    assert any(ln.startswith("Next measurements: Repeat some commands") for ln in lines)
    assert "**" not in out and "`" not in out and "](#" not in out
    # nine rows beyond 5 sigma of a noise nobody measured: the assumption is what fails
    assert "assumed noise" in out and "cannot all be outliers" in out
