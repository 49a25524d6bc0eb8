"""Speed of the sampled-configuration tools (``python benches/bench_sampling.py``).

:func:`cdsm.accuracy.sampling.nearest_neighbours` (``scipy.spatial.KDTree``,
leaf size 64, up to ``TREE_MAX_JOINTS`` = 12 joints; beyond, every pair
compared) against ``KDTree`` at SciPy's default leaf size 16 and at 64 and
a brute-force search in blocks of 1024 rows (squared distances by one matrix
product, ``argpartition``: cdsm's only search before SciPy), on uniform
points of the joint box; and :func:`cdsm.accuracy.sampling.sobol` (SciPy's
scrambled Sobol). One thread (set OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
for the matrix products); best of ``--repeat`` runs, ms.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from scipy.spatial import KDTree

from cdsm.accuracy import sampling


def brute(theta: np.ndarray, k: int, block: int = 1024) -> np.ndarray:
    """k nearest other rows by full distance blocks, nearest first."""
    sq = (theta * theta).sum(axis=1)
    out = np.empty((len(theta), k), dtype=np.int64)
    for s in range(0, len(theta), block):
        rows = slice(s, min(s + block, len(theta)))
        d = sq[rows, None] + sq[None, :] - 2.0 * theta[rows] @ theta.T
        d[np.arange(rows.stop - rows.start), np.arange(rows.start, rows.stop)] = np.inf
        part = np.argpartition(d, k - 1, axis=1)[:, :k]
        order = np.argsort(np.take_along_axis(d, part, axis=1), axis=1, kind="stable")
        out[rows] = np.take_along_axis(part, order, axis=1)
    return out


def best(f, repeat: int) -> float:
    """Best wall time of ``repeat`` calls, ms."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return 1e3 * min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    print(f"cores visible: {os.cpu_count()}, one thread")
    print(f"{'N':>6s} {'joints':>6s}   {'cdsm':>8s} {'KDTree leaf 16':>14s} {'KDTree leaf 64':>14s} "
          f"{'brute force':>12s}   (ms, k = 6)")
    rng = np.random.default_rng(0)
    for count, n in [(1000, 4), (1000, 8), (4000, 8), (1000, 12), (4000, 12), (4000, 16), (1000, 24), (4000, 24)]:
        theta = rng.uniform(-0.6, 0.6, (count, n))
        got = sampling.nearest_neighbours(theta, 6)
        assert (got == brute(theta, 6)).all()  # no ties among uniform points: the same neighbours
        t = [best(lambda: sampling.nearest_neighbours(theta, 6), args.repeat),
             best(lambda: KDTree(theta).query(theta, 7), args.repeat),
             best(lambda: KDTree(theta, leafsize=64).query(theta, 7), args.repeat),
             best(lambda: brute(theta, 6), args.repeat)]
        print(f"{count:6d} {n:6d}   {t[0]:8.1f} {t[1]:14.1f} {t[2]:14.1f} {t[3]:12.1f}")
    for count, n in [(1000, 4), (1000, 8), (4096, 24)]:
        ms = best(lambda: sampling.sobol(count, n, scramble=True, seed=1), args.repeat)
        print(f"sobol({count}, {n}, scrambled): {ms:.2f} ms")


if __name__ == "__main__":
    main()
