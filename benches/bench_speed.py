"""Per-core speed of the solves against the plain scalar C yardsticks, in one run.

    python benches/bench_speed.py [--groups 200] [--repeat 3] [--yardsticks DIR]
                                  [--compare-yardsticks DIR]

Workload (the speed issue's): the ±30° grid in 5° steps (13^3 = 2197
configurations) x G groups of uniform ±1 mm errors on the upper cables, each
solve seeded at its grid angles, through the public API with one worker
thread (``robot.threads = 1``): ``Robot.solve_cables`` with ``method="newton"``
and ``"auto"``, and the Monte-Carlo kernel (``accuracy.monte_carlo``, cable
errors only, then the paper's cable + hole errors). The C yardsticks
(``c_newton.c``, ``c_closed.c``, kept in ``benches/yardsticks/``; another
copy with ``--yardsticks``) are built with ``gcc -O3`` (portable, as a
wheel) and run on the same workload in the same run; the ratios are what to
read (these machines are noisy). A yardstick that cannot be built or run
ends the benchmark with an error. ``--compare-yardsticks DIR`` runs a second
set of yardsticks (e.g. the earlier ``../shared/anchors``) beside the first
in every round and prints the factor between them, so ratios taken against
either stay comparable.

Pose IK: the peer's poses — 2000 random theta in ±30° (seed 0), their tip
poses (phi = sum theta), repeated to G x 2000 / 2 solves — from
``workspace.paper_ik_seed``, with the damped least squares (LM, the default)
and the closed form (``method="closed_form"``, n = 3), one thread.

Every figure is the best of ``--repeat`` rounds (each round runs the C
yardsticks and every case once, so drift in the machine's speed slows both
sides alike), in millions of solves per second per core.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import cdsm
from cdsm.accuracy import montecarlo, workspace

ROOT = Path(__file__).resolve().parents[1]


def seconds(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


#: The C yardsticks, by name (``<name>.c``), and what they are.
YARDSTICKS = {"c_newton": "C Newton", "c_closed": "C closed form"}


def c_build(src: Path, exe: Path) -> Path:
    """Build ``src`` into ``exe`` with gcc -O3; exits with the reason when it
    cannot (no gcc, no source, a compile error)."""
    if shutil.which("gcc") is None:
        sys.exit(f"bench_speed: gcc not found: the C yardsticks ({src}) cannot be built")
    if not src.is_file():
        sys.exit(f"bench_speed: C yardstick {src} does not exist")
    done = subprocess.run(["gcc", "-O3", "-o", str(exe), str(src), "-lm"], capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"bench_speed: building {src} failed (gcc exit {done.returncode}):\n{done.stderr}")
    return exe


def c_run(exe: Path, groups: int) -> float:
    """One run of a C yardstick: its M solves/s; exits when it fails or says
    no rate."""
    done = subprocess.run([str(exe), str(groups)], capture_output=True, text=True)
    found = re.search(r"([0-9.]+) M/s", done.stdout)
    if done.returncode != 0 or found is None:
        sys.exit(f"bench_speed: C yardstick {exe.name} failed (exit {done.returncode}): {done.stdout}{done.stderr}")
    return float(found.group(1))


def workload(robot, groups: int, seed: int = 0):
    """(targets (N, 3) m, seeds (N, 3) rad) of the Monte-Carlo workload."""
    grid = workspace.joint_grid(robot.n)
    rng = np.random.default_rng(seed)
    err = rng.uniform(-1e-3, 1e-3, (groups, robot.n))
    l0 = robot.upper_lengths(grid)
    targets = (l0[None, :, :] + err[:, None, :]).reshape(-1, robot.n)
    return targets, np.tile(grid, (groups, 1)), grid, err


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--groups", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--yardsticks", default=str(ROOT / "benches" / "yardsticks"),
                    help="directory of c_newton.c and c_closed.c (default: benches/yardsticks)")
    ap.add_argument("--compare-yardsticks", metavar="DIR", default=None,
                    help="a second copy of the yardsticks run beside the first: prints the factor between them")
    args = ap.parse_args()
    dirs = {"": Path(args.yardsticks)}
    if args.compare_yardsticks is not None:
        dirs["other "] = Path(args.compare_yardsticks)
    with tempfile.TemporaryDirectory() as tmp:
        # the yardsticks first: one that cannot be built ends the run before any work
        exes = {prefix + k: c_build(d / f"{k}.c", Path(tmp) / f"{prefix.strip()}{k}")
                for prefix, d in dirs.items() for k in YARDSTICKS}
        best = measure(args, exes)
    print(f"yardsticks: {Path(args.yardsticks).resolve()}")
    print(f"{'path':<58} {'M/s/core':>9} {'yardstick':>10}  ratio")
    for label, ref, rate in best["cases"]:
        if ref is None:
            print(f"{label:<58} {rate:9.2f} {'':>10}     (roboticstoolbox ik_LM ≈ 0.045)")
        else:
            print(f"{label:<58} {rate:9.2f} {best[ref]:10.2f}  {rate / best[ref]:5.2f}x {YARDSTICKS[ref]}")
    if args.compare_yardsticks is not None:
        print(f"the same yardsticks from {Path(args.compare_yardsticks).resolve()} (best of {args.repeat} rounds, "
              "run in turn with the others):")
        for k, what in YARDSTICKS.items():
            print(f"  {what:<14} {best[k]:6.2f} M/s here, {best['other ' + k]:6.2f} M/s there: "
                  f"factor {best[k] / best['other ' + k]:.3f}")
    print(f"cores visible: {os.cpu_count()}")


def measure(args, exes) -> dict:
    """Best M solves/s of every C yardstick in ``exes`` (by name) and of
    every case over ``args.repeat`` rounds; ``"cases"``: (label, yardstick
    name or None, M/s) per case."""
    robot = cdsm.Robot.paper()
    robot.threads = 1
    targets, seeds, grid, err = workload(robot, args.groups)
    N = len(targets)
    print(f"workload: {args.groups} groups x {len(grid)} configurations = {N:,} solves; one thread; "
          f"SIMD: {cdsm._cdsm.simd_instruction_set()}")
    # the cases, each a (label, C yardstick, one timed run giving M/s)
    cases = []
    for method in ("newton", "auto"):
        sol = robot.solve_cables(targets, seed=seeds, method=method)
        assert sol.converged.all(), f"{method}: {np.sum(~sol.converged)} failed"
        cases.append((f"solve_cables(method={method!r})", "c_newton" if method == "newton" else "c_closed",
                      lambda m=method: N / seconds(lambda: robot.solve_cables(targets, seed=seeds, method=m)) / 1e6))
    for label, dh in (("cable errors only", 0.0), ("paper's errors (cables ±1 mm, holes ±0.35 mm)", 0.35e-3)):
        kw = dict(samples=args.groups, seed=1, chunk=args.groups, progress=False, dl_tol=1e-3, dh_tol=dh)
        cases.append((f"Monte-Carlo kernel, {label}", "c_closed",
                      lambda kw=kw: N / seconds(lambda: montecarlo.monte_carlo(robot, grid, **kw)) / 1e6))
    # pose IK on the peer's poses
    th = np.random.default_rng(0).uniform(-np.radians(30), np.radians(30), (2000, robot.n))
    poses = np.tile(robot.fk(th), (max(args.groups // 2, 1), 1))
    seed = workspace.paper_ik_seed(robot.n)
    methods = ["lm"] + (["closed_form"] if "closed_form" in getattr(cdsm.robot, "IK_METHODS", ()) else [])
    for m in methods:
        kw = {} if m == "lm" else {"method": m}
        sol = robot.ik(poses[:2000], seed=seed, **kw)
        assert sol.converged.all()
        cases.append((f"pose IK, method={m!r}, from paper_ik_seed", None,
                      lambda kw=kw: len(poses) / seconds(lambda: robot.ik(poses, seed=seed, **kw)) / 1e6))
    # rounds: every C yardstick and every case once per round, best of the
    # rounds each, so a machine whose speed drifts slows both sides alike
    best = {}
    for _ in range(args.repeat):
        for k, exe in exes.items():
            best[k] = max(best.get(k, 0.0), c_run(exe, args.groups))
        for label, _, run in cases:
            best[label] = max(best.get(label, 0.0), run())
    best["cases"] = [(label, ref, best[label]) for label, ref, _ in cases]
    return best


if __name__ == "__main__":
    main()
