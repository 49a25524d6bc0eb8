"""Soak benchmark (not CI): a Monte Carlo of >= 1e9 cable solves on a local
Dask cluster whose workers are killed twice mid-run, bitwise equal to the
same study run locally.

    python benches/soak_dask.py [--samples 456000] [--chunk 2000] [--workers 2]

Workload: the paper robot over the ±30° joint grid in 5° steps (2197
configurations) x ``--samples`` error samples (default 456,000: 1.0e9
solves). The cluster is a ``LocalCluster`` of single-threaded worker
processes under nannies; a watcher thread kills one worker process
(SIGKILL, as the OOM killer does) at 1/3 and at 2/3 of the chunks; its nanny
restarts it and the scheduler runs its lost chunks again. The local run uses
the Rust threads of this process. Prints the wall time and solves per second
of both, the peak resident memory of this process and of all its
descendants (sampled every 0.2 s), and whether every statistic of the two
results is bitwise equal (exit status 1 if not). Needs dask[distributed].
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import time

import numpy as np
import psutil

import cdsm
from cdsm.accuracy import distributed, workspace

FIELDS = ("count", "failed", "sum", "sum_sq", "min", "max", "hist")


class PeakMemory:
    """Samples the resident memory of this process and its descendants."""

    def __init__(self, every: float = 0.2):
        self.every, self.peak, self.peak_self = every, 0, 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        me = psutil.Process()
        while not self._stop.is_set():
            total = 0
            for p in [me] + me.children(recursive=True):
                try:
                    total += p.memory_info().rss
                except psutil.Error:
                    pass
            self.peak = max(self.peak, total)
            self.peak_self = max(self.peak_self, me.memory_info().rss)
            time.sleep(self.every)

    def __enter__(self) -> "PeakMemory":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()


def main() -> int:
    from distributed import Client, LocalCluster

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--samples", type=int, default=456_000)
    ap.add_argument("--chunk", type=int, default=2000)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--kills", type=int, default=2)
    args = ap.parse_args()
    robot = cdsm.Robot.paper()
    theta0 = np.ascontiguousarray(workspace.joint_grid(3))
    solves = args.samples * len(theta0)
    chunks = -(-args.samples // args.chunk)
    print(f"workload: {args.samples:,} samples x {len(theta0)} configurations = {solves:.3e} cable solves in "
          f"{chunks} chunks of {args.chunk}; {args.workers} single-threaded workers; {os.cpu_count()} cores",
          flush=True)

    cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    kills, marks = [], [int(chunks * (k + 1) / (args.kills + 1)) for k in range(args.kills)]
    lock = threading.Lock()

    def on_chunk(c: int, merged: int, total: int) -> None:
        with lock:
            if marks and merged >= marks[0]:
                marks.pop(0)
                pids = sorted(client.run(os.getpid).values())
                victim = pids[len(kills) % len(pids)]
                os.kill(victim, signal.SIGKILL)
                kills.append((merged, victim))
                print(f"  killed worker pid {victim} after {merged}/{total} chunks", flush=True)

    with PeakMemory() as mem_cluster:
        t = time.perf_counter()
        on_cluster = distributed.run(robot, theta0, args.samples, seed=7, chunk=args.chunk, scheduler=client,
                                     progress=False, on_chunk=on_chunk, timeout=60.0)
        t_cluster = time.perf_counter() - t
    client.close()
    cluster.close()
    print(f"cluster: {t_cluster:.1f} s, {solves / t_cluster / 1e6:.1f} M solves/s, {len(kills)} workers killed, "
          f"peak memory {mem_cluster.peak / 2**20:.0f} MB (this process and its workers), "
          f"client {mem_cluster.peak_self / 2**20:.0f} MB", flush=True)

    robot.threads = 0
    with PeakMemory() as mem_local:
        t = time.perf_counter()
        local = distributed.run(robot, theta0, args.samples, seed=7, chunk=args.chunk, progress=False)
        t_local = time.perf_counter() - t
    print(f"local:   {t_local:.1f} s, {solves / t_local / 1e6:.1f} M solves/s ({os.cpu_count()} Rust threads), "
          f"peak memory {mem_local.peak / 2**20:.0f} MB", flush=True)

    same = all(np.array_equal(getattr(local, f), getattr(on_cluster, f)) for f in FIELDS)
    print(f"bitwise equal: {same}; count {int(local.count.sum()):,}, failed {int(local.failed.sum())}", flush=True)
    return 0 if same and len(kills) == args.kills else 1


if __name__ == "__main__":
    sys.exit(main())
