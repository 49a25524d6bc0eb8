"""Monte Carlo on Dask (issue 8): a cluster run gives the same arrays, bit for
bit, as a local run — whatever the number of workers, the order chunks finish
in, or a worker killed mid-run — and cluster problems give clear errors.

A ``LocalCluster`` (worker processes, loopback only; its dashboard on a free loopback port) is started here;
the module is skipped when dask.distributed is not installed.
"""

from __future__ import annotations

import json
import os
import signal
import sys
import time

import numpy as np
import pytest

dask_distributed = pytest.importorskip("distributed")
cloudpickle = pytest.importorskip("cloudpickle")

import cdsm  # noqa: E402
from cdsm.accuracy import distributed, montecarlo, workspace  # noqa: E402
from cdsm.accuracy.tolerance import read_tolerances  # noqa: E402
from cdsm.cli import main  # noqa: E402

from conftest import N12_LINKAGES, hole_perturbation, robot_toml  # noqa: E402

# test-only task wrappers below travel to the workers by value
cloudpickle.register_pickle_by_value(sys.modules[__name__])

FIELDS = ("count", "failed", "sum", "sum_sq", "min", "max", "hist", "hist_lo")
SAMPLES, CHUNK, SEED = 600, 40, 11  # 15 chunks, the last one full
TOL = dict(dl_tol=1e-3, dh_tol=0.35e-3)


def _cluster(**kw):
    opts = dict(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                dashboard_address="127.0.0.1:0")
    opts.update(kw)
    return dask_distributed.LocalCluster(**opts)


@pytest.fixture(scope="module")
def cluster():
    cl = _cluster()
    yield cl
    cl.close()


@pytest.fixture(scope="module")
def robot():
    """The paper robot with perturbed holes: built in code, it has no TOML of its own."""
    r = cdsm.Robot.paper()
    return r.with_holes(r.holes + hole_perturbation(3, 2e-4, seed=5))


@pytest.fixture(scope="module")
def theta0():
    return workspace.joint_grid(3, step=np.radians(10.0))  # 343 configurations


@pytest.fixture(scope="module")
def local(robot, theta0):
    robot.threads = 0
    return distributed.run(robot, theta0, SAMPLES, SEED, CHUNK, progress=False, **TOL)


def assert_same(a, b):
    for f in FIELDS:
        x, y = np.asarray(getattr(a, f)), np.asarray(getattr(b, f))
        assert x.dtype == y.dtype and x.shape == y.shape, f
        # bitwise: equal bytes (NaN-safe, -0.0 distinct)
        assert x.tobytes() == y.tobytes(), f"{f} differs"


# ---------------------------------------------------------------------------
# no cluster needed
# ---------------------------------------------------------------------------
def test_robot_spec_round_trip(robot):
    text = robot_toml(N12_LINKAGES).replace('name = "test robot"', r'name = "n12 \"q\" – ü"')
    n12 = cdsm.Robot.from_toml_str(text)
    assert n12.name == 'n12 "q" – ü'
    cabled = cdsm.Robot.paper().with_cable(youngs_modulus=2e11, diameter=0.3e-3, routing_length=0.5)
    for r in (cdsm.Robot.paper(), robot, n12, cabled):
        back = distributed.robot_from_spec(distributed.robot_spec(r))
        assert back.name == r.name
        for name in ("link_before", "link_after", "thickness", "mass", "lower_tension",
                     "joint_limits", "holes"):
            assert np.array_equal(getattr(back, name), getattr(r, name)), name
        assert (back.youngs_modulus, back.cable_diameter, back.routing_length) == \
            (r.youngs_modulus, r.cable_diameter, r.routing_length)


def test_local_run_is_errors_monte_carlo_and_thread_independent(robot, theta0, local):
    robot.threads = 1
    one = montecarlo.monte_carlo(robot, theta0, SAMPLES, SEED, chunk=CHUNK, progress=False, **TOL)
    robot.threads = 0
    assert_same(local, one)
    assert local.count.sum() + local.failed.sum() == SAMPLES * len(theta0)


def test_ordered_merge_is_independent_of_arrival_order(robot, theta0, local):
    t0 = np.ascontiguousarray(theta0)
    dl = np.full(3, 1e-3)
    dh = np.full(3, 0.35e-3)
    sizes = list(montecarlo.chunk_sizes(SAMPLES, CHUNK))
    parts = [distributed.pack(montecarlo.monte_carlo_chunk(robot, t0, SEED, c, m, dl, dh))
             for c, m in enumerate(sizes)]
    rng = np.random.default_rng(0)
    for _ in range(5):
        order = rng.permutation(len(parts))
        m = distributed.OrderedMerge(len(parts))
        for c in order:
            m.add(c, parts[c])
        assert m.done and m.pending == 0
        assert_same(m.result, local)
    # reversed arrival parks everything but the last before merging
    m = distributed.OrderedMerge(len(parts))
    for c in reversed(range(len(parts))):
        m.add(c, parts[c])
    assert m.peak == len(parts) and m.done
    with pytest.raises(ValueError):
        m.add(0, parts[0])


