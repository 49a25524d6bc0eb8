"""Where outputs go (issue 32, items 1-4 and 10): no output replaces an
input or another output of the same run, no path is empty, a run owns its
output directory while it writes (a second run is refused, the manifest and
the page hold what this run wrote), a directory of someone else's files of
the report's names is refused unless asked, a killed run's ``.part`` files
go with the next run, and a file where the report writes ``figures/`` is an
error before anything is computed. Each test reproduces what the review
found."""

from __future__ import annotations

import base64
import contextlib
import errno
import hashlib
import json
import os
import stat
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

DATA = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "data"


def _cli(capsys, argv):
    from cdsm import cli

    try:
        rc = cli.main([str(a) for a in argv])
    except SystemExit as exc:  # argparse errors exit
        rc = exc.code
    out = capsys.readouterr()
    return rc, out.out, out.err


def _tree(root: Path) -> dict:
    """Every file under ``root``: {relative path: bytes, or the link's target}."""
    out = {}
    for dp, dirs, fs in os.walk(root):
        for f in fs + [d for d in dirs if os.path.islink(os.path.join(dp, d))]:
            p = os.path.join(dp, f)
            rel = os.path.relpath(p, root)
            out[rel] = ("->", os.readlink(p)) if os.path.islink(p) else open(p, "rb").read()
        out.update({os.path.relpath(os.path.join(dp, d), root) + "/": b"" for d in dirs})
    return out


def _nothing_computed(monkeypatch):
    """Every command's computation raises: a check that comes after it fails."""
    from cdsm import study
    from cdsm.accuracy import distributed, tolerance
    from cdsm.calibration import diagnosis, model

    def computed(*a, **k):
        raise AssertionError("the command computed before checking its paths")

    for mod, name in ((study, "run"), (diagnosis, "diagnose"), (tolerance, "allocate"), (distributed, "run"),
                      (model.FittedPlant, "compensate")):
        monkeypatch.setattr(mod, name, computed)


@pytest.fixture
def files(cdsm, tmp_path, monkeypatch):
    """A working directory with the inputs every command reads."""
    robot = cdsm.Robot.paper()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.csv").write_bytes((DATA / "table3.csv").read_bytes())
    (tmp_path / "r.toml").write_text(robot.to_toml())
    (tmp_path / "v.csv").write_bytes((DATA / "table3.csv").read_bytes())
    os.symlink("d.csv", tmp_path / "link.csv")
    os.link(tmp_path / "d.csv", tmp_path / "hard.csv")
    (tmp_path / "sub").mkdir()
    (tmp_path / "rep").mkdir()
    (tmp_path / "rep" / "residuals.csv").write_bytes((DATA / "table3.csv").read_bytes())
    x, y, phi = robot.fk(np.zeros(robot.n))[:3]
    (tmp_path / "t.csv").write_text(f"x,y,phi\n{x!r},{y!r},{phi!r}\n")
    cdsm.FittedPlant.from_effects(robot, {"tip_offset": [1e-3, 0.0]}).save(tmp_path / "m.json")
    (tmp_path / "j.csv").write_text("theta_1,theta_2,theta_3\n0,0,0\n")
    (tmp_path / "r.npz").write_text(robot.to_toml())  # a robot file of any name
    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "scenarios.csv").write_text(robot.to_toml())
    (tmp_path / "p" / "figures").mkdir()
    (tmp_path / "p" / "figures" / "r.toml").write_text(robot.to_toml())
    return tmp_path


