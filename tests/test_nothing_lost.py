"""Nothing lost: names survive every round trip, forked workers end with
their parent, and files are written whole or not at all (issue 21, items
1-3). Each test reproduces what a reliability review found broken."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

#: Names a user may give an arm: outside the Basic Multilingual Plane (the
#: review's failure: surrogate escapes the TOML reader refuses), quotes,
#: backslashes, control characters, DEL, other scripts, combining marks.
NAMES = ["arm \U0001F4AA", "\U0001D4D0rm \U00020000", 'say "hi"', "back\\slash \\u0041", "tab\there\nline",
         "bell\x07 del\x7f nul\x00", "κλειδί 鍵 مفتاح", "e\u0301\u200d", "", " ", "'single' ''' \"\"\""]


def _named(cdsm, name: str):
    """The paper robot renamed ``name`` (every character written as a TOML
    ``\\U`` escape, so the file is valid whatever the name)."""
    text = cdsm.Robot.paper().to_toml()
    first = text.splitlines()[1]
    assert first.startswith("name = ")
    quoted = '"' + "".join(f"\\U{ord(ch):08X}" for ch in name) + '"'
    return cdsm.Robot.from_toml_str(text.replace(first, f"name = {quoted}", 1))


@pytest.mark.parametrize("name", NAMES)
def test_any_unicode_name_round_trips(cdsm, name):
    r = _named(cdsm, name)
    assert r.name == name
    back = cdsm.Robot.from_toml_str(r.to_toml())
    assert back.name == name and back.to_toml() == r.to_toml()


def test_a_saved_model_of_a_non_bmp_robot_loads_back(cdsm, tmp_path):
    """The review's case: diagnose --save-model succeeded, compensate could
    not load the model."""
    from cdsm.accuracy.distributed import robot_from_spec, robot_spec

    r = _named(cdsm, "arm \U0001F4AA")
    m = cdsm.Model.from_effects(r, {"actuation_scale": [0.01]})
    m.save(tmp_path / "m.json")
    back = cdsm.Model.load(tmp_path / "m.json")
    assert back.robot.name == r.name and np.array_equal(back.p, m.p)
    assert robot_from_spec(robot_spec(r)).name == r.name  # what a Dask worker receives


# ---------------------------------------------------------------------------
# forked figure workers end with their parent
# ---------------------------------------------------------------------------
_ORPHAN_SCRIPT = textwrap.dedent("""
    import os, sys, time
    from cdsm.report.figures import render_jobs

    def jobs(_):
        def slow():
            open(os.path.join(sys.argv[1], f"worker-{os.getpid()}"), "w").close()
            time.sleep(60)
            return []
        return [(f"job{i}", slow) for i in range(2)]

    render_jobs(jobs, None, sys.argv[1], workers=2)
""")


def _children(pid: int):
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True).stdout
    return [int(p) for p in out.split()]


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="figure workers fork on Linux only")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM])
def test_forked_figure_workers_end_with_their_parent(tmp_path, sig):
    parent = subprocess.Popen([sys.executable, "-c", _ORPHAN_SCRIPT, str(tmp_path)])
    try:
        deadline = time.time() + 60
        while len([f for f in os.listdir(tmp_path) if f.startswith("worker-")]) < 2:
            assert time.time() < deadline and parent.poll() is None, "the workers never started"
            time.sleep(0.05)
        workers = [int(f.split("-")[1]) for f in os.listdir(tmp_path) if f.startswith("worker-")]
        assert all(_alive(w) for w in workers)
        parent.send_signal(sig)
        parent.wait(10)
        deadline = time.time() + 10
        while any(_alive(w) for w in workers) and time.time() < deadline:
            time.sleep(0.05)
        assert not any(_alive(w) for w in workers), "a figure worker outlived its parent"
    finally:
        if parent.poll() is None:
            parent.kill()


# ---------------------------------------------------------------------------
# whole files or none
# ---------------------------------------------------------------------------
_NPZ_SCRIPT = textwrap.dedent("""
    import sys
    import numpy as np
    from cdsm.files import write_npz

    big = np.random.default_rng(0).normal(size=(4_000_000,))   # 32 MB, slow to compress
    while True:
        write_npz(sys.argv[1], {"x": big}, "test")
