"""Monte-Carlo error studies at scale: locally (threads in the Rust core) or on
a ``dask.distributed`` cluster, with identical results. SI units: m, rad.

The study is the one of :func:`cdsm.accuracy.montecarlo.monte_carlo` (the paper's Fig. 7:
uniform errors within ±dl_tol on each upper cable and ±dh_tol on each disk's
hole height), split into chunks of ``chunk`` samples. Chunk ``c`` draws its
errors from its own counter-based stream ``np.random.default_rng([seed, c])``
and is one call of :func:`cdsm.accuracy.montecarlo.monte_carlo_chunk` (one Rust call over
all configurations) — the same function on the laptop and on every worker.

Exact reproducibility (bitwise-identical arrays whatever the number of
workers, the order chunks finish in, or a worker dying mid-run)
-----------------------------------------------------------------------------
Counts, failures, histograms (integers), minima and maxima merge exactly in
any order; the floating sums (sum, sum of squares) do not: ``(a + b) + c`` and
``a + (b + c)`` differ in the last bit. We **merge in chunk-index order**
(:class:`OrderedMerge`): results are taken as they complete, parked in a
reorder buffer keyed by chunk index, and folded in as soon as every lower
chunk is in — exactly the left fold ``((p0 + p1) + p2) + ...`` of the local
:func:`cdsm.accuracy.montecarlo.monte_carlo`. So a cluster run equals the local run bit
for bit, at no extra arithmetic cost, with the existing :class:`MonteCarlo`.
The reorder buffer is bounded by submitting at most ``window`` chunks beyond
the oldest unmerged one (default: twice the cluster's threads), so the client
holds at most ``window`` chunk results; the price is head-of-line blocking: if
the oldest chunk is slow (or re-run after its worker died), the others keep
working only up to the window. The alternative — exact, associative sums
(integer fixed-point superaccumulators) — would allow any order and worker-side
tree reductions, but would change every sum relative to the local path, and
costs ~2000-bit accumulators per statistic; not worth it while the client can
merge faster than the cluster produces (see ``benches/bench_dask.py``).

Within a chunk the Rust kernel accumulates every configuration sequentially
over the samples in one thread; threads split configurations only, so the
number of Rust threads (local: all cores; workers: ``threads_per_chunk``)
does not change a bit either. Results do depend on ``chunk`` (it fixes the
streams and the summation order): same seed and chunk, same arrays.

Memory: a worker holds, per running chunk, its errors (chunk x n x 2 x 8 B)
and one chunk result (N x ~560 x 8 B for N configurations); the client holds
at most ``window`` results plus the running total.

Available statistics per configuration: count, failed, mean, std, min, max
(and max |.|) of dX, dY (m), dphi (rad) and |d(X, Y)| (m); percentiles of
|d(X, Y)| from the exact log-spaced histogram (232 bins per decade, reported
at the bin's geometric middle: within 0.498 % of the sample quantile; the
counts add, so local and cluster runs agree bitwise). Percentiles of dX, dY, dphi would
need their own histograms in the Rust kernel (not computed).
"""

from __future__ import annotations

import os
import time
import uuid
from typing import Callable, Dict, Optional

import numpy as np

from ..inputs import CdsmInputError, as_batch, as_count, as_tolerances
from ..progress import Progress
from ..robot import Robot
from .montecarlo import MonteCarlo, error_widths, monte_carlo, monte_carlo_chunk
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL

__all__ = ["run", "ClusterError", "OrderedMerge", "robot_spec", "robot_from_spec", "pack", "unpack",
           "chunk_task"]

_INSTALL_HINT = "install it with: pip install 'cdsm[dask]'  (or: pip install 'dask[distributed]')"


class ClusterError(RuntimeError):
    """The Dask cluster cannot run the study (unreachable scheduler, no
    workers, workers without cdsm or with another version)."""


# ---------------------------------------------------------------------------
# the robot as plain data (the pyo3 robot is not picklable)
# ---------------------------------------------------------------------------
def robot_spec(robot: Robot) -> dict:
    """The robot as plain data for another process: ``{"toml": str}``,
    :meth:`cdsm.Robot.to_toml` (every parameter, explicit holes, floats in
    their shortest round-trip form: parsed back to the same bits), so robots
    built in code (``with_holes``, ``with_cable``) travel too."""
    return {"toml": robot.to_toml()}


