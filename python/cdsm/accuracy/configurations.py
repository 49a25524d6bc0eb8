"""Configurations that avoid the special points (issue 7). SI units: m, rad.

The paper's conclusion: "If we can avoid these special points in trajectory
planning, the tip positioning accuracy will be significantly improved." For a
target we pick the joint configuration whose tip is least sensitive to the
cable-length and hole errors, measured by the linear RMS of the tip position
error (:func:`cdsm.accuracy.sensitivity.amplification`: ``sqrt(sum_ij S_ij^2
t_j^2 / 3)``, i over the position components; ``t`` the tolerances). Planar
arms: default the paper's ±1 mm per cable and ±0.35 mm per disk's hole
height, targets ``[x, y, phi]`` (mask ``"pose"``). Spatial arms: ±1 mm per
position cable and ±0.35 mm on every coordinate of every hole (the general
sensitivities of the one model), targets ``[x, y, z, rx, ry, rz]`` matched on
the mask's rows (default ``"position"``: the end origin, so that an arm with
more than three joints has a null space; ``"pose"`` needs more than six).

* No redundancy (as many joints as matched rows, e.g. a planar 3-joint arm
  on the full pose): the IK has (generically) several branches; they are
  found from several seeds (``(0, ∓1e-3, 0)``, ``(0, ±0.5, 0)``, 0) and the
  converged branch within the joint limits with the smaller RMS
  amplification wins.
* Redundancy: gradient projection in the null space of the matched rows of
  the task Jacobian (``P = I - J^+ J``, gradient of the squared RMS
  amplification by central differences: planar in the Rust core, spatial of
  the general sensitivities), a step along ``-P grad`` followed by the IK
  back onto the target, accepted only if it lowers the objective and stays
  within the joint limits; started from the θ = 0 seeded IK (the default).
* Paths: dynamic programming over the branches (cost = sum of RMS
  amplification + ``mu |Δθ|²``, transitions with ``max |Δθ| > max_step``
  forbidden, so the sequence stays continuous); with redundancy warm-started
  null-space descent from the previous target, with the penalty
  ``mu |θ - θ_prev|²``.

:func:`compare_with_default` measures the improvement with the Rust Monte
Carlo (the P-th percentile of the tip position error per target and pooled).
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from ..inputs import CdsmInputError, as_batch
from ..robot import Robot
from .montecarlo import monte_carlo
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL
from .tolerance import error_tolerances, pooled_percentile

__all__ = ["rms_amplification", "rms_and_gradient", "ik_branches", "best_configurations", "null_space_optimize",
           "path_configurations", "compare_with_default"]


def rms_amplification(robot: Robot, theta, dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL) -> np.ndarray:
    """(N,) linear RMS of the tip position error (m) at ``theta (N, n)`` rad
    for uniform errors within ±dl_tol per position cable and ±dh_tol per
    disk's hole height (planar) or hole coordinate (spatial), m; inf where
    the cable Jacobian is singular."""
    return rms_and_gradient(robot, theta, dl_tol, dh_tol)[0]


def rms_and_gradient(robot: Robot, theta, dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL, h: float = 1e-6):
    """:func:`rms_amplification` (N,) m and its gradient (N, n) m/rad in
    ``theta (N, n)`` rad (central differences of ``h`` rad, in the Rust core
    over the arm's sensitivities)."""
    t, _ = as_batch("theta", theta, robot.n)
    tol = np.ascontiguousarray(np.concatenate(error_tolerances(robot, dl_tol, dh_tol)))
    v, g = robot.core.rms_amplification(t, tol, float(h), robot.threads)
    return v, g.reshape(-1, robot.n)


def _rows(robot: Robot, mask: Optional[str]) -> np.ndarray:
    """The task rows a mask matches (default the kind's
    :attr:`~cdsm.kinds.Kind.default_mask`): ``"pose"`` every task coordinate
    (planar x, y, phi), ``"position"`` the position's (x, y or x, y, z)."""
    kind = robot.kind
    rows = {"pose": np.arange(kind.task), "position": np.arange(kind.dim)}
    mask = _mask_name(robot, mask)
    if mask not in rows:
        raise CdsmInputError(f"`mask`: expected 'pose' or 'position', got {mask!r}")
    return rows[mask]


def _mask_name(robot: Robot, mask: Optional[str]) -> str:
    return robot.kind.default_mask if mask is None else mask


def _pose_ok(robot: Robot, theta: np.ndarray, poses: np.ndarray, sol, mask=None) -> np.ndarray:
    ok = np.asarray(sol.converged, bool) & robot.within_limits(theta)
    rows = _rows(robot, mask)
    err = np.abs(robot.fk(theta)[:, rows] - poses[:, rows]).max(axis=1)
    return ok & (err < 1e-9)


def ik_branches(robot: Robot, poses, seeds=None, mask=None):
    """Candidate IK solutions of every target (N, task) from several seeds.

    Returns ``theta (N, B, n)`` rad and ``valid (N, B)`` (converged, within the
    joint limits, not a duplicate of an earlier seed's answer)."""
    p, _ = as_batch("poses", poses, robot.task)
    n = robot.n
    if seeds is None:
        seeds = []
        for v in (-1e-3, 1e-3, -0.5, 0.5):
            s = np.zeros(n)
            if n >= 2:
                s[1] = v
            seeds.append(s)
        seeds.append(np.zeros(n))
    cand = np.empty((len(p), len(seeds), n))
    valid = np.zeros((len(p), len(seeds)), bool)
    for b, s in enumerate(seeds):
        sol = robot.ik(p, seed=np.asarray(s, float), mask=_mask_name(robot, mask))
        th = np.atleast_2d(sol.theta)
        cand[:, b] = th
        ok = _pose_ok(robot, th, p, sol, mask)
        for prev in range(b):
            ok &= ~(valid[:, prev] & (np.abs(cand[:, prev] - th).max(axis=1) < 1e-6))
        valid[:, b] = ok
    return cand, valid


def null_space_optimize(robot: Robot, poses, theta_start, dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL,
                        iters: int = 60, theta_prev=None, mu: float = 0.0, step: float = 0.05,
                        margin: float = np.radians(0.5), mask=None) -> np.ndarray:
    """Null-space descent of ``rms² + mu |θ - θ_prev|²`` keeping the matched
    rows of the target: ``poses (N, task)``, ``theta_start (N, n)`` rad (must
    reach them); returns the improved ``theta (N, n)``. ``step``: initial max
    joint step, rad; joint limits shrunk by ``margin`` rad."""
    p, _ = as_batch("poses", poses, robot.task)
    rows = _rows(robot, mask)
    mname = _mask_name(robot, mask)
    th, _ = as_batch("theta_start", theta_start, robot.n)
    th = th.copy()
    n, N = robot.n, len(p)
    lim = robot.joint_limits
    lo, hi = lim[:, 0] + margin, lim[:, 1] - margin
    prev = None if theta_prev is None else as_batch("theta_prev", theta_prev, n)[0]

    def objective(t, rows=None):
        """rms² + mu |θ - θ_prev|² and its gradient (analytic in the penalty)."""
        v, g = rms_and_gradient(robot, t, dl_tol, dh_tol)
        f, grad = v ** 2, 2.0 * v[:, None] * g
        if prev is not None and mu > 0:
            pr = prev if rows is None else prev[rows]
            f = f + mu * ((t - pr) ** 2).sum(axis=1)
            grad = grad + 2.0 * mu * (t - pr)
        return f, grad

    f = objective(th)[0]
    eta = np.full(N, float(step))
    active = np.isfinite(f)
    for _ in range(int(iters)):
        idx = np.flatnonzero(active)
        if len(idx) == 0:
            break
        t = th[idx]
        grad = objective(t, idx)[1]
        J = robot.fk_jacobian(t)[:, rows]
        P = np.eye(n)[None] - np.linalg.pinv(J) @ J
        d = -(P @ grad[..., None])[..., 0]
        dmax = np.abs(d).max(axis=1)
        move = dmax > 1e-14
        dn = np.where(move[:, None], d / np.maximum(dmax, 1e-300)[:, None], 0.0)
        trial = np.clip(t + eta[idx, None] * dn, lo, hi)
        sol = robot.ik(p[idx], seed=trial, enforce_limits=True, mask=mname)
        tn = np.atleast_2d(sol.theta)
        ok = _pose_ok(robot, tn, p[idx], sol, mask) & np.all((tn >= lo) & (tn <= hi), axis=1) & move
        fn = np.where(ok, objective(np.where(ok[:, None], tn, t), idx)[0], np.inf)
        better = ok & (fn < f[idx] * (1 - 1e-9))
        th[idx[better]] = tn[better]
        f[idx[better]] = fn[better]
        eta[idx] = np.where(better, np.minimum(eta[idx] * 1.5, 0.3), eta[idx] * 0.5)
        active[idx] = (eta[idx] > 1e-5) & move
    return th


def best_configurations(robot: Robot, poses, dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL,
                        iters: int = 60, starts: int = 4, mask=None) -> dict:
    """Least-sensitive configuration of every target (N, task) against the
    default (θ = 0 seeded IK on the mask's rows; module doc). Returns
    ``theta_default``, ``theta_best`` (N, n) rad, ``rms_default``,
    ``rms_best`` (N,) m (linear RMS of the tip position error), and ``ok``
    (N,) (the default IK reached the target within the limits). Targets the
    default cannot reach within the limits keep the default (not compared).
    With redundancy: null-space descent from the default and from ``starts
    - 1`` IK answers of fixed random seeds; the lowest objective wins."""
    p, _ = as_batch("poses", poses, robot.task)
    n = robot.n
    mname = _mask_name(robot, mask)
    sol = robot.ik(p, mask=mname)
    t_def = np.atleast_2d(sol.theta)
    ok = _pose_ok(robot, t_def, p, sol, mask)
    f_def = np.where(ok, rms_amplification(robot, t_def, dl_tol, dh_tol), np.inf)
    if n <= len(_rows(robot, mask)):
        cand, valid = ik_branches(robot, p, mask=mask)
        f = rms_amplification(robot, cand.reshape(-1, n), dl_tol, dh_tol).reshape(valid.shape)
        f = np.where(valid, f, np.inf)
        b = np.argmin(f, axis=1)
        t_best = cand[np.arange(len(p)), b]
        f_best = f[np.arange(len(p)), b]
        keep = ~(f_best < f_def)  # the default is never worse than itself
    else:
        # multi-start: the default plus ``starts - 1`` IK answers from fixed random seeds
        rng = np.random.default_rng(12345)
        lim = robot.joint_limits
        t_best = t_def.copy()
        f_best = f_def.copy()
        for k in range(int(starts)):
            if k == 0:
                t0, ok0 = t_def, ok
            else:
                seed = rng.uniform(0.6 * lim[:, 0], 0.6 * lim[:, 1])
                s0 = robot.ik(p, seed=seed, mask=mname)
                t0 = np.atleast_2d(s0.theta)
                ok0 = _pose_ok(robot, t0, p, s0, mask)
            if not ok0.any():
                continue
            tk = t0.copy()
            tk[ok0] = null_space_optimize(robot, p[ok0], t0[ok0], dl_tol, dh_tol, iters=iters, mask=mask)
            fk_ = np.where(ok0, rms_amplification(robot, tk, dl_tol, dh_tol), np.inf)
            better = fk_ < f_best
            t_best[better] = tk[better]
            f_best[better] = fk_[better]
        keep = ~ok | ~(f_best < f_def)
    t_best = np.where(keep[:, None], t_def, t_best)
    f_best = np.where(keep, f_def, f_best)
    return dict(theta_default=t_def, theta_best=t_best, rms_default=f_def, rms_best=f_best, ok=ok)


def path_configurations(robot: Robot, poses, dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL,
                        mu: float = 1e-4, max_step: float = 0.15, iters: int = 30, mask=None) -> dict:
    """A continuous, low-sensitivity configuration sequence along a path of
    targets (M, task). ``mu`` (m²/rad² on the squared objective with
    redundancy; m/rad² on the DP cost without) weighs continuity;
    ``max_step`` (rad) is the largest joint change allowed between
    consecutive targets (without redundancy).

    Returns ``theta (M, n)``, ``rms (M,)`` m, and ``max_joint_step`` (rad)."""
    p, _ = as_batch("poses", poses, robot.task)
    n, M = robot.n, len(p)
    mname = _mask_name(robot, mask)
    if n <= len(_rows(robot, mask)):
        cand, valid = ik_branches(robot, p, mask=mask)
        B = cand.shape[1]
        f = rms_amplification(robot, cand.reshape(-1, n), dl_tol, dh_tol).reshape(M, B)
        f = np.where(valid, f, np.inf)
        cost = f[0].copy()
        back = np.zeros((M, B), int)
        for i in range(1, M):
            d = cand[i][None, :, :] - cand[i - 1][:, None, :]  # (B_prev, B, n)
            trans = mu * (d ** 2).sum(-1)
            trans = np.where(np.abs(d).max(-1) > max_step, np.inf, trans)
            tot = cost[:, None] + trans
            back[i] = np.argmin(tot, axis=0)
            cost = tot[back[i], np.arange(B)] + f[i]
        if not np.isfinite(cost).any():
            raise CdsmInputError("path_configurations: no continuous branch sequence "
                                 f"(raise max_step={max_step} rad?)")
        b = np.zeros(M, int)
        b[-1] = int(np.argmin(cost))
        for i in range(M - 1, 0, -1):
            b[i - 1] = back[i, b[i]]
        theta = cand[np.arange(M), b]
    else:
        theta = np.empty((M, n))
        prev = np.zeros(n)
        for i in range(M):
            sol = robot.ik(p[i], seed=prev, mask=mname)
            t = np.atleast_2d(sol.theta)
            theta[i] = null_space_optimize(robot, p[i:i + 1], t, dl_tol, dh_tol, iters=iters,
                                           theta_prev=None if i == 0 else prev[None], mu=mu, mask=mask)[0]
            prev = theta[i]
    steps = np.abs(np.diff(theta, axis=0)).max(axis=1) if M > 1 else np.zeros(0)
    return dict(theta=theta, rms=rms_amplification(robot, theta, dl_tol, dh_tol),
                max_joint_step=float(steps.max()) if len(steps) else 0.0)


def compare_with_default(robot: Robot, poses, dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL,
                         percentile: float = 95.0, samples: int = 500, seed: int = 0,
                         iters: int = 60, best: Optional[dict] = None, mask=None) -> dict:
    """Monte-Carlo check (Rust core) of :func:`best_configurations` against the
    θ = 0 seeded default over the targets (N, task) where the default is valid.

    Returns per-pose percentiles (m) ``p_default``, ``p_best``, the pooled
    percentiles ``pooled_default_m``, ``pooled_best_m``, the worst per-pose
    percentiles, the median per-pose ratio best/default, the fraction of poses
    improved by more than 1 % and the count of poses compared."""
    p, _ = as_batch("poses", poses, robot.task)
    res = best if best is not None else best_configurations(robot, p, dl_tol, dh_tol, iters, mask=mask)
    ok = res["ok"]
    dl_tol, dh_tol = error_tolerances(robot, dl_tol, dh_tol)  # a spatial hole tolerance per cable: per coordinate
    kw = dict(samples=samples, seed=seed, dl_tol=dl_tol, dh_tol=dh_tol, progress=False)
    md = monte_carlo(robot, res["theta_default"][ok], **kw)
    mb = monte_carlo(robot, res["theta_best"][ok], **kw)
    pd, pb = md.percentile(percentile), mb.percentile(percentile)
    ratio = pb / pd
    return dict(
        poses=int(ok.sum()), percentile=float(percentile),
        p_default=pd, p_best=pb,
        pooled_default_m=pooled_percentile(md, percentile), pooled_best_m=pooled_percentile(mb, percentile),
        worst_default_m=float(np.max(pd)), worst_best_m=float(np.max(pb)),
        median_ratio=float(np.median(ratio)), min_ratio=float(np.min(ratio)),
        improved_fraction=float(np.mean(ratio < 0.99)),
        rms_default_m=res["rms_default"][ok], rms_best_m=res["rms_best"][ok],
        theta_default=res["theta_default"][ok], theta_best=res["theta_best"][ok])