""")


def test_a_kill_during_an_npz_write_leaves_the_last_whole_file(cdsm, tmp_path):
    """The review killed ``cdsm montecarlo`` during its write and found a
    truncated file at the final path 10 times in 10: now the final path
    holds a whole file or none, and a reader never sees a half."""
    from cdsm.files import read_npz

    target = tmp_path / "mc.npz"
    for attempt in range(4):
        proc = subprocess.Popen([sys.executable, "-c", _NPZ_SCRIPT, str(target)])
        try:
            deadline = time.time() + 60
            # the first write has begun: a file exists in the directory (the target or a temporary)
            while len(os.listdir(tmp_path)) <= (1 if target.exists() else 0):
                assert time.time() < deadline and proc.poll() is None
                time.sleep(0.01)
            time.sleep(0.3 * attempt)  # then part-way through it, or through a later one
            proc.kill()
            proc.wait(10)
        finally:
            if proc.poll() is None:
                proc.kill()
        if target.exists():
            assert read_npz(target, "test")["x"].shape == (4_000_000,)


def test_a_truncated_npz_is_a_clear_error(cdsm, tmp_path):
    from cdsm.files import read_npz, write_npz

    p = write_npz(tmp_path / "a", {"x": np.arange(10_000.0)}, "test")
    assert p.endswith("a.npz")
    data = open(p, "rb").read()
    for cut in (0, 10, len(data) // 2, len(data) - 1):
        open(p, "wb").write(data[:cut])
        with pytest.raises(cdsm.CdsmInputError, match=r"a\.npz.*(truncated|damaged)"):
            read_npz(p, "Monte-Carlo")


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(cdsm, tmp_path):
    from cdsm.files import atomic_file, write_text

    p = tmp_path / "report.md"
    write_text(p, "old\n", "report")
    with pytest.raises(RuntimeError):
        with atomic_file(p, "report") as fh:
            fh.write(b"half of the new")
            raise RuntimeError("killed")
    assert p.read_text() == "old\n" and os.listdir(tmp_path) == ["report.md"]
    with pytest.raises(cdsm.CdsmInputError, match="not valid Unicode"):
        write_text(p, "lone \udc00", "report")
    assert p.read_text() == "old\n" and os.listdir(tmp_path) == ["report.md"]


def test_a_report_directory_is_marked_complete_only_at_its_end(cdsm, tmp_path, monkeypatch):
    """A re-run into a finished directory that dies half-way leaves a
    directory whose manifest says incomplete; a finished run lists every
    file with its hash."""
    from cdsm.calibration import diagnosis, plant
    from cdsm.files import RUN_MANIFEST, run_complete
    from cdsm.report import diagnosis as report

    robot = cdsm.Robot.paper()
    vp = plant.VirtualPrototype(robot, {"tip_offset": [1e-3, -1e-3]}, noise=1e-5, seed=3)
    th, dl = vp.random_commands(12)
    d = diagnosis.diagnose(robot, vp.measure(th, dl), effects=["tip_offset"], folds=3, noise=1e-5, frame="base")
    out = tmp_path / "rep"
    paths = report.write(d, out)
    assert run_complete(out)
    man = json.loads((out / RUN_MANIFEST).read_text())
    listed = set(man["files"])
    assert {"report.md", "report.html", "diagnosis.json", "residuals.csv"} <= listed
    assert {os.path.relpath(p, out) for k, p in paths.items() if k not in ("figures", "manifest")} <= listed
    assert all(os.path.isfile(out / f) for f in listed)
    # a damaged file is seen
    (out / "residuals.csv").write_text("x\n")
    assert run_complete(out, verify=False) and not run_complete(out)

    def dies(*args, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "write_json", dies)
    with pytest.raises(KeyboardInterrupt):
        report.write(d, out)
    assert not run_complete(out, verify=False)
    assert json.loads((out / RUN_MANIFEST).read_text())["complete"] is False
    assert not [f for f in os.listdir(out) if f.endswith(".part")]