def robot_from_spec(spec: dict, threads: int = 0) -> Robot:
    """The robot of :func:`robot_spec` (``threads``: Rust threads, 0 = all cores)."""
    r = Robot.from_toml_str(spec["toml"])
    r.threads = threads
    return r


def _check_spec(robot: Robot, spec: dict) -> None:
    back = robot_from_spec(spec)
    if back.to_toml() != robot.to_toml():  # pragma: no cover
        raise CdsmInputError(f"robot {robot.name!r}: cannot be sent to the workers (its description does "
                             f"not survive the round trip)")


# ---------------------------------------------------------------------------
# the order-independent reduction
# ---------------------------------------------------------------------------
class OrderedMerge:
    """Folds chunk results in chunk-index order, whatever order they arrive in.

    ``add(c, part)`` parks ``part`` (a :class:`MonteCarlo` of chunk ``c``, or
    anything :func:`unpack` accepts) and folds every consecutive chunk from
    :attr:`next`; the total is ``((p0 + p1) + p2) + ...`` exactly as in
    :func:`cdsm.accuracy.montecarlo.monte_carlo`. :attr:`pending` results wait for a lower
    chunk; :attr:`peak` is the most ever parked. Adding a chunk twice (a task
    re-run whose first result also arrived) is an error.
    """

    def __init__(self, n_chunks: int):
        self.n_chunks = int(n_chunks)
        self.next = 0
        self.result: Optional[MonteCarlo] = None
        self._parked: Dict[int, object] = {}
        self.peak = 0

    @property
    def pending(self) -> int:
        return len(self._parked)

    @property
    def done(self) -> bool:
        return self.next >= self.n_chunks

    def add(self, c: int, part) -> None:
        c = int(c)
        if not 0 <= c < self.n_chunks or c < self.next or c in self._parked:
            raise ValueError(f"chunk {c}: out of range or already merged")
        self._parked[c] = part
        self.peak = max(self.peak, len(self._parked))
        while self.next in self._parked:
            p = unpack(self._parked.pop(self.next))
            if self.result is None:
                self.result = p
            else:
                self.result.merge(p)
            self.next += 1


def pack(part: MonteCarlo) -> dict:
    """A chunk result for the wire: the histogram's window (its occupied
    bins) as uint32 (counts of one chunk), the rest as is."""
    hist = part.hist
    if hist.dtype != np.uint32 and (hist.size == 0 or hist.max() < 2 ** 32):
        hist = hist.astype(np.uint32)
    return dict(count=part.count, failed=part.failed, sum=part.sum, sum_sq=part.sum_sq,
                min=part.min, max=part.max, hist_lo=int(part.hist_lo), hist=np.ascontiguousarray(hist))


def unpack(obj, theta0: Optional[np.ndarray] = None) -> MonteCarlo:
    if isinstance(obj, MonteCarlo):
        return obj
    n_cfg = len(obj["count"])
    return MonteCarlo(theta0=theta0 if theta0 is not None else np.zeros((n_cfg, 0)),
                      count=np.asarray(obj["count"], np.int64).copy(),
                      failed=np.asarray(obj["failed"], np.int64).copy(),
                      sum=np.array(obj["sum"]), sum_sq=np.array(obj["sum_sq"]),
                      min=np.array(obj["min"]), max=np.array(obj["max"]),
                      hist=np.array(obj["hist"]), hist_lo=int(obj["hist_lo"]))


# ---------------------------------------------------------------------------
# worker side
# ---------------------------------------------------------------------------
def _job(spec: dict) -> dict:
    """Task holding the study's shared inputs (recomputable if its worker dies)."""
    return spec


def chunk_task(job: dict, c: int, size: int) -> dict:
    """One chunk on a worker: one Rust call, packed result."""
    robot = robot_from_spec(job["robot"], threads=job["threads"])
    # arrays arriving over the wire may be read-only views: hand the core owned copies
    theta0 = np.array(job["theta0"], dtype=np.float64, order="C")
    part = monte_carlo_chunk(robot, theta0, job["seed"], c, size, np.array(job["dl_tol"]),
                             np.array(job["dh_tol"]), job["method"])
    return pack(part)


