"""The README's figures that no other committed script prints, recomputed.

    python benches/readme_figures.py [--part study|findings|spatial|cpu|all] [--out DIR] [--seeds 30]

Most of the README's numbers are printed by the run they come from: the
report of ``cdsm paper`` (report.md and its CSVs), ``cdsm tolerance``, and
the benchmarks of ``benches/`` (the README's "Where the numbers come from"
table says which). This script prints the rest, each under the README
sentence it belongs to:

- ``study``: ``cdsm paper`` on the paper's prototype, on ``two_universal``
  and on ``examples/two_section_arm.toml``, run one after the other (the
  console script, as a user runs it): wall time, CPU time (the run and its
  figure processes), configurations and Monte-Carlo samples per
  configuration ("The accuracy study of any arm");
- ``findings``: from the prototype's run directory, the figures of "What the
  paper study finds" that the report's text does not print: the
  mirror-symmetric seed's miss at Table 3's points 8 and 9
  (``table3.csv``), the share of the ±30° grid with every upper cable taut
  and the elastic tip deviation of each load reading (``readings.csv``), the
  friction hysteresis loops over the joint-space grid (``friction.csv``);
- ``spatial``: the ``two_universal`` study ("Spatial arms", Study): the
  largest tip deviation of a length error, how much less the hole errors
  move it, the configurations the neighbour rule flags and whether the
  deviation is smooth along each flagged pair (400 steps), and the count
  over the Sobol seeds 0 to ``--seeds`` - 1;
- ``cpu``: solves per CPU second (``time.process_time``, median of 5, one
  thread; other jobs on the same cores slow CPU time too: at load 13-16 on
  2 cores these rates came out at 40-65 % of an idle machine's) of the generated
  8-joint spatial arm of ``bench_scale.py`` (its cable-solve and
  Monte-Carlo workloads) and of the Monte Carlo of ``sjtu_snake`` (±1 mm
  on every position cable, ±0.35 mm on every hole coordinate, 200
  configurations in ±0.3 rad x 10 samples) ("Performance", spatial rows in
  lanes).

The runs go to ``--out`` (default: a temporary directory, removed).
"""

from __future__ import annotations

import argparse
import csv
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import cdsm
from cdsm import study
from cdsm.accuracy import montecarlo, sampling, scenarios, workspace

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_scale import spatial_toml  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]

#: The robots of the "study" part: (label, --robot argument or None for the default).
STUDY_ROBOTS = (("paper prototype (default)", None), ("two_universal", "two_universal"),
                ("examples/two_section_arm.toml", str(ROOT / "examples" / "two_section_arm.toml")))