def test_pack_round_trip_is_exact(robot, theta0):
    part = montecarlo.monte_carlo_chunk(robot, np.ascontiguousarray(theta0), 1, 0, 30,
                                    np.full(3, 1e-3), np.full(3, 0.35e-3))
    wire = distributed.pack(part)
    # the wire carries the chunk's window of the histogram, as uint32
    assert wire["hist"].dtype == np.uint32 and wire["hist_lo"] == part.hist_lo > 0
    assert 0 < wire["hist"].shape[1] < cdsm._cdsm.HIST_BINS // 2
    assert_same(distributed.unpack(wire), part)


def test_bad_scheduler_address_fails_fast(robot, theta0):
    t = time.perf_counter()
    with pytest.raises(distributed.ClusterError, match=r"tcp://127\.0\.0\.1:1.*within 2 s"):
        distributed.run(robot, theta0[:5], 10, scheduler="tcp://127.0.0.1:1", timeout=2,
                       progress=False)
    assert time.perf_counter() - t < 8
    with pytest.raises(distributed.ClusterError, match="bad Dask scheduler address 'a:b:c'"):
        distributed.run(robot, theta0[:5], 10, scheduler="a:b:c", progress=False)


def test_missing_dask_is_a_clear_error(robot, theta0, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(distributed.ClusterError, match=r"pip install 'cdsm\[dask\]'"):
        distributed.run(robot, theta0[:5], 10, scheduler="tcp://127.0.0.1:8786", progress=False)


def test_tolerance_file(tmp_path, robot, theta0):
    f = tmp_path / "tol.json"
    f.write_text(json.dumps({"cable_length_tol_m": [1e-4, 2e-4, 3e-4],
                             "hole_height_tol_m": [5e-5, 6e-5, 7e-5], "other": "ignored"}))
    dl, dh = read_tolerances(str(f), robot)
    assert dl.tolist() == [1e-4, 2e-4, 3e-4] and dh.tolist() == [5e-5, 6e-5, 7e-5]
    f.write_text(json.dumps({"cable_length_tol_m": [1e-4, 2e-4], "hole_height_tol_m": 1e-4}))
    with pytest.raises(cdsm.CdsmInputError, match="needs 3 values"):
        read_tolerances(str(f), robot)
    f.write_text(json.dumps({"cable_length_tol_m": 1e-4}))
    with pytest.raises(cdsm.CdsmInputError, match="missing key 'hole_height_tol_m'"):
        read_tolerances(str(f), robot)
    f.write_text(json.dumps({"cable_length_tol_m": -1e-4, "hole_height_tol_m": 1e-4}))
    with pytest.raises(cdsm.CdsmInputError, match=">= 0"):
        read_tolerances(str(f), robot)


# ---------------------------------------------------------------------------
# on a LocalCluster
# ---------------------------------------------------------------------------
def test_cluster_equals_local_bitwise(cluster, robot, theta0, local, capsys, monkeypatch):
    addr = cluster.scheduler_address
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)  # progress draws on terminals only
    got = distributed.run(robot, theta0, SAMPLES, SEED, CHUNK, scheduler=addr, progress=True, **TOL)
    assert_same(got, local)
    assert got.params["workers"] == 2 and got.params["scheduler"] == addr
    assert "monte carlo (2 workers)" in capsys.readouterr().err
    # strictly one chunk in flight, and everything in flight at once: same bits
    for window in (1, 100):
        got = distributed.run(robot, theta0, SAMPLES, SEED, CHUNK, scheduler=addr, window=window,
                             progress=False, **TOL)
        assert_same(got, local)


def test_cluster_one_worker_equals_two(robot, theta0, local):
    with _cluster(n_workers=1) as cl1:
        got = distributed.run(robot, theta0, SAMPLES, SEED, CHUNK, scheduler=cl1, progress=False,
                             **TOL)
    assert got.params["workers"] == 1
    assert_same(got, local)


def _slow_chunk(job, c, size):
    """Chunk task whose early chunks finish last (completion order shuffled)."""
    time.sleep(0.02 * ((7 * c) % 15))
    return distributed.chunk_task(job, c, size)


