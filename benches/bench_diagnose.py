"""Benchmark of the sim-to-real diagnosis (``python benches/bench_diagnose.py``).

1. A 60-row absolute dataset from the virtual prototype (10 µm noise, one
   hidden effect at its typical magnitude) against every effect of the
   library with 10-fold cross-validation — once per hidden effect.
2. The seed paper's Table 3 (9 displacement rows, leave-one-out).

Prints seconds and the answer. Thread count: CDSM threads default (set
``RAYON_NUM_THREADS=2`` to time on 2 cores).
"""

from __future__ import annotations

import os
import time

import numpy as np

from cdsm import Robot, diagnose, measurements, plant


def main() -> None:
    robot = Robot.paper()
    print(f"cores visible: {os.cpu_count()}, RAYON_NUM_THREADS={os.environ.get('RAYON_NUM_THREADS', 'unset')}")
    total = 0.0
    for k, effect in enumerate(plant.EFFECTS):
        lay = plant.layout(robot)[effect]
        w = lay.stop - lay.start
        sign = np.ones(w) if effect in plant.NON_NEGATIVE else np.resize([1.0, -1.0], w)
        vp = plant.VirtualPrototype(robot, {effect: plant.TYPICAL[effect] * sign}, noise=10e-6, seed=100 + k)
        th, dl = vp.random_commands(60)
        meas = vp.measure(th, dl)
        t0 = time.perf_counter()
        d = diagnose.diagnose(robot, meas, folds=10)
        dt = time.perf_counter() - t0
        total += dt
        print(f"60 rows, 10-fold, hidden {effect:<19s}: {dt:5.2f} s  best={d.best:<30s} "
              f"held-out {d.baseline.heldout_rms * 1e6:7.1f} -> {d.final().heldout_rms * 1e6:5.1f} µm "
              f"(floor {d.noise_floor * 1e6:.1f})")
    print(f"all {len(plant.EFFECTS)} hidden effects: {total:.1f} s, {total / len(plant.EFFECTS):.2f} s each")
    meas = measurements.packaged("table3")
    t0 = time.perf_counter()
    d = diagnose.diagnose(robot, meas)
    dt = time.perf_counter() - t0
    print(f"Table 3 (9 displacement rows, leave-one-out): {dt:.2f} s  best={d.best} "
          f"held-out {d.baseline.heldout_rms * 1e6:.1f} -> {d.final().heldout_rms * 1e6:.1f} µm; "
          f"best single {d.singles[0].name} {d.singles[0].heldout_rms * 1e6:.1f} µm")


if __name__ == "__main__":
    main()