# ---------------------------------------------------------------------------
# item 1: an output that names an input, or another output
# ---------------------------------------------------------------------------
FAST = ["--effects", "tip_offset", "--folds", "3", "--quiet"]
COLLISIONS = [
    (["diagnose", "d.csv", "--json", "d.csv"], ["--json", "DATA.csv"]),
    (["diagnose", "d.csv", "--save-model", "./d.csv"], ["--save-model", "DATA.csv"]),
    (["diagnose", "d.csv", "--robot", "r.toml", "--json", "r.toml"], ["--json", "--robot"]),
    (["diagnose", "d.csv", "--json", "x.json", "--save-model", "sub/../x.json"], ["--json", "--save-model"]),
    (["diagnose", "d.csv", "--json", "link.csv"], ["--json", "DATA.csv"]),  # a symbolic link to the input
    (["diagnose", "d.csv", "--validate", "v.csv", "--save-model", "v.csv"], ["--save-model", "--validate"]),
    (["diagnose", "d.csv", "--save-model", "hard.csv"], ["--save-model", "DATA.csv"]),  # a hard link
    (["diagnose", "rep/residuals.csv", "--report", "rep"], ["--report", "DATA.csv", "residuals.csv"]),
    (["diagnose", "d.csv", "--report", "out", "--json", "out/diagnosis.json"], ["--json", "--report"]),
    (["diagnose", "d.csv", "--report", "out", "--save-model", "out"], ["--save-model", "--report"]),
    (["export", "--robot", "r.toml", "--mjcf", "r.toml"], ["--mjcf", "--robot"]),
    (["export", "--robot", "./r.toml", "--urdf", "sub/../r.toml"], ["--urdf", "--robot"]),
    (["compensate", "t.csv", "--model", "m.json", "--out", "t.csv"], ["--out", "TARGETS.csv"]),
    (["compensate", "t.csv", "--model", "m.json", "--out", "m.json"], ["--out", "--model"]),
    (["tolerance", "--target-mm", "1", "--region", "joints:j.csv", "--json", "j.csv"], ["--json", "--region"]),
    (["tolerance", "--target-mm", "1", "--robot", "r.toml", "--json", "./r.toml"], ["--json", "--robot"]),
    (["montecarlo", "--robot", "r.npz", "--out", "r", "--samples", "2"], ["--out", "--robot"]),  # r -> r.npz
    (["paper", "--robot", "p/scenarios.csv", "--out-dir", "p"], ["--out-dir", "--robot", "scenarios.csv"]),
    (["paper", "--robot", "p/figures/r.toml", "--out-dir", "p"], ["--out-dir", "--robot", "figures/r.toml"]),
]


@pytest.mark.parametrize("argv,named", COLLISIONS, ids=[" ".join(a) for a, _ in COLLISIONS])
def test_an_output_that_names_an_input_or_another_output_is_refused_first(cdsm, files, capsys, monkeypatch,
                                                                          argv, named):
    """The review's `cdsm diagnose d.csv --json d.csv` replaced the
    measurements, exit 0; likewise --save-model, --json over --robot, export
    over its robot and two outputs of one name. Every command now refuses
    before computing or writing anything, naming both options."""
    _nothing_computed(monkeypatch)
    before = _tree(files)
    rc, out, err = _cli(capsys, argv + (FAST if argv[0] == "diagnose" else []))
    assert rc == 2, (out, err)
    for word in named:
        assert word in err, err
    assert "Traceback" not in err and _tree(files) == before


def test_outputs_of_other_names_beside_the_inputs_are_fine(cdsm, files, capsys):
    rc, out, err = _cli(capsys, ["diagnose", "d.csv", "--json", "x.json", "--save-model", "m2.json",
                                 "--report", "."] + FAST)
    assert rc == 0, err
    assert (files / "d.csv").read_bytes() == (DATA / "table3.csv").read_bytes()
    assert {"x.json", "m2.json", "report.html", "residuals.csv"} <= set(os.listdir(files))


# ---------------------------------------------------------------------------
# item 2: empty paths
# ---------------------------------------------------------------------------
#: the path options of every command (a new one must be declared: cdsm.cli.paths.add_path)
PATH_OPTIONS = {"paper": {"robot", "out_dir"},
                "diagnose": {"data", "robot", "json", "report", "save_model", "validate"},
                "compensate": {"targets", "model", "out"}, "tolerance": {"robot", "region", "json"},
                "montecarlo": {"robot", "out", "tolerances"}, "export": {"robot", "mjcf", "urdf"}, "list": set()}