def run_paper(robot, out: Path) -> dict:
    """``cdsm paper --quiet`` on ``robot`` into ``out``: wall and CPU seconds
    (user + system of the run and its children), the report's Monte-Carlo
    samples per configuration and the study's configurations."""
    cmd = [sys.executable, "-m", "cdsm", "paper", "--out-dir", str(out), "--quiet"]
    if robot is not None:
        cmd += ["--robot", robot]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    head = (out / "report.md").read_text(encoding="utf-8")[:3000]
    samples = int(re.search(r"Monte Carlo: (\d+) samples", head).group(1))
    with open(out / "configurations.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    by_protocol = {}
    for r in rows:
        by_protocol[r.get("protocol", "")] = by_protocol.get(r.get("protocol", ""), 0) + 1
    return dict(wall=wall, cpu=cpu, samples=samples, configurations=by_protocol)


def part_study(out: Path) -> dict:
    print("## The accuracy study of any arm: `cdsm paper` (one after the other)")
    runs = {}
    for label, robot in STUDY_ROBOTS:
        r = run_paper(robot, out / label.split("/")[-1].split(" ")[0])
        runs[label] = r
        configs = ", ".join(f"{k} {v}" for k, v in r["configurations"].items())
        print(f"  {label:<32} {r['wall']:6.1f} s wall, {r['cpu']:6.1f} s CPU; configurations: {configs}; "
              f"{r['samples']} Monte-Carlo samples each")
    base = runs[STUDY_ROBOTS[0][0]]["cpu"]
    for label, _ in STUDY_ROBOTS[1:]:
        print(f"  {label}: {runs[label]['cpu'] / base:.2f}x the prototype's CPU")
    return runs


def _rows(path: Path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def part_findings(run: Path) -> None:
    print(f"## What the paper study finds (from {run})")
    t3 = {int(r["point"]): r for r in _rows(run / "table3.csv")}
    miss = {p: 1e3 * np.hypot(float(t3[p]["dx_ours_plain_seed_m"]) - float(t3[p]["dx_ours_m"]),
                              float(t3[p]["dy_ours_plain_seed_m"]) - float(t3[p]["dy_ours_m"])) for p in t3}
    missed = {p: m for p, m in miss.items() if m > 1e-3}  # more than 1 µm
    print("  Table 3, the damped Newton from exactly theta = 0: misses point(s) "
          + ", ".join(f"{p} by {m:.2f} mm" for p, m in sorted(missed.items())))
    print("  load readings over the ±30° grid: every upper cable taut / largest elastic tip deviation (steel)")
    for r in _rows(run / "readings.csv"):
        taut = 100.0 * (1.0 - float(r["grid_slack_fraction"]))
        print(f"    {r['reading']:<32} {taut:5.1f} %   {1e3 * float(r['grid_max_elastic_dxy_m']):.2f} mm")
    rows = _rows(run / "friction.csv")
    for p in dict.fromkeys(r["protocol"] for r in rows):
        w = np.array([float(r["loop_width_m"]) for r in rows if r["protocol"] == p])
        mu = rows[0]["mu"]
        print(f"  friction hysteresis loops (±1 mm cycle of every cable, mu = {mu}), {p} protocol, {len(w)} "
              f"configurations: median {np.median(w) * 1e6:.1f} µm, largest {w.max() * 1e6:.1f} µm")


def flagged(robot, ws, scen) -> tuple:
    """The sampled study's jump test (:mod:`cdsm.study`): for every scenario
    the position deviation at ``ws``'s configurations and its jump points;
    (configurations on a jump in any scenario (N,) bool, {scenario key:
    SampledJumps}, {key: dS (N, 6)})."""
    jumps, devs = {}, {}
    for sc in scen:
        dev = scenarios.deviation(robot, ws.theta0, dL=sc.dL, dholes=sc.dholes, statics=False)
        ds = np.where(np.asarray(dev.ok, bool)[:, None], dev.dS, np.nan)
        devs[sc.key] = ds
        jumps[sc.key] = sampling.jump_points(ws.theta0, ds[:, :3], neighbours=ws.neighbours)
    point = np.any([j.point for j in jumps.values()], axis=0)
    return point, jumps, devs


def part_spatial(seeds: int) -> None:
    robot = cdsm.Robot.packaged("two_universal")
    scen = study.scenario_set(robot)
    ws = workspace.sample(robot, study.DEFAULT_CONFIGURATIONS, seed=0)
    point, jumps, devs = flagged(robot, ws, scen)
    print(f"## Spatial arms: the two_universal study ({len(ws.theta0)} configurations, seed 0)")
    peak = {sc.key: float(np.nanmax(np.linalg.norm(devs[sc.key][:, :3], axis=1))) for sc in scen}
    largest = {kind: max(v for k, v in peak.items() if k.startswith(kind)) for kind in ("cable", "radial", "normal")}
    print(f"  largest |d(X, Y, Z)|: ±1 mm on a cable's length {largest['cable'] * 1e3:.2f} mm; ±0.35 mm on its holes "
          f"radially {largest['radial'] * 1e3:.2f} mm, along the disk normal {largest['normal'] * 1e3:.2f} mm")
    cables = sorted({sc.cable for sc in scen})
    for kind, ref in (("radial", "cable"), ("normal", "radial")):
        rms = {key: float(np.sqrt(np.nanmean(np.sum(devs[key][:, :3] ** 2, axis=1)))) for key in devs}
        ratios = [(rms[f"{ref}{c + 1}+"] + rms[f"{ref}{c + 1}-"]) / (rms[f"{kind}{c + 1}+"] + rms[f"{kind}{c + 1}-"])
                  for c in cables]
        print(f"  RMS over the configurations, per cable: {ref} errors {min(ratios):.1f}-{max(ratios):.1f}x the "
              f"{kind} hole errors")
    keys = [k for k, j in jumps.items() if j.count]
    print(f"  neighbour rule: {int(point.sum())} configurations on a jump, in scenarios {', '.join(keys) or 'none'}")
    worst = 0.0
    for k in keys:
        j = jumps[k]
        sc = next(s for s in scen if s.key == k)
        for a, b in j.pairs[j.edge_jump]:
            path = ws.theta0[a] + np.linspace(0.0, 1.0, 401)[:, None] * (ws.theta0[b] - ws.theta0[a])
            dev = scenarios.deviation(robot, path, dL=sc.dL, dholes=sc.dholes, statics=False)
            step = np.linalg.norm(np.diff(dev.dS[:, :3], axis=0), axis=1)
            worst = max(worst, float(step.max() / step.mean()))
    print(f"  along each flagged pair (400 steps): largest step {worst:.2f}x the pair's mean step")
    counts = []
    for s in range(seeds):
        w = workspace.sample(robot, study.DEFAULT_CONFIGURATIONS, seed=s)
        counts.append(int(flagged(robot, w, scen)[0].sum()))
    print(f"  configurations on a jump over Sobol seeds 0-{seeds - 1}: {min(counts)} to {max(counts)} "
          f"({' '.join(map(str, counts))})")


def per_cpu_second(fn, count: int, repeat: int = 5) -> float:
    """``count`` solves over the median CPU time of ``repeat`` calls of ``fn``."""
    times = []
    for _ in range(repeat):
        t = time.process_time()
        fn()
        times.append(time.process_time() - t)
    return count / float(np.median(times))


def part_cpu() -> None:
    print("## Performance: solves per CPU second (median of 5, one thread)")
    arm = cdsm.Robot.from_toml_str(spatial_toml(4))
    arm.threads = 1
    th = np.random.default_rng(0).uniform(-0.4, 0.4, (20000, arm.n))
    lengths = arm.position_lengths(th)
    assert arm.solve_cables(lengths, seed=th + 0.02).converged.all()
    solve = per_cpu_second(lambda: arm.solve_cables(lengths, seed=th + 0.02), len(th))
    mc = per_cpu_second(lambda: montecarlo.monte_carlo(arm, th[:2000], samples=100, seed=0, progress=False),
                        2000 * 100)
    print(f"  {arm.name} (bench_scale.py's workloads): cable solve {solve / 1e6:.2f} M, Monte Carlo {mc / 1e6:.2f} M")
    snake = cdsm.Robot.packaged("sjtu_snake")
    snake.threads = 1
    th = np.random.default_rng(0).uniform(-0.3, 0.3, (200, snake.n))
    mc = per_cpu_second(lambda: montecarlo.monte_carlo(snake, th, samples=10, seed=0, dl_tol=1e-3, dh_tol=0.35e-3,
                                                       progress=False), 200 * 10)
    print(f"  sjtu_snake Monte Carlo (±1 mm cables, ±0.35 mm holes, from ±0.3 rad): {mc / 1e3:.1f} k")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--part", choices=("study", "findings", "spatial", "cpu", "all"), default="all")
    ap.add_argument("--out", default=None, help="directory for the cdsm paper runs (default: a temporary one)")
    ap.add_argument("--seeds", type=int, default=30, help="Sobol seeds of the spatial count")
    args = ap.parse_args()
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="readme-figures-"))
    try:
        if args.part in ("study", "all"):
            part_study(out)
        if args.part in ("findings", "all"):
            run = out / "paper"
            if not (run / "table3.csv").is_file():
                run_paper(None, run)
            part_findings(run)
        if args.part in ("spatial", "all"):
            part_spatial(args.seeds)
        if args.part in ("cpu", "all"):
            part_cpu()
    finally:
        if args.out is None:
            shutil.rmtree(out, ignore_errors=True)
    print(f"cdsm {cdsm.__version__}, commit {git_head()}")


def git_head() -> str:
    """The repository's HEAD (short; ``-dirty`` with uncommitted changes), or
    "unknown" outside a git checkout."""
    done = subprocess.run(["git", "-C", str(ROOT), "describe", "--always", "--dirty", "--abbrev=7"],
                          capture_output=True, text=True)
    return done.stdout.strip() if done.returncode == 0 else "unknown"


if __name__ == "__main__":
    main()
