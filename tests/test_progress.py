"""Progress a user can see (issue 32, item 11): on a terminal a line redrawn
in place, at most ten times a second; off a terminal (a log, CI, a pipe)
plain lines, no carriage return, a few of them — one per half minute of
work and one when a stage is done — where it used to print nothing at
all. Clock-driven checks use a fake clock; the command's own stderr is
checked through a pipe."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
import types
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "data"


class _Clock:
    def __init__(self):
        self.t = 1000.0

    def perf_counter(self) -> float:
        return self.t


@pytest.fixture
def fake(cdsm, monkeypatch):
    """(progress module, clock, stderr buffer): stderr a StringIO (not a terminal)."""
    from cdsm import progress

    clock, buf = _Clock(), io.StringIO()
    monkeypatch.setattr(progress, "time", clock)
    monkeypatch.setattr(progress, "sys", types.SimpleNamespace(stderr=buf))
    return progress, clock, buf


def test_off_a_terminal_a_long_stage_logs_a_line_per_half_minute_and_one_when_done(fake):
    progress, clock, buf = fake
    bar = progress.Progress(9600, "work", True)
    for _ in range(9600):   # ten minutes of work in 9600 steps
        clock.t += 0.0625
        bar.update(1)
    text = buf.getvalue()
    lines = text.splitlines()
    assert "\r" not in text and "\033" not in text and text.endswith("\n")
    # one line per 30 s of work (19 while running) and the done line: not 9600
    assert len(lines) == 20, lines
    assert lines[0] == "work: 5 %, 480/9600, 30.0 s elapsed, about 9 min 30 s left"
    assert lines[9] == "work: 50 %, 4800/9600, 5 min 00 s elapsed, about 5 min 00 s left"
    assert all(re.match(r"work: \d+ %, \d+/9600, ", ln) for ln in lines[:-1])
    assert lines[-1] == "work: done, 9600/9600 in 10 min 00 s"


def test_off_a_terminal_a_short_stage_leaves_one_line(fake):
    progress, clock, buf = fake
    bar = progress.Progress(31, "figures", True)
    for _ in range(31):
        clock.t += 0.1
        bar.update(1)
    assert buf.getvalue() == "figures: done, 31/31 in 3.1 s\n"


def test_a_stage_of_unknown_length_counts_and_ends_with_finish(fake):
    progress, clock, buf = fake
    bar = progress.Progress(None, "search", True, unit="fold fits")
    for _ in range(40):
        clock.t += 2.0
        bar.update(6)
    bar.finish()
    lines = buf.getvalue().splitlines()
    assert lines[0] == "search: 90 fold fits, 30.0 s elapsed"
    assert lines[-1] == "search: done, 240 fold fits in 1 min 20 s" and len(lines) == 3
    assert bar.done == bar.total == 240


def test_on_a_terminal_the_line_is_redrawn_at_most_ten_times_a_second(fake):
    progress, clock, buf = fake
    bar = progress.Progress(100_000, "monte carlo", True, force=True)
    for _ in range(100_000):   # one second of tiny steps
        clock.t += 1e-5
        bar.update(1)
    text = buf.getvalue()
    assert 5 <= text.count("\r") <= 12 and text.endswith("\n") and text.count("\n") == 1
    assert "100000/100000" in text.rsplit("\r", 1)[1]


def test_nothing_when_not_enabled(fake):
    progress, clock, buf = fake
    bar = progress.Progress(10, "quiet", False, force=True)
    for _ in range(10):
        clock.t += 100.0
        bar.update(1)
    bar.finish()
    assert buf.getvalue() == ""


def test_the_diagnose_command_logs_its_stages_when_stderr_is_not_a_terminal(cdsm, tmp_path):
    """``cdsm diagnose FILE`` with stderr redirected: a line per stage
    (reading the file, the single effects, the selection), no carriage
    return (the old progress line drew only on terminals: stderr held the
    final ``done in`` line alone)."""
    f = tmp_path / "measured.csv"
    f.write_text((DATA / "table3.csv").read_text(encoding="utf-8"), encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(cdsm.__file__).parents[1]),
                                                         os.environ.get("PYTHONPATH", "")]))
    run = subprocess.run([sys.executable, "-m", "cdsm", "diagnose", str(f)], capture_output=True, text=True,
                         env=env, timeout=600)
    assert run.returncode == 0, run.stderr
    err = run.stderr
    assert "\r" not in err and "\033" not in err
    lines = err.splitlines()
    assert re.fullmatch(r"reading measured\.csv: done, 0\.7 kB of 0\.7 kB in \d+\.\d s", lines[0]), lines
    assert re.fullmatch(r"diagnose: the nominal model and each effect: done, 110/110 fold fits in .*", lines[1])
    assert re.fullmatch(r"diagnose: selection, search and checks: done, \d+ fold fits in .*", lines[2])
    assert lines[-1].startswith("done in") and len(lines) <= 8