BASE = {"paper": ["paper"], "diagnose": ["diagnose", "d.csv"], "export": ["export", "--mjcf", "o.xml"],
        "compensate": ["compensate", "t.csv", "--model", "m.json", "--out", "o.csv"],
        "tolerance": ["tolerance", "--target-mm", "1"], "montecarlo": ["montecarlo", "--out", "o.npz"]}


def _path_options():
    import argparse

    from cdsm.cli import COMMANDS, build_parser

    build_parser()  # registers the commands
    out = {}
    for name, cmd in COMMANDS.items():
        p = argparse.ArgumentParser()
        cmd.add_args(p)
        out[name] = p.get_default("_paths") or []
    return out


def test_every_path_option_is_declared(cdsm):
    assert {k: {s.dest for s in v} for k, v in _path_options().items()} == PATH_OPTIONS


def test_an_empty_path_is_refused_in_every_option_of_every_command(cdsm, files, capsys, monkeypatch):
    """`--out-dir ''` (an unset shell variable) wrote the whole report into
    the current directory, replacing a report.md there."""
    _nothing_computed(monkeypatch)
    (files / "report.md").write_text("my own report\n")
    before = _tree(files)
    tried = 0
    for name, specs in _path_options().items():
        for spec in specs:
            argv = list(BASE[name])
            if not spec.label.startswith("-"):
                argv[argv.index(next(a for a in argv[1:] if not a.startswith("-")))] = ""
            elif spec.label in argv:
                argv[argv.index(spec.label) + 1] = ""
            else:
                argv += [spec.label, ""]
            rc, out, err = _cli(capsys, argv)
            assert rc == 2 and f"{spec.label}: empty path" in err, (argv, out, err)
            assert _tree(files) == before, argv
            tried += 1
    assert tried == sum(map(len, PATH_OPTIONS.values()))
    rc, _, err = _cli(capsys, ["tolerance", "--target-mm", "1", "--region", "joints:"])
    assert rc == 2 and "--region 'joints:': empty path" in err


def _small_diagnosis(cdsm):
    from cdsm.calibration import diagnosis, plant

    robot = cdsm.Robot.paper()
    vp = plant.VirtualPrototype(robot, {"tip_offset": [1e-3, -1e-3]}, noise=1e-5, seed=3)
    th, dl = vp.random_commands(12)
    return diagnosis.diagnose(robot, vp.measure(th, dl), effects=["tip_offset"], folds=3, noise=1e-5, frame="base")


def test_an_empty_path_is_refused_by_the_python_functions_that_write(cdsm, tmp_path, monkeypatch):
    from cdsm.accuracy import montecarlo
    from cdsm.files import run_directory, write_npz, write_text
    from cdsm.report import diagnosis as report
    from cdsm.report.figures import new_figure, render_jobs, save

    monkeypatch.chdir(tmp_path)
    (tmp_path / "report.md").write_text("my own report\n")
    d = _small_diagnosis(cdsm)
    calls = [lambda: write_text("", "x", "report"), lambda: write_npz("", {"x": np.zeros(2)}, "Monte-Carlo"),
             lambda: cdsm.FittedPlant.from_diagnosis(d).save(""), lambda: report.write(d, ""),
             lambda: save(new_figure(2, 2), ""), lambda: render_jobs(lambda _: [], None, ""),
             lambda: montecarlo.save_npz("", None)]
    for call in calls:
        with pytest.raises(cdsm.CdsmInputError, match="empty path"):
            call()
    with pytest.raises(cdsm.CdsmInputError, match="empty path"):
        with run_directory("", "test", ["a.txt"]):
            pass
    assert os.listdir(tmp_path) == ["report.md"] and (tmp_path / "report.md").read_text() == "my own report\n"


