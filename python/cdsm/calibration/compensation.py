"""Compensation: the upper-cable commands that put the tip of a fitted plant
on target poses, and the table they are written to. SI units (m, rad, N).
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass
from typing import List

import numpy as np

from ..accuracy.workspace import paper_ik_seed
from ..files import read_table, table_column, write_text
from ..inputs import CdsmInputError
from ..robot import Robot
from . import plant

__all__ = ["Compensation", "compensate", "read_targets"]


# ---------------------------------------------------------------------------
# targets
# ---------------------------------------------------------------------------
def read_targets(path: "str | os.PathLike[str]") -> np.ndarray:
    """Target poses from a CSV file: columns ``x, y`` (m) and optional ``phi``
    (rad); lines starting with ``#`` are comments, other columns are ignored.
    Returns (N, 3) or (N, 2). Raises :class:`CdsmInputError` on a missing
    column, a non-number or a non-finite value."""
    src = str(path)
    cols, rows = read_table(path, "targets")
    missing = [c for c in ("x", "y") if c not in cols]
    if missing:
        raise CdsmInputError(f"{src}: missing target columns {', '.join(missing)} (need x, y [m] "
                             f"and optional phi [rad]); found {', '.join(cols)}")
    use = ["x", "y"] + (["phi"] if "phi" in cols else [])
    return np.stack([table_column(rows, c, src) for c in use], axis=1)


# ---------------------------------------------------------------------------
# compensation result
# ---------------------------------------------------------------------------
@dataclass
class Compensation:
    """Compensated commands for N target poses (robot with n joints).

    targets: (N, 2) or (N, 3) the targets [x, y(, phi)] (m, m, rad).
    commands: (N, n) upper-cable length commands L_1..L_n, m (what the
    controller sends; NaN where the target is unreachable). theta_cmd: (N, n)
    rad, the nominal IK of the target (the uncompensated configuration) and dL:
    (N, n) m the correction, so ``commands = upper_lengths(theta_cmd) + dL``.
    nominal_commands: (N, n) m, the uncompensated commands
    ``upper_lengths(theta_cmd)``. converged: (N,) bool. predicted_error: (N,) m,
    the model's predicted tip position error |xy - target| with the commands;
    predicted_error_nominal: (N,) m, the same with the nominal commands;
    predicted_phi_error: (N,) rad (NaN when phi was not given). theta_pred:
    (N, n) rad, the configuration the fitted arm is predicted to settle at.
    flags: one str per row, "" when fine, else '; '-joined reasons
    (``unreachable: ...``, ``slack cable``, ``joint limits``, ``not converged``).
    """

    targets: np.ndarray
    commands: np.ndarray
    theta_cmd: np.ndarray
    dL: np.ndarray
    nominal_commands: np.ndarray
    converged: np.ndarray
    predicted_error: np.ndarray
    predicted_error_nominal: np.ndarray
    predicted_phi_error: np.ndarray
    theta_pred: np.ndarray
    flags: List[str]
    model_name: str = ""

    def __len__(self) -> int:
        return len(self.targets)

    @property
    def ok(self) -> np.ndarray:
        """(N,) converged and not flagged."""
        return self.converged & np.array([not f for f in self.flags], bool)

    def to_csv(self, path: "str | os.PathLike[str]") -> None:
        """Write the commands table: target columns (x, y[, phi]), L_1..L_n (m),
        converged (0/1), predicted_error and predicted_error_nominal (m),
        predicted_phi_error (rad, empty without phi), theta_1..theta_n (rad,
        the nominal configuration) and dL_1..dL_n (m, the correction), flags.
        Undefined numbers are written as ``nan``; floats by ``repr`` (exact)."""
        n = self.commands.shape[1]
        has_phi = self.targets.shape[1] == 3
        head = ["x", "y"] + (["phi"] if has_phi else []) + [f"L_{i}" for i in range(1, n + 1)] + \
            ["converged", "predicted_error", "predicted_error_nominal"] + \
            (["predicted_phi_error"] if has_phi else []) + \
            [f"theta_{i}" for i in range(1, n + 1)] + [f"dL_{i}" for i in range(1, n + 1)] + ["flags"]
        buf = io.StringIO()
        buf.write(f"# cdsm compensate: upper-cable length commands from model {self.model_name!r}\n")
        buf.write("# SI units: x, y, L_i, dL_i, predicted_error* in m; phi, theta_i, predicted_phi_error in rad\n")
        buf.write("# L_i = nominal upper length at theta_cmd + dL_i; converged 1/0; flags empty when fine\n")
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(head)
        for i in range(len(self)):
            row = [repr(float(v)) for v in self.targets[i]]
            row += [repr(float(v)) for v in self.commands[i]]
            row += [str(int(self.converged[i])), repr(float(self.predicted_error[i])),
                    repr(float(self.predicted_error_nominal[i]))]
            if has_phi:
                row.append(repr(float(self.predicted_phi_error[i])))
            row += [repr(float(v)) for v in self.theta_cmd[i]] + [repr(float(v)) for v in self.dL[i]]
            row.append(self.flags[i])
            w.writerow(row)
        write_text(path, buf.getvalue(), "commands")

    def summary(self) -> str:
        """A few lines: counts and the predicted errors before/after (µm)."""
        ok = self.converged
        fl = sum(1 for f in self.flags if f)
        lines = [f"{len(self)} targets: {int(ok.sum())} converged, {fl} flagged"]
        if ok.any():
            lines.append(f"predicted tip error with nominal commands: max "
                         f"{np.nanmax(self.predicted_error_nominal[ok]) * 1e6:.1f} µm; compensated: max "
                         f"{np.nanmax(self.predicted_error[ok]) * 1e6:.3g} µm")
        return "\n".join(lines)




def compensate(model, poses, tol: float = 1e-9, max_iter: int = 40, h: float = 1e-6,
               min_tension: float = 0.0, enforce_limits: bool = False) -> Compensation:
    """Upper-cable length commands that put the fitted plant's tip on ``poses``.

    poses: (N, 3) [x, y, phi] (m, m, rad) or (N, 2) [x, y]. Each row: the
    nominal configuration ``theta_cmd`` is the nominal pose IK of the target
    from the paper's seed (:func:`cdsm.accuracy.workspace.paper_ik_seed`; without phi,
    the IK of (x, y, 0) — for n = 3 the paper's branch — or of (x, y) alone
    when that fails or leaves the joint limits). The commands are ``upper_lengths(theta_cmd) + dL`` and
    dL (n,) m is found by damped Newton (Levenberg–Marquardt, minimal-norm
    steps) on the plant's absolute observation, Jacobian by central
    differences of ``h`` m — every row and perturbation in one Rust call
    per iteration. Residual [x, y(, phi·L)] with L the straight arm length
    (m/rad); converged when its largest component is <= ``tol`` (m).

    Flags: ``unreachable`` (nominal IK fails), ``outside the joint limits``
    (the nominal IK answer leaves them: flagged, and left out only with
    ``enforce_limits``),
    ``slack cable`` (an upper tension <= ``min_tension`` N at the predicted
    configuration of the fitted arm), ``joint limits`` (that configuration
    leaves the limits), ``not converged``.
    """
    r = model.robot
    n = r.n
    arr = np.asarray(poses, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] not in (2, 3):
        raise CdsmInputError(f"`poses`: expected shape (N, 3) or (N, 2), got {np.shape(poses)}")
    if not np.isfinite(arr).all():
        i, j = np.argwhere(~np.isfinite(arr))[0]
        raise CdsmInputError(f"`poses`: non-finite value {arr[i, j]} at row {i}, column {j}")
    N = len(arr)
    has_phi = arr.shape[1] == 3
    flags: List[List[str]] = [[] for _ in range(N)]
    seed = paper_ik_seed(n)
    full = arr if has_phi else np.column_stack([arr, np.zeros(N)])
    sol = r.ik(full, seed=seed) if N else None
    theta = np.array(sol.theta, dtype=float).reshape(N, n) if N else np.zeros((0, n))
    reach = np.asarray(sol.converged, bool).reshape(N) if N else np.zeros(0, bool)
    if not has_phi and N:
        # (x, y, 0) unreachable or outside the limits: position-only IK
        idx = np.flatnonzero(~(reach & r.within_limits(theta)))
        if len(idx):
            th2, ok2 = _ik_xy(r, arr[idx], seed)
            ok2 &= r.within_limits(th2) | ~reach[idx]
            theta[idx[ok2]] = th2[ok2]
            reach[idx[ok2]] = True
    for i in np.flatnonzero(~reach):
        flags[i].append("unreachable: the nominal pose IK finds no configuration")
    lim = r.within_limits(theta) if N else np.zeros(0, bool)
    for i in np.flatnonzero(reach & ~lim):
        flags[i].append("outside the joint limits: the nominal IK answer leaves them"
                        + (" (not compensated: enforce_limits)" if enforce_limits else ""))
    if enforce_limits:
        reach &= lim
    theta[~reach] = 0.0
    scale = float(np.sum(r.link_before + r.link_after + r.thickness))
    m = 3 if has_phi else 2
    w = np.array([1.0, 1.0, scale])[:m]
    dL = np.zeros((N, n))

    def resid(rows, d):
        obs, conv = plant.predict(r, model.p, theta[rows], d, "absolute")
        res = (arr[rows, :m] - obs[:, :m]) * w
        res[~conv] = np.nan
        return res

    res = np.full((N, m), np.nan)
    conv = np.zeros(N, bool)
    if reach.any():
        res[reach] = resid(np.flatnonzero(reach), dL[reach])
    res0 = res.copy()
    bad0 = reach & ~np.isfinite(res).all(axis=1)
    for i in np.flatnonzero(bad0):
        flags[i].append("the fitted model cannot realise the nominal commands")
    active = reach & ~bad0
    lam = np.full(N, 1e-8)
    conv[active] = np.abs(res[active]).max(axis=1) <= tol
    active &= ~conv
    it = 0
    while active.any() and it < max_iter:
        it += 1
        rows = np.flatnonzero(active)
        k = len(rows)
        # Jacobian: rows x (+h, -h) per cable, one call
        pert = np.repeat(dL[rows], 2 * n, axis=0).reshape(k, 2 * n, n)
        for j in range(n):
            pert[:, 2 * j, j] += h
            pert[:, 2 * j + 1, j] -= h
        rr = np.repeat(rows, 2 * n)
        obs, cv = plant.predict(r, model.p, theta[rr], pert.reshape(-1, n), "absolute")
        o = obs[:, :m].reshape(k, 2 * n, m) * w
        J = np.transpose((o[:, 0::2] - o[:, 1::2]) / (2 * h), (0, 2, 1))  # (k, m, n)
        good = np.isfinite(J).all(axis=(1, 2)) & cv.reshape(k, 2 * n).all(axis=1)
        J = np.nan_to_num(J)
        rk = res[rows]
        cost = np.einsum("ij,ij->i", rk, rk)
        # damped, minimal-norm steps; retry a row with more damping when a step fails
        accepted = np.zeros(k, bool)
        for _ in range(12):
            todo = ~accepted & good & (lam[rows] < 1e10)
            if not todo.any():
                break
            t = np.flatnonzero(todo)
            Jt = J[t]
            if m <= n:
                A = Jt @ np.transpose(Jt, (0, 2, 1)) + lam[rows[t], None, None] * np.eye(m)
                y = np.linalg.solve(A, rk[t][..., None])
                step = (np.transpose(Jt, (0, 2, 1)) @ y)[..., 0]
            else:
                A = np.transpose(Jt, (0, 2, 1)) @ Jt + lam[rows[t], None, None] * np.eye(n)
                step = np.linalg.solve(A, (np.transpose(Jt, (0, 2, 1)) @ rk[t][..., None]))[..., 0]
            trial = dL[rows[t]] + step
            rn = resid(rows[t], trial)
            cn = np.einsum("ij,ij->i", rn, rn)
            win = np.isfinite(cn) & (cn < cost[t])
            wi = rows[t][win]
            dL[wi] = trial[win]
            res[wi] = rn[win]
            lam[wi] = np.maximum(lam[wi] / 10.0, 1e-12)
            lam[rows[t][~win]] *= 10.0
            accepted[t[win]] = True
        done = np.abs(res[rows]).max(axis=1) <= tol
        conv[rows[done]] = True
        stuck = ~accepted | ~good | (lam[rows] >= 1e10)
        active[rows[done | stuck]] = False
    commands = np.full((N, n), np.nan)
    nominal = np.full((N, n), np.nan)
    if reach.any():
        nominal[reach] = r.upper_lengths(theta[reach])
        commands[reach] = nominal[reach] + dL[reach]
    err = np.hypot(res[:, 0] / w[0], res[:, 1] / w[1])
    err0 = np.hypot(res0[:, 0], res0[:, 1])
    perr = np.abs(res[:, 2] / scale) if has_phi else np.full(N, np.nan)
    for i in np.flatnonzero(reach & ~bad0 & ~conv):
        flags[i].append(f"not converged (predicted residual {np.nanmax(np.abs(res[i])):.2e} m)")
    th_pred = np.full((N, n), np.nan)
    if reach.any():
        rows = np.flatnonzero(reach)
        th_pred[rows] = plant.settle(r, model.p, theta[rows], dL[rows])[0]
        fin = np.isfinite(th_pred[rows]).all(axis=1)
        feas = np.zeros(len(rows), bool)
        inlim = np.zeros(len(rows), bool)
        if fin.any():
            feas[fin] = r.feasible(th_pred[rows[fin]], min_tension=min_tension)
            inlim[fin] = r.within_limits(th_pred[rows[fin]])
        for i, f, li, fi in zip(rows, feas, inlim, fin):
            if not fi:
                flags[i].append("the fitted arm's configuration could not be solved (tension check skipped)")
                continue
            if not f:
                flags[i].append("slack cable: an upper cable tension <= "
                                f"{min_tension:g} N at the predicted configuration")
            if not li:
                flags[i].append("joint limits: the predicted configuration leaves them")
    dL[~reach] = np.nan
    return Compensation(arr.copy(), commands, theta, dL, nominal, conv, err, err0, perr, th_pred,
                        ["; ".join(f) for f in flags], model.name)


def _ik_xy(robot: Robot, xy: np.ndarray, seed: np.ndarray, tol: float = 1e-12, max_iter: int = 100):
    """Nominal IK of positions only: (N, 2) m -> theta (N, n) rad, converged
    (N,). Levenberg–Marquardt with minimal-norm steps from ``seed``."""
    n = robot.n
    N = len(xy)
    th = np.tile(np.asarray(seed, float), (N, 1))
    lam = np.full(N, 1e-3)
    r = xy - robot.fk(th)[:, :2]
    cost = np.einsum("ij,ij->i", r, r)
    conv = np.abs(r).max(axis=1) <= tol
    for _ in range(max_iter):
        act = ~conv & (lam < 1e12)
        if not act.any():
            break
        J = robot.fk_jacobian(th[act])[:, :2, :]
        Jt = np.transpose(J, (0, 2, 1))
        if n >= 2:
            A = J @ Jt + lam[act, None, None] * np.eye(2)
            step = (Jt @ np.linalg.solve(A, r[act][..., None]))[..., 0]
        else:
            A = Jt @ J + lam[act, None, None] * np.eye(n)
            step = np.linalg.solve(A, Jt @ r[act][..., None])[..., 0]
        trial = th[act] + step
        rn = xy[act] - robot.fk(trial)[:, :2]
        cn = np.einsum("ij,ij->i", rn, rn)
        win = cn < cost[act]
        idx = np.flatnonzero(act)
        th[idx[win]], r[idx[win]], cost[idx[win]] = trial[win], rn[win], cn[win]
        lam[idx[win]] = np.maximum(lam[idx[win]] / 10, 1e-12)
        lam[idx[~win]] *= 10
        conv = np.abs(r).max(axis=1) <= tol
    return th, conv
