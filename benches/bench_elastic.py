"""Per-core speed of the elastic forward statics (``Robot.equilibrium``) on OpenCR's
FTDCR v4 (60 joints, 9 tendons), beside the NumPy reference in the same run.

    python benches/bench_elastic.py [--csv TRAIN.csv] [--rows 1620] [--reference-rows 20]
                                    [--repeat 3]

Workload: the recorded servo displacements of the FTDCR v4 train file
(``../shared/opencr/ftdcr_v4/tdcr_sysid_*_train.csv``, the columns ``servo_*_mm`` in
file order = tendons k0..k8, mm -> m), the first ``--rows`` rows, through the public API
with one worker thread (``robot.threads = 1``):

* warm: ``sequence=True``, each row from the previous row's answer (the recording's
  order);
* cold: every row from the rest angles (the straight arm).

The reference (``cdsm.reference.elastic.equilibrium_sequence`` and ``equilibrium``) runs
on the first ``--reference-rows`` rows of the same workload. Every figure is the best of
``--repeat`` rounds, in equilibria per second of the process's CPU time (one thread: per
core; the wall-clock rate beside it); the converged rows are counted,
and the largest difference between the core's and the reference's angles on the rows
both solved is printed (rad). Targets (issue 35): >= 50 k/s warm, >= 5 k/s cold.

Measured (2026-11-27, the shared 2-core machine under load ~12, ``taskset -c 0``, 1620
rows, best of 5 per round, five rounds alternating with the build before, both in the
same session): warm 43.4-44.0 k/s/core (before 40.1-41.1 k), cold 32.7-34.7 k/s/core
(before 31.8-32.7 k); 4.27 and 4.88 iterations per row, the answers bit for bit those
before (a cable's row of ``G`` made where it pulls, its length only where a bound of
its moment arms cannot tell it slack). Against the NumPy reference ~1200x warm, ~135x
cold.
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

import cdsm
from cdsm.reference import elastic, load_robot

ROOT = Path(__file__).resolve().parents[1]
FTDCR = ROOT / "tests" / "data" / "opencr" / "ftdcr_v4.toml"
TRAIN = "opencr/ftdcr_v4/tdcr_sysid_20260511-183002_train.csv"


def default_csv() -> Path | None:
    """The train file in a ``shared`` folder beside the checkout (or beside its parent:
    a worktree)."""
    for base in (ROOT.parent, ROOT.parent.parent):
        p = base / "shared" / TRAIN
        if p.exists():
            return p
    return None


def read_servos(path: Path) -> np.ndarray:
    """The ``servo_*_mm`` columns of a sysid CSV in file order (k0..k8), m."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    head = rows[0]
    cols = [i for i, h in enumerate(head) if h.startswith("servo_") and h.endswith("_mm")]
    if len(cols) != 9:
        raise SystemExit(f"{path}: expected 9 servo_*_mm columns, found {len(cols)}")
    return np.array([[float(r[i]) for i in cols] for r in rows[1:]]) / 1000.0


def best(fn, repeat: int):
    """The least CPU time (s) of ``repeat`` calls of ``fn`` (one thread: the process's CPU
    time is the core's; a loaded machine stretches wall time, not this), its wall time
    and the answer."""
    cpu, wall, out = [], [], None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - t)
    return min(cpu), min(wall), out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--csv", type=Path, default=default_csv())
    ap.add_argument("--rows", type=int, default=1620)
    ap.add_argument("--reference-rows", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    if args.csv is None or not args.csv.exists():
        raise SystemExit("no FTDCR v4 train CSV: give --csv PATH (../shared/opencr/ftdcr_v4/...train.csv)")
    d = np.ascontiguousarray(read_servos(args.csv)[: args.rows])
    robot = cdsm.Robot.from_toml(FTDCR)
    robot.threads = 1
    ref = load_robot(FTDCR)
    N, R = d.shape[0], min(args.reference_rows, d.shape[0])
    print(f"FTDCR v4: {robot.n} joints, {robot.cables} tendons; {N} recorded rows of {args.csv.name}")
    tw, ww, warm = best(lambda: robot.equilibrium(displacements=d, sequence=True), args.repeat)
    tc, wc, cold = best(lambda: robot.equilibrium(displacements=d), args.repeat)
    trw, _, rwarm = best(lambda: elastic.equilibrium_sequence(ref, displacements=d[:R]), 1)
    trc, _, rcold = best(lambda: elastic.equilibrium(ref, displacements=d[:R]), 1)
    print("equilibria per second of CPU time (one thread); wall-clock rate in brackets")
    print(f"{'':18}{'core /s/core':>14}{'(wall)':>10}{'converged':>12}{'reference /s':>14}{'ratio':>8}"
          f"{'iter/row':>10}")
    for label, t, wt, sol, rt, rsol in (("warm (sequence)", tw, ww, warm, trw, rwarm),
                                        ("cold (from rest)", tc, wc, cold, trc, rcold)):
        rate, rrate = N / t, R / rt
        print(f"{label:18}{rate:14,.0f}{N / wt:10,.0f}{int(sol.converged.sum()):>7}/{N:<4}{rrate:14,.1f}"
              f"{rate / rrate:8.0f}{sol.iterations.mean():10.2f}")
        both = sol.converged[:R] & rsol["converged"]
        diff = np.abs(sol.theta[:R][both] - rsol["theta"][both]).max(initial=0.0)
        print(f"{'':24}max |theta core - reference| on {int(both.sum())} rows: {diff:.2e} rad")


if __name__ == "__main__":
    main()