# ---------------------------------------------------------------------------
# item 3: one run owns its directory while it writes
# ---------------------------------------------------------------------------
# cdsm's command line with every write of a file whose path matches the
# regular expression argv[2] slowed down by argv[1] seconds; with a directory
# argv[3] (not ""), the first write waits there for a file "go" after making
# "ready.<pid>". The review's race, two runs writing into one directory,
# made certain; a run caught part-way through a file.
_SLOW_CLI = textwrap.dedent("""
    import contextlib, os, re, sys, time
    import cdsm.files as files

    original = files.atomic_file
    delay, where, barrier = float(sys.argv[1]), re.compile(sys.argv[2]), sys.argv[3]

    @contextlib.contextmanager
    def slow(path, what):
        global barrier
        if barrier:
            open(os.path.join(barrier, f"ready.{os.getpid()}"), "w").close()
            deadline = time.time() + 300
            while not os.path.exists(os.path.join(barrier, "go")) and time.time() < deadline:
                time.sleep(0.02)
            barrier = ""
        with original(path, what) as fh:
            if where.search(str(path)):
                time.sleep(delay)
            yield fh

    files.atomic_file = slow
    import cdsm.report.figures as figures
    if hasattr(figures, "atomic_file"):
        figures.atomic_file = slow
    from cdsm.cli import main
    sys.exit(main(sys.argv[4:]))
""")


def _slow_cli(delay: float, argv, where: str = "", barrier="") -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-c", _SLOW_CLI, str(delay), where, str(barrier), *map(str, argv)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _listed(out: Path) -> dict:
    from cdsm.files import RUN_MANIFEST

    return json.loads((out / RUN_MANIFEST).read_text())["files"]


def test_two_runs_started_together_into_one_directory_never_leave_a_certified_mix(cdsm, tmp_path):
    """Two `cdsm paper` runs into one directory left one run's report.md and
    the other's figures, certified complete. Two runs (of different data)
    started together: one is refused while the other writes; the directory
    is then exactly one run's files, byte for byte."""
    from cdsm.files import run_complete

    runs = [["diagnose", "table3"] + FAST, ["diagnose", "table3_theory"] + FAST]
    ref = []
    alone = [_slow_cli(0, argv + ["--report", tmp_path / f"ref{k}"]) for k, argv in enumerate(runs)]  # own dirs
    for k, p in enumerate(alone):
        assert p.wait(300) == 0, p.stderr.read()
        ref.append({f: (tmp_path / f"ref{k}" / f).read_bytes() for f in _listed(tmp_path / f"ref{k}")})
    assert ref[0]["report.html"] != ref[1]["report.html"]
    shared, barrier = tmp_path / "shared", tmp_path / "barrier"
    barrier.mkdir()
    # both runs write at once, one slow on its figures, the other on the rest
    procs = [_slow_cli(0.4, argv + ["--report", shared], where, barrier)
             for argv, where in zip(runs, ["figures", r"\.(md|html|json|csv)$"])]
    deadline = time.time() + 300
    while len(os.listdir(barrier)) < 2 and all(p.poll() is None for p in procs):  # until both write, or one ended
        assert time.time() < deadline
        time.sleep(0.02)
    (barrier / "go").touch()
    results = [(p.wait(300), p.stderr.read()) for p in procs]
    assert any(rc == 0 for rc, _ in results), results
    for rc, err in results:
        assert rc == 0 or (rc == 2 and "another cdsm run is writing into this directory" in err), (rc, err)
    assert run_complete(shared)
    listed = _listed(shared)
    assert any(set(listed) == set(r) and all((shared / f).read_bytes() == r[f] for f in listed) for r in ref), \
        "the directory is certified complete but is not one run's output"


