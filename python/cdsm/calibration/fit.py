"""Least-squares fit of plant effects to measurements: Levenberg–Marquardt in
parameters scaled by their typical size, parameter uncertainty and the
directions the data cannot see. SI units (m, rad).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..inputs import CdsmInputError
from ..robot import Robot
from . import plant

__all__ = ["Fit", "fit", "free_parameters", "residual_matrix"]


@dataclass
class Fit:
    """A fitted model: effects, the full parameter vector p (P,), free
    parameter names and values, standard deviations, correlation, and fit
    statistics on the rows it saw."""

    effects: List[str]
    p: np.ndarray
    names: List[str]
    values: np.ndarray
    std: np.ndarray
    corr: np.ndarray
    singular: np.ndarray
    rms: float
    ssr: float
    n_obs: int
    aic: float
    bic: float
    converged: bool
    iterations: int

    def params_by_effect(self, robot: Robot) -> Dict[str, List[float]]:
        lay = plant.layout(robot)
        return {e: self.p[lay[e]].tolist() for e in self.effects}

    def std_by_effect(self, robot: Robot) -> Dict[str, List[float]]:
        out, k = {}, 0
        lay = plant.layout(robot)
        for e in self.effects:
            w = lay[e].stop - lay[e].start
            out[e] = self.std[k:k + w].tolist()
            k += w
        return out


def free_parameters(robot: Robot, effects: Sequence[str]):
    """Indices (k,) into the flat plant vector of the parameters of ``effects``,
    their typical sizes (k,) (the fit's scale), names, and non-negativity flags."""
    lay = plant.layout(robot)
    idx, scale, names, nonneg = [], [], [], []
    for e in effects:
        if e not in lay:
            raise CdsmInputError(f"`effects`: unknown effect {e!r}; known: {', '.join(plant.EFFECTS)}")
        sl = lay[e]
        w = sl.stop - sl.start
        idx.extend(range(sl.start, sl.stop))
        scale.extend([plant.TYPICAL[e]] * w)
        names.extend([f"{e}[{j}]" if w > 1 else e for j in range(w)])
        nonneg.extend([e in plant.NON_NEGATIVE] * w)
    return np.array(idx, dtype=int), np.array(scale), names, np.array(nonneg, bool)


def residual_matrix(prep, P: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """(K, 2·len(rows)) prediction minus measurement for parameter sets P (K, P)."""
    obs, conv = plant.predict(prep.robot, P, prep.theta_cmd[rows], prep.meas.dL[rows], prep.kind)
    r = obs[:, :, :2] - prep.meas.measured[rows][None]
    r[~conv] = np.nan
    return r.reshape(len(P), -1)


def fit(prep, effects: Sequence[str], rows: Optional[np.ndarray] = None,
        max_iter: int = 30) -> Fit:
    """Least-squares fit of ``effects`` on ``rows`` (default: all usable) by
    Levenberg–Marquardt in parameters scaled by their typical size; the
    Jacobian by central differences, all parameter sets in one Rust call."""
    robot = prep.robot
    rows = prep.rows if rows is None else np.asarray(rows)
    idx, scale, names, nonneg = free_parameters(robot, effects)
    P0 = np.zeros(plant.size(robot))
    k = len(idx)

    def full(z):
        p = P0.copy()
        p[idx] = z * scale
        return p

    z = np.zeros(k)
    r = residual_matrix(prep, full(z)[None], rows)[0]
    if not np.isfinite(r).all():
        raise CdsmInputError("the nominal model cannot realise some commanded rows")
    cost = float(r @ r)
    lam, it, conv = 1e-3, 0, k == 0
    h = 1e-4
    J = np.zeros((len(r), k))
    while k and it < max_iter:
        it += 1
        sets = [full(z)]
        lo = z - h
        lo[nonneg] = np.maximum(lo[nonneg], 0.0)  # one-sided at the bound
        for j in range(k):
            for v in (lo[j] + 2 * h, lo[j]):
                zz = z.copy()
                zz[j] = v
                sets.append(full(zz))
        R = residual_matrix(prep, np.array(sets), rows)
        J = (R[1::2] - R[2::2]).T / (2 * h)
        if not np.isfinite(J).all():
            J = np.nan_to_num(J)
        g = J.T @ r
        A = J.T @ J
        improved = False
        while lam < 1e12:
            step = np.linalg.solve(A + lam * np.diag(np.maximum(np.diag(A), 1e-12)), -g)
            zn = z + step
            zn[nonneg] = np.maximum(zn[nonneg], 0.0)
            rn = residual_matrix(prep, full(zn)[None], rows)[0]
            cn = float(rn @ rn) if np.isfinite(rn).all() else np.inf
            if cn < cost:
                rel = (cost - cn) / max(cost, 1e-300)
                z, r, cost = zn, rn, cn
                lam = max(lam / 10, 1e-12)
                improved = True
                break
            lam *= 10
        if not improved or rel < 1e-10:
            conv = True
            break
    m = len(r)
    sigma2 = cost / max(m - k, 1)
    if k:
        col = np.maximum(np.linalg.norm(J, axis=0), 1e-300)
        _, sv, vt = np.linalg.svd(J / col, full_matrices=False)
        cov_z = np.linalg.pinv(J.T @ J) * sigma2
        std = np.sqrt(np.maximum(np.diag(cov_z), 0.0)) * scale
        # a parameter with a share in a direction the data cannot see is not
        # determined: its standard deviation is infinite, reported as NaN
        null = vt[sv < 1e-8 * max(sv[0], 1e-300)] if len(sv) else np.zeros((0, k))
        blind = (np.linalg.norm(J, axis=0) == 0) | ((null ** 2).sum(axis=0) > 1e-2)
        std[blind] = np.nan
        d = np.sqrt(np.maximum(np.diag(cov_z), 1e-300))
        corr = cov_z / np.outer(d, d)
    else:
        sv, std, corr = np.zeros(0), np.zeros(0), np.zeros((0, 0))
    ll = m * np.log(max(cost / m, 1e-300))
    return Fit(list(effects), full(z), names, z * scale, std, corr, sv,
               float(np.sqrt(cost / (m / 2))), cost, m, ll + 2 * k, ll + k * np.log(m), conv, it)
