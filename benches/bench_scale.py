"""How the solves scale with the number of joints, planar and spatial arms.

    python benches/bench_scale.py [--rows 20000] [--repeat 3] [--out FILE.md]

Arms: planar n = 3 (the paper's prototype), 8 (``serpentine8``) and 20
(generated below: 20 linkages of 0.02 / 0.02 / 0.008 m, hole heights 0.025
to 0.018 m, ±35°); spatial ``two_universal`` (4 joints) and an 8-joint arm
generated below (four universal-joint sections, the ``two_universal``
pattern continued). Per arm, with one worker thread (``robot.threads = 1``),
best of ``--repeat``, in solves per second per core:

* cable solve: random configurations in ±0.4 rad (seed 0), their
  position-cable lengths solved from theta + 0.02 rad (planar: damped
  Newton and ``auto``, which takes the per-joint closed form; spatial: the
  damped Newton of the shared solver);
* pose IK: the tip pose of each configuration from theta = 0 + 1 mrad on
  joint 2 (planar: LM, and the closed form at n = 3; spatial: masks
  ``position`` and ``pose``);
* Monte Carlo: the paper's ±1 mm cable and ±0.35 mm hole errors (spatial:
  on every hole coordinate), 2000 configurations x 100 samples, with one
  thread and with every core (``os.cpu_count()``).

Prints a Markdown table (and writes it to ``--out``). These machines are
noisy: compare rows of the same run.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import cdsm
from cdsm.accuracy import montecarlo


def planar_toml(n: int) -> str:
    lines = [f'name = "generated planar {n}-joint arm"', f"n = {n}", ""]
    for i in range(n):
        h = 0.025 - 0.007 * i / max(n - 1, 1)
        lines += ["[[linkage]]", "link_before = 0.020", "link_after = 0.020", "thickness = 0.008",
                  f"hole_height = {h:.6f}", "mass = 0.01", "lower_tension = 0.5",
                  "joint_limits = [-0.6108652381980153, 0.6108652381980153]", ""]
    return "\n".join(lines)


def spatial_toml(sections: int) -> str:
    lines = ['kind = "spatial"', f'name = "generated spatial arm, {2 * sections} joints"',
             "gravity = [0.0, 0.0, -9.80665]", "", "[base]", "radius = 0.03", ""]
    for _ in range(sections):
        lines += ["[[linkage]]", "joints = [",
                  "  { axis = [0.0, 1.0, 0.0], offset = [0.015, 0.0, 0.0], limits = [-0.6, 0.6] },",
                  "  { axis = [0.0, 0.0, 1.0], offset = [0.0, 0.0, 0.0], limits = [-0.6, 0.6] },",
                  "]", "link_after = [0.015, 0.0, 0.0]", "thickness = 0.005", "radius = 0.03",
                  "mass = 0.015", "com = [0.0025, 0.0, 0.0]", ""]
    for s in range(sections):
        r = 0.028 - 0.002 * s
        for k, (mode, extra) in enumerate((("position", ""), ("position", ""), ("force", "tension = 1.0"),
                                           ("force", "tension = 1.0"))):
            lines += ["[[cables]]", f"end = {s + 1}", f'mode = "{mode}"', f"radius = {r:.4f}",
                      f"angle = {k * np.pi / 2!r}"] + ([extra] if extra else []) + [""]
    return "\n".join(lines)


def rate(fn, count: int, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return count / best


def fmt(v: float) -> str:
    if v != v:
        return "—"
    return f"{v / 1e6:.2f} M" if v >= 1e6 else f"{v / 1e3:.0f} k"


def bench(label: str, robot, rows: int, repeat: int, mc_rows: int, mc_samples: int) -> dict:
    rng = np.random.default_rng(0)
    th = rng.uniform(-0.4, 0.4, (rows, robot.n))
    seed = th + 0.02
    ik_seed = np.zeros(robot.n)
    ik_seed[min(1, robot.n - 1)] = -1e-3
    robot.threads = 1
    out = {"arm": label, "n": robot.n}
    if robot.kind == "spatial":
        lengths = robot.position_lengths(th)
        sol = robot.solve_cables(lengths, seed=seed)
        assert sol.converged.all(), label
        out["newton"] = rate(lambda: robot.solve_cables(lengths, seed=seed), rows, repeat)
        out["auto"] = float("nan")
        pose = robot.fk(th)
        k = rows // 4
        out["ik"] = rate(lambda: robot.ik(pose[:k], seed=ik_seed, mask="position"), k, repeat)
        out["ik_pose"] = rate(lambda: robot.ik(pose[:k], seed=ik_seed, mask="pose"), k, repeat)
        out["ik_closed"] = float("nan")
    else:
        lengths = robot.upper_lengths(th)
        out["newton"] = rate(lambda: robot.solve_cables(lengths, seed=seed, method="newton"), rows, repeat)
        out["auto"] = rate(lambda: robot.solve_cables(lengths, seed=seed, method="auto"), rows, repeat)
        pose = robot.fk(th)
        k = rows // 4
        out["ik"] = float("nan")
        out["ik_pose"] = rate(lambda: robot.ik(pose[:k], seed=ik_seed), k, repeat)
        out["ik_closed"] = (rate(lambda: robot.ik(pose, seed=ik_seed, method="closed_form"), rows, repeat)
                            if robot.n == 3 else float("nan"))
    mth = th[:mc_rows]
    solves = mc_rows * mc_samples
    for threads, key in ((1, "mc1"), (os.cpu_count() or 1, "mcN")):
        robot.threads = threads
        out[key] = rate(lambda: montecarlo.monte_carlo(robot, mth, samples=mc_samples, seed=0, progress=False),
                        solves, repeat)
    robot.threads = 1
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--rows", type=int, default=20000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    arms = [("planar, paper prototype", cdsm.Robot.paper()),
            ("planar, serpentine8", cdsm.Robot.packaged("serpentine8")),
            ("planar, generated", cdsm.Robot.from_toml_str(planar_toml(20))),
            ("spatial, two_universal", cdsm.Robot.packaged("two_universal")),
            ("spatial, generated", cdsm.Robot.from_toml_str(spatial_toml(4)))]
    rows = [bench(label, r, a.rows, a.repeat, 2000, 100) for label, r in arms]
    cores = os.cpu_count() or 1
    head = ("| arm | joints | cable solve, Newton | cable solve, auto | IK position | IK pose (LM) | "
            f"IK closed form | Monte Carlo, 1 thread | Monte Carlo, {cores} threads |")
    table = [head, "|" + "---|" * 9]
    for r in rows:
        table.append(f"| {r['arm']} | {r['n']} | {fmt(r['newton'])} | {fmt(r['auto'])} | {fmt(r['ik'])} | "
                     f"{fmt(r['ik_pose'])} | {fmt(r['ik_closed'])} | {fmt(r['mc1'])} | {fmt(r['mcN'])} |")
    text = ("Solves per second (M = 10^6, k = 10^3); one worker thread except the last column; "
            f"best of {a.repeat}.\n\n" + "\n".join(table) + "\n")
    print(text)
    if a.out:
        with open(a.out, "w", encoding="utf-8") as f:
            f.write(text)


if __name__ == "__main__":
    main()