def test_a_runs_manifest_and_page_hold_what_it_wrote_not_what_lands_later(cdsm, tmp_path, monkeypatch):
    """finish_run hashed what was on disk and the page embedded the PNGs
    read back from the shared figures/: another run's files, certified.
    Here a figure is replaced right after this run wrote it."""
    import cdsm.files as files_module
    import cdsm.report.figures as figures_module
    from cdsm.files import run_complete
    from cdsm.report import diagnosis as report

    d = _small_diagnosis(cdsm)
    original, ours = files_module.atomic_file, {}

    @contextlib.contextmanager
    def then_replaced(path, what):
        with original(path, what) as fh:
            yield fh
        if str(path).endswith("residual_map.png"):
            ours["png"] = Path(path).read_bytes()
            Path(path).write_bytes(b"another run's figure")

    monkeypatch.setattr(files_module, "atomic_file", then_replaced)
    monkeypatch.setattr(figures_module, "atomic_file", then_replaced, raising=False)
    out = tmp_path / "rep"
    report.write(d, out)
    assert _listed(out)["figures/residual_map.png"] == hashlib.sha256(ours["png"]).hexdigest()
    page = (out / "report.html").read_text()
    assert base64.b64encode(ours["png"]).decode() in page
    assert base64.b64encode(b"another run's figure").decode() not in page
    assert not run_complete(out)  # the directory no longer holds what the run wrote


def test_a_directory_is_owned_by_one_thread_and_shared_by_its_nested_runs(cdsm, tmp_path):
    from cdsm.files import run_directory

    out = tmp_path / "o"
    held, release, seen = threading.Event(), threading.Event(), []

    def owner():
        with run_directory(out, "test", ["a.txt"]):
            held.set()
            release.wait(30)

    t = threading.Thread(target=owner)
    t.start()
    try:
        assert held.wait(30)
        with pytest.raises(cdsm.CdsmInputError, match="another cdsm run is writing"):
            with run_directory(out, "test", ["a.txt"]):
                seen.append("entered")
    finally:
        release.set()
        t.join(30)
    assert not seen
    with run_directory(out, "test", ["a.txt"]) as outer:  # the owner's report: nested, shares the lock
        with run_directory(out, "test", ["a.txt"]) as inner:
            inner.write_text("a.txt", "x\n", "test")
            inner.finish()
        assert outer.out == inner.out
    with pytest.raises(ValueError, match="not a file of this run"):
        with run_directory(out, "test", ["a.txt"]) as run:
            run.write_text("b.txt", "x\n", "test")


def test_where_a_directory_cannot_be_locked_a_lock_file_in_it_is(cdsm, tmp_path, monkeypatch):
    """Network file systems lock files opened for writing, not directories."""
    import fcntl

    from cdsm.files import run_directory

    real = fcntl.flock

    def files_only(fd, op):
        if stat.S_ISDIR(os.fstat(fd).st_mode):
            raise OSError(errno.EBADF, "Bad file descriptor")
        return real(fd, op)

    monkeypatch.setattr(fcntl, "flock", files_only)
    with run_directory(tmp_path / "o", "test", ["a.txt"]):
        fd = os.open(tmp_path / "o" / ".cdsm-run.lock", os.O_RDWR)
        try:
            with pytest.raises(BlockingIOError):
                real(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(fd)


# ---------------------------------------------------------------------------
# item 4: someone else's files; a killed run's .part files
# ---------------------------------------------------------------------------
def test_a_directory_of_someone_elses_files_of_the_reports_names_is_refused_unless_asked(cdsm, tmp_path, capsys,
                                                                                        monkeypatch):
    """A directory holding a user's report.md and residuals.csv was written
    over without a word."""
    from cdsm.files import run_complete
    from cdsm.report import diagnosis as report

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "report.md").write_text("my notes\n")
    (mine / "residuals.csv").write_text("a,b\n1,2\n")
    (mine / "data.csv").write_bytes((DATA / "table3.csv").read_bytes())
    before = _tree(mine)
    with monkeypatch.context() as m:
        _nothing_computed(m)
        rc, _, err = _cli(capsys, ["diagnose", "table3", "--report", mine] + FAST)
        assert rc == 2 and "report.md" in err and "residuals.csv" in err and "--overwrite" in err, err
        assert _tree(mine) == before
    with pytest.raises(cdsm.CdsmInputError, match="report.md, residuals.csv.*overwrite=True"):
        report.write(_small_diagnosis(cdsm), mine)
    assert _tree(mine) == before
    rc, _, err = _cli(capsys, ["diagnose", mine / "data.csv", "--report", mine, "--overwrite"] + FAST)
    assert rc == 0, err
    assert run_complete(mine) and (mine / "data.csv").read_bytes() == before["data.csv"]
    # a previous cdsm run is written over without asking
    rc, _, err = _cli(capsys, ["diagnose", "table3", "--report", mine] + FAST)
    assert rc == 0 and run_complete(mine), err
    # and a directory of other files is fine
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine\n")
    assert _cli(capsys, ["diagnose", "table3", "--report", other] + FAST)[0] == 0
    assert (other / "notes.txt").read_text() == "mine\n" and run_complete(other)