# The probe is a string run by the builtin ``eval`` on each worker: a function of
# this module would itself need cdsm to be unpickled there.
_PROBE = "(__import__('cdsm').__version__, __import__('cdsm.accuracy.distributed').accuracy.distributed.__name__)"


# ---------------------------------------------------------------------------
# client side
# ---------------------------------------------------------------------------
def _import_distributed():
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise ClusterError(f"--scheduler needs dask.distributed, which is not installed; "
                           f"{_INSTALL_HINT}") from None
    return distributed


def connect(scheduler, timeout: float = 10.0):
    """A ``distributed.Client`` for ``scheduler`` (address such as
    ``tcp://host:8786``, a ``LocalCluster``, or a ``Client`` — returned as is).
    Returns (client, owned). Raises :class:`ClusterError` naming the address
    if no scheduler answers within ``timeout`` s."""
    distributed = _import_distributed()
    if isinstance(scheduler, distributed.Client):
        return scheduler, False
    if not isinstance(scheduler, str):
        return distributed.Client(scheduler, set_as_default=False), True
    _check_address(scheduler)
    try:
        return distributed.Client(scheduler, timeout=float(timeout), set_as_default=False), True
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        detail = " ".join(str(exc).split()) or type(exc).__name__
        raise ClusterError(f"cannot reach a Dask scheduler at {scheduler!r} within {timeout:g} s "
                           f"({detail}); check the address (e.g. tcp://host:8786) and that "
                           f"`dask scheduler` runs there") from None


