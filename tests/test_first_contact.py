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


def _long_options(parser):
    return [o for a in parser._actions for o in a.option_strings if o.startswith("--")]


def test_no_command_takes_an_abbreviated_option(cdsm):
    """argparse's prefix matching is off on every parser (issue 32, item 13):
    a shortened option is an unknown option, not another one."""
    from cdsm import cli

    parser = cli.build_parser()
    commands = parser._subparsers._group_actions[0].choices
    # the positionals and required options, so that only the abbreviation can fail
    fillers = {"diagnose": ["d.csv"], "compensate": ["t.csv", "--model", "m.json", "--out", "c.csv"],
               "tolerance": ["--target-mm", "1"], "montecarlo": ["--out", "mc.npz"]}
    checked = 0
    for name, sub in commands.items():
        options = _long_options(sub)
        for opt in options:
            abbr = opt[:-1]
            if len(abbr) < 4 or abbr in options:
                continue
            argv = [name, *fillers.get(name, []), abbr]
            try:
                _, extra = parser.parse_known_args(argv)
            except SystemExit:  # an abbreviation that argparse took, then found incomplete or ambiguous
                extra = None
            assert extra == [abbr], (argv, extra)
            checked += 1
    assert checked > 40


def test_a_shortened_option_is_refused_with_the_commands_usage(cdsm, capsys):
    rc, _, err = _cli(capsys, ["paper", "--sample", "5", "--robot", "no_such_robot"])
    assert rc == 2 and "usage: cdsm paper" in err and "unrecognized arguments: --sample 5" in err
    rc, out, err = _cli(capsys, ["--vers"])
    assert rc == 2 and "unrecognized arguments: --vers" in err and out == ""


@pytest.mark.parametrize("script", sorted(p.name for p in EXAMPLES.glob("*.py")))
def test_the_examples_take_no_abbreviated_option(script, capsys, monkeypatch):
    import re
    import runpy

    path = EXAMPLES / script
    option = re.search(r'add_argument\("(--[a-z-]+)"', path.read_text()).group(1)
    # a value no option takes: an abbreviation taken as the option fails at once too
    monkeypatch.setattr("sys.argv", [script, option[:-1], "x"])
    with pytest.raises(SystemExit) as exc:
        runpy.run_path(str(path), run_name="__main__")
    assert exc.value.code == 2 and f"unrecognized arguments: {option[:-1]}" in capsys.readouterr().err


@pytest.mark.parametrize("name, suggestion", [("two_univresal", "two_universal"), ("serpentine", "serpentine8"),
                                              ("two_universal.toml", "two_universal")])
def test_a_misspelt_packaged_robot_gets_a_suggestion(cdsm, capsys, name, suggestion):
    with pytest.raises(cdsm.CdsmInputError, match=f"did you mean '{suggestion}'"):
        cdsm.Robot.from_toml(name)
    with pytest.raises(cdsm.CdsmInputError, match=f"did you mean '{suggestion}'"):
        cdsm.Robot.packaged(name)
    rc, _, err = _cli(capsys, ["export", "--robot", name, "--urdf", "never.urdf"])
    assert rc == 2 and f"did you mean '{suggestion}'?" in err
    # nothing close: no guess, the list of names as before
    with pytest.raises(cdsm.CdsmInputError, match="packaged: ") as exc:
        cdsm.Robot.from_toml("qqqq")
    assert "did you mean" not in str(exc.value)


def test_a_misspelt_packaged_table_gets_a_suggestion(cdsm, capsys):
    from cdsm.calibration import measurements

    rc, _, err = _cli(capsys, ["diagnose", "tabel3", "--quiet"])
    assert rc == 2 and "did you mean 'table3'" in err
    with pytest.raises(cdsm.CdsmInputError, match="did you mean 'table3'"):
        measurements.packaged("table_3")


BENCHES = EXAMPLES.parent / "benches"


def _fresh_clone_benches(tmp_path):
    """benches/ of a fresh clone: nothing beside the repository."""
    import shutil

    repo = tmp_path / "clone"
    (repo / "benches").mkdir(parents=True)
    shutil.copy(BENCHES / "bench_speed.py", repo / "benches")
    if (BENCHES / "yardsticks").is_dir():
        shutil.copytree(BENCHES / "yardsticks", repo / "benches" / "yardsticks")
    return repo


def test_bench_speed_runs_its_own_c_yardsticks_from_a_fresh_clone(tmp_path):
    """issue 32, item 14: from a fresh clone every ratio was nan (the C
    yardsticks were looked for outside the repository)."""
    import subprocess
    import sys

    repo = _fresh_clone_benches(tmp_path)
    done = subprocess.run([sys.executable, str(repo / "benches" / "bench_speed.py"), "--groups", "1", "--repeat", "1"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "nan" not in done.stdout
    ratios = [ln for ln in done.stdout.splitlines() if ln.rstrip().endswith(("C Newton", "C closed form"))]
    assert len(ratios) == 4 and all("x C " in ln for ln in ratios), done.stdout


def test_bench_speed_fails_loudly_when_a_yardstick_cannot_be_built(tmp_path):
    import subprocess
    import sys

    repo = _fresh_clone_benches(tmp_path)
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "c_newton.c").write_text("int main(void) { return undeclared; }\n")
    for args in (["--yardsticks", str(broken)], ["--yardsticks", str(tmp_path / "nowhere")]):
        done = subprocess.run([sys.executable, str(repo / "benches" / "bench_speed.py"), "--groups", "1",
                               "--repeat", "1", *args], capture_output=True, text=True, timeout=300)
        assert done.returncode != 0 and "nan" not in done.stdout
        assert "c_newton.c" in done.stderr and "Traceback" not in done.stderr, done.stderr


ROOT = EXAMPLES.parent


def _readme_block_after(heading_words: str) -> str:
    """The first code block after the README paragraph that starts with
    ``heading_words``: one shell command (its lines joined)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    rest = text[text.index(heading_words):]
    block = rest.split("```", 2)[1]
    return " ".join(block.split())


def _shell_words(text: str) -> str:
    """A shell script's commands, comments dropped, whitespace normalised."""
    lines = [ln for ln in text.splitlines() if not ln.lstrip().startswith("#")]
    return " ".join(" ".join(lines).split())


def test_the_readme_commands_start_in_a_virtual_environment_git_ignores():
    """issue 32, item 13: the venv step was prose only, `.venv/` not ignored."""
    venv = "python3 -m venv .venv && . .venv/bin/activate && pip install"
    main = _readme_block_after("Run the main job")
    tests = _readme_block_after("Run all tests")
    assert main.startswith(venv) and "cdsm paper" in main
    assert tests.startswith(venv)
    assert ".venv/" in (ROOT / ".gitignore").read_text().split()
    assert "`cdsm list`" in (ROOT / "README.md").read_text(encoding="utf-8").split("## What the paper study finds")[0]


def test_ci_runs_the_readmes_test_command_and_it_builds_as_ci_does():
    """`.ci/run` runs the README's test command as written, so the two cannot
    drift; the command's cargo test builds without debug info."""
    tests = _readme_block_after("Run all tests")
    assert tests in _shell_words((ROOT / ".ci" / "run").read_text())
    cargo = tests[tests.rindex("&&"):]
    assert "CARGO_PROFILE_DEV_DEBUG=0" in cargo and "CARGO_PROFILE_TEST_DEBUG=0" in cargo and "cargo test" in cargo