def test_shuffled_completion_order_gives_same_bits(cluster, robot, theta0, local):
    arrived = []
    got = distributed.run(robot, theta0, SAMPLES, SEED, CHUNK, scheduler=cluster.scheduler_address,
                         window=100, progress=False, _task=_slow_chunk,
                         on_chunk=lambda c, merged, total: arrived.append(c), **TOL)
    assert sorted(arrived) == list(range(SAMPLES // CHUNK))
    assert arrived != sorted(arrived), "completion order was not shuffled"
    assert_same(got, local)


def _steady_chunk(job, c, size):
    time.sleep(0.05)
    return distributed.chunk_task(job, c, size)


def test_worker_killed_mid_run_gives_same_bits(robot, theta0, local):
    with _cluster() as cl, dask_distributed.Client(cl) as client:
        pids = client.run(os.getpid)
        killed = {}

        def kill_one(c, merged, total):
            if not killed:
                addr, pid = sorted(pids.items())[0]
                os.kill(pid, signal.SIGKILL)
                killed[addr] = (pid, merged, total)

        got = distributed.run(robot, theta0, SAMPLES, SEED, CHUNK, scheduler=client, window=4,
                             progress=False, _task=_steady_chunk, on_chunk=kill_one, **TOL)
        (pid, merged, total), = killed.values()
        assert merged < total - 4  # the kill happened with chunks still to run
        client.wait_for_workers(2, timeout=30)
        assert pid not in client.run(os.getpid).values()  # the nanny started a new process
    assert_same(got, local)


def test_workers_without_cdsm_are_named(tmp_path, robot, theta0):
    pre = tmp_path / "no_cdsm.py"
    pre.write_text("import sys\nsys.modules['cdsm'] = None  # as if cdsm were not installed\n")
    with _cluster(n_workers=1, preload=[str(pre)]) as cl:
        addr = next(iter(cl.workers.values())).worker_address
        with pytest.raises(distributed.ClusterError, match=r"1 of 1 Dask workers cannot import cdsm") as ei:
            distributed.run(robot, theta0[:5], 10, scheduler=cl.scheduler_address, progress=False)
        assert addr in str(ei.value)


# ---------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------
CLI = ["montecarlo", "--samples", "120", "--chunk", "40", "--seed", "3", "--step", "15", "--quiet"]
KEYS = {"theta0", "poses", "count", "failed", "mean", "std", "min", "max", "max_abs", "sum", "sum_sq",
        "p50", "p95", "p99", "dxy_percentiles", "percentiles", "hist", "hist_edges", "quantities",
        "units", "params"}


def test_cli_local_and_cluster_write_the_same_npz(cluster, tmp_path, capsys):
    a, b = tmp_path / "local.npz", tmp_path / "cluster.npz"
    assert main(CLI + ["--out", str(a)]) == 0
    assert main(CLI + ["--out", str(b), "--scheduler", cluster.scheduler_address]) == 0
    assert "configurations x 120 samples" in capsys.readouterr().out
    za, zb = np.load(a), np.load(b)
    assert set(za.files) == KEYS == set(zb.files)
    n = len(za["count"])
    assert za["mean"].shape == (n, 4) and za["hist"].shape == (n, cdsm._cdsm.HIST_BINS)
    assert za["poses"].shape == (n, 3) and za["theta0"].shape == (n, 3)
    for k in KEYS - {"params"}:
        assert za[k].tobytes() == zb[k].tobytes(), k
    p = json.loads(str(za["params"]))
    assert p["samples"] == 120 and p["seed"] == 3 and p["chunk"] == 40
    assert p["tolerances"] == "paper" and p["dl_tol_m"] == [1e-3] * 3
    assert p["robot"] == "paper prototype (Table 1)" and p["cdsm_version"] == cdsm.__version__
    assert json.loads(str(zb["params"]))["scheduler"] == cluster.scheduler_address
    mc, _ = montecarlo.load_npz(str(a))
    assert np.array_equal(mc.percentile(95), za["p95"])


def test_cli_bad_scheduler_and_tolerances(tmp_path, capsys):
    out = str(tmp_path / "x.npz")
    assert main(CLI + ["--out", out, "--scheduler", "tcp://127.0.0.1:1", "--timeout", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdsm: error: cannot reach a Dask scheduler at 'tcp://127.0.0.1:1'")
    tol = tmp_path / "tol.json"
    tol.write_text(json.dumps({"cable_length_tol_m": [1e-4] * 2, "hole_height_tol_m": [1e-4] * 3}))
    assert main(CLI + ["--out", out, "--tolerances", str(tol)]) == 2
    assert "needs 3 values" in capsys.readouterr().err
    tol.write_text(json.dumps({"cable_length_tol_m": [1e-4] * 3, "hole_height_tol_m": [1e-4] * 3}))
    assert main(CLI + ["--out", out, "--tolerances", str(tol)]) == 0
    p = json.loads(str(np.load(out)["params"]))
    assert p["dl_tol_m"] == [1e-4] * 3 and p["tolerances"] == str(tol)