def test_a_killed_runs_part_files_go_with_the_next_run_and_only_they(cdsm, tmp_path, capsys):
    """After a killed run its .part files stayed behind, even after a
    successful re-run."""
    from cdsm.files import run_complete

    out = tmp_path / "rep"

    def writing_a_figure() -> bool:
        return (out / "figures").is_dir() and any(f.endswith(".part") for f in os.listdir(out / "figures"))

    proc = _slow_cli(120, ["diagnose", "table3", "--report", out] + FAST, where="figures")  # killed there
    try:
        deadline = time.time() + 300
        while not writing_a_figure():
            assert time.time() < deadline and proc.poll() is None, proc.stderr.read() if proc.poll() else ""
            time.sleep(0.05)
    finally:
        proc.kill()
        proc.wait(30)
    killed = [os.path.join(dp, f) for dp, _, fs in os.walk(out) for f in fs if f.endswith(".part")]
    assert killed
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    try:
        writing = out / f".report.md.{live.pid}.abcdefgh.part"  # a writer that still runs
        writing.write_text("being written")
        not_ours = out / f".notes.txt.{proc.pid}.abcdefgh.part"  # not a name this run writes
        not_ours.write_text("someone's")
        rc, _, err = _cli(capsys, ["diagnose", "table3", "--report", out] + FAST)
        assert rc == 0 and run_complete(out), err
        left = sorted(os.path.join(dp, f) for dp, _, fs in os.walk(out) for f in fs if f.endswith(".part"))
        assert left == sorted([str(writing), str(not_ours)])
    finally:
        live.kill()
        live.wait(30)


def test_a_killed_writes_part_file_goes_with_the_next_write_of_that_file(cdsm, tmp_path):
    """A killed `--save-model m.json` (any single output) left its .part."""
    ended = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                               text=True, check=True).stdout)
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
    try:
        parts = {k: f".{name}.{pid}.abcdefgh.part" for k, name, pid in
                 (("killed", "m.json", ended), ("writing", "m.json", live.pid), ("other", "n.json", ended))}
        for f in parts.values():
            (tmp_path / f).write_text("half")
        cdsm.FittedPlant.from_effects(cdsm.Robot.paper(), {"tip_offset": [1e-3, 0.0]}).save(tmp_path / "m.json")
        assert sorted(f for f in os.listdir(tmp_path) if f.endswith(".part")) == sorted(
            [parts["writing"], parts["other"]])
    finally:
        live.kill()
        live.wait(30)


# ---------------------------------------------------------------------------
# item 10: a file where the report writes figures/
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("argv", [["paper", "--out-dir"], ["diagnose", "table3", "--report"]])
def test_a_file_where_the_report_writes_a_directory_is_an_error_before_the_computation(cdsm, tmp_path, capsys,
                                                                                      monkeypatch, argv):
    """`DIR/figures` a regular file gave a raw FileExistsError traceback
    after the computation."""
    _nothing_computed(monkeypatch)
    out = tmp_path / "out"
    out.mkdir()
    (out / "figures").write_text("not a directory\n")
    rc, _, err = _cli(capsys, argv + [out])
    assert rc == 2 and "'figures' in it is a file" in err and "Traceback" not in err, err
    (out / "figures").unlink()
    (out / "report.md").mkdir()
    rc, _, err = _cli(capsys, argv + [out])
    assert rc == 2 and "'report.md' in it is a directory" in err, err