def _check_address(address: str) -> None:
    """Rejects a malformed scheduler address at once (before any connection)."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, loc = parse_address(address, strict=False)
        if scheme in ("tcp", "tls"):
            host, port = parse_host_port(loc, 8786)
            if not host or not 0 < int(port) < 65536:
                raise ValueError("needs host:port with a port in 1..65535")
    except (ValueError, TypeError) as exc:
        raise ClusterError(f"bad Dask scheduler address {address!r} ({' '.join(str(exc).split())}); "
                           f"expected e.g. tcp://host:8786") from None


def probe(client, timeout: float = 10.0) -> Dict[str, str]:
    """Checks that every worker imports cdsm (the same version as here):
    ``{worker address: cdsm version}``. Raises :class:`ClusterError` listing
    the workers that lack it, or if no worker joins within ``timeout`` s."""
    from .. import __version__

    try:
        client.wait_for_workers(1, timeout=float(timeout))
    except (OSError, TimeoutError) as exc:
        raise ClusterError(f"the Dask scheduler at {client.scheduler.address!r} has no workers "
                           f"(waited {timeout:g} s): start some with `dask worker ADDRESS`") from exc
    got = client.run(eval, _PROBE, on_error="return")
    missing = {a: r for a, r in got.items() if isinstance(r, BaseException)}
    if missing:
        lines = "; ".join(f"{a}: {type(e).__name__}: {e}" for a, e in sorted(missing.items()))
        raise ClusterError(f"{len(missing)} of {len(got)} Dask workers cannot import cdsm ({lines}); "
                           f"install cdsm in the workers' environment (pip install cdsm) and "
                           f"restart them")
    versions = {a: r[0] for a, r in got.items()}
    other = {a: v for a, v in versions.items() if v != __version__}
    if other:
        raise ClusterError(f"Dask workers run another cdsm version than this client ({__version__}): "
                           + ", ".join(f"{a}: {v}" for a, v in sorted(other.items())))
    return versions


def run(robot: Robot, theta0, samples: int = 1000, seed: int = 0, chunk: int = 100,
        dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL, scheduler=None, progress: bool = True,
        method: str = "auto", threads_per_chunk: int = 1, window: Optional[int] = None,
        timeout: float = 10.0, on_chunk: Optional[Callable[[int, int, int], None]] = None,
        _task: Optional[Callable] = None) -> MonteCarlo:
    """The Monte-Carlo study over the configurations ``theta0`` (N, n), rad.

    samples: error samples; chunk: samples per chunk (= per task / Rust call);
    seed: chunk c draws from ``default_rng([seed, c])``. dl_tol, dh_tol:
    uniform error bounds, m, scalar or (n,) (default: the paper's 1 mm and
    0.35 mm). scheduler: None runs locally (``robot.threads`` Rust threads);
    otherwise a Dask scheduler address, ``LocalCluster`` or ``Client``: each
    chunk is one task running ``threads_per_chunk`` Rust threads, at most
    ``window`` chunks (default 2 x the cluster's threads) beyond the oldest
    unmerged one are in flight. timeout: s to reach the scheduler and find
    workers. on_chunk(c, merged_chunks, n_chunks) is called as each result
    arrives (cluster runs only). ``_task`` (tests only) replaces the chunk
    task ``chunk_task(job, c, size)``. Results are identical for both paths (module
    docstring). Returns a :class:`MonteCarlo` (N configurations) whose
    ``params`` record the run.
    """
    t0, _ = as_batch("theta0", theta0, robot.n)
    samples, chunk = as_count("samples", samples, 1), as_count("chunk", chunk, 1)
    seed = as_count("seed", seed)
    wl, wh = error_widths(robot)
    dlt, dht = as_tolerances("dl_tol", dl_tol, wl), as_tolerances("dh_tol", dh_tol, wh)
    start = time.perf_counter()
    if scheduler is None:
        mc = monte_carlo(robot, t0, samples=samples, seed=seed, dl_tol=dlt, dh_tol=dht,
                         chunk=chunk, progress=progress, method=method)
        mc.params.update(scheduler="local", workers=1, threads=robot.threads or os.cpu_count(),
                         elapsed_s=time.perf_counter() - start)
        return mc
    spec = robot_spec(robot)
    _check_spec(robot, spec)
    client, owned = connect(scheduler, timeout)
    try:
        versions = probe(client, timeout)
        nthreads = sum(client.nthreads().values())
        win = max(2, 2 * nthreads) if window is None else int(window)
        if win < 1:
            raise CdsmInputError(f"`window`: must be >= 1, got {window}")
        mc = _run_cluster(client, spec, t0, samples, seed, chunk, dlt, dht, method,
                          int(threads_per_chunk), win, progress, on_chunk,
                          f"monte carlo ({len(versions)} workers)", _task or chunk_task)
        mc.params = dict(samples=samples, seed=seed, chunk=chunk, dl_tol_m=dlt.tolist(),
                         dh_tol_m=dht.tolist(), method=method,
                         scheduler=str(client.scheduler.address), workers=len(versions),
                         threads=nthreads, window=win, elapsed_s=time.perf_counter() - start)
        return mc
    finally:
        if owned:
            client.close()


def _run_cluster(client, spec, t0, samples, seed, chunk, dlt, dht, method, threads, window,
                 progress, on_chunk, label, task) -> MonteCarlo:
    from distributed import as_completed

    n_chunks = -(-samples // chunk)
    token = uuid.uuid4().hex[:12]
    job = client.submit(_job, dict(robot=spec, theta0=t0, seed=seed, dl_tol=dlt, dh_tol=dht,
                                   method=method, threads=threads),
                        key=f"cdsm-mc-job-{token}", pure=False)
    merge = OrderedMerge(n_chunks)
    bar = Progress(samples, label, progress)
    index: Dict[str, int] = {}
    # with_results: the client's IO loop fetches results in the background as
    # they finish (no blocking round trip per chunk); a task's error is raised here
    ac = as_completed(loop=client.loop, with_results=True)
    submitted = 0

    def size(c: int) -> int:
        return min(chunk, samples - c * chunk)

    def top_up() -> None:
        nonlocal submitted
        while submitted < n_chunks and submitted < merge.next + window:
            f = client.submit(task, job, submitted, size(submitted),
                              key=f"cdsm-mc-{token}-{submitted}", pure=False, retries=0)
            index[f.key] = submitted
            ac.add(f)
            submitted += 1

    try:
        top_up()
        for fut, part in ac:
            c = index.pop(fut.key)
            fut.release()
            merge.add(c, part)
            bar.update(size(c))
            if on_chunk is not None:
                on_chunk(c, merge.next, n_chunks)
            top_up()
    except BaseException:
        client.cancel(list(ac.futures) + [job], force=True)
        raise
    job.release()
    out = merge.result
    out.theta0 = t0
    return out
