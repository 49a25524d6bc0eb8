"""The paper's Monte-Carlo workload through the public API and through the
NumPy reference, in one run: 1000 error samples x 2197 workspace configurations
(the ±30° grid in 5° steps) = 2,197,000 cable solves.

    python benches/bench_montecarlo.py [--samples 1000] [--ref-samples 20]

Prints solves per second for the Rust core on 1 thread and on all cores, for
the vectorised NumPy reference (closed form and damped Newton, on a subset of
samples: same per-solve work), and their ratios.
"""

from __future__ import annotations

import argparse
import os
import time

import cdsm
from cdsm import reference, workspace
from cdsm.errors import monte_carlo, sample_errors


def rust_rate(robot, theta0, samples, threads, method, repeat=3):
    """Best of ``repeat`` runs (chunks of 1000 samples), solves per second."""
    robot.threads = threads
    best = 0.0
    for _ in range(repeat):
        t = time.perf_counter()
        mc = monte_carlo(robot, theta0, samples=samples, seed=1, chunk=1000, progress=False, method=method)
        el = time.perf_counter() - t
        assert mc.failed.sum() == 0, "failed solves in the benchmark"
        best = max(best, samples * len(theta0) / el)
    return best


def reference_rate(robot, theta0, samples, solver):
    dl, dh = sample_errors(robot.n, samples, 1, 0, 1e-3, 0.35e-3)
    l0 = reference.cable_lengths(robot, theta0)[:, 0::2]
    t = time.perf_counter()
    for s in range(samples):
        r = reference.hole_height_error(reference.Robot.like(robot), dh[s])
        sol = solver(r, l0 + dl[s], seed=theta0)
        reference.fk(robot, sol["theta"])
    el = time.perf_counter() - t
    return samples * len(theta0) / el


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--samples", type=int, default=1000)
    ap.add_argument("--ref-samples", type=int, default=20)
    args = ap.parse_args()
    robot = cdsm.Robot.paper()
    theta0 = workspace.joint_grid(3)
    cores = os.cpu_count() or 1
    print(f"workload: {args.samples} samples x {len(theta0)} configurations = "
          f"{args.samples * len(theta0):,} cable solves (reference: {args.ref_samples} samples)")
    rows = []
    r1 = rust_rate(robot, theta0, args.samples, 1, "auto")
    rn = rust_rate(robot, theta0, args.samples, 0, "auto")
    rnewt = rust_rate(robot, theta0, max(args.samples // 10, 1), 1, "newton")
    ref_cf = reference_rate(robot, theta0, args.ref_samples, reference.solve_cables_closed_form)
    ref_nt = reference_rate(robot, theta0, max(args.ref_samples // 4, 1), reference.solve_cables)
    rows += [("rust auto (closed form), 1 thread", r1), (f"rust auto, {cores} threads", rn),
             ("rust damped Newton, 1 thread", rnewt), ("numpy reference closed form", ref_cf),
             ("numpy reference damped Newton", ref_nt)]
    for name, rate in rows:
        print(f"{name:<40} {rate:>14,.0f} solves/s")
    print(f"ratio rust auto 1 thread / numpy closed form:   {r1 / ref_cf:8.1f}x")
    print(f"ratio rust Newton 1 thread / numpy Newton:      {rnewt / ref_nt:8.1f}x")
    print(f"ratio rust public API (auto) 1 thread / numpy reference solve_cables (damped Newton): "
          f"{r1 / ref_nt:8.1f}x")
    print(f"ratio rust auto {cores} threads / numpy closed form: {rn / ref_cf:8.1f}x")
    print(f"seconds per 1000 groups over the 2197-point grid: rust {1000 * len(theta0) / rn:.2f} s "
          f"({cores} threads), numpy {1000 * len(theta0) / ref_cf:.1f} s")


if __name__ == "__main__":
    main()
