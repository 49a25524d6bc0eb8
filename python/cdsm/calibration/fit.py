"""Least-squares fit of plant effects to measurements, in the Rust core: the
shared Levenberg–Marquardt (QR step, Marquardt damping) in parameters scaled
by their typical size, within the physical domain, with the exact Jacobian of
the plant; cross-validation folds in one call. Here: what the fit means —
parameter uncertainty, correlations and the directions the data cannot see.
SI units (m, rad).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..inputs import CdsmInputError, as_array, as_iterations
from ..robot import Robot
from . import plant
from ..display import ShortRepr

__all__ = ["Fit", "fit", "fit_folds", "free_parameters", "FIT_ITERATIONS"]

#: Trial steps of one fit.
FIT_ITERATIONS = 30


@dataclass(repr=False)
class Fit(ShortRepr):
    """A fitted model: effects, the full parameter vector p (P,), free
    parameter names and values, standard deviations (NaN: not determined by
    the data), correlation, singular values of the column-scaled Jacobian,
    fit statistics on the rows it saw (``rms`` per axis, m; ``ssr`` m²;
    ``n_obs`` residual components; AIC, BIC), and its predictions of every
    row (``prediction`` (N, 3), ``predicted`` (N,) settled). ``std``,
    ``corr`` and ``singular`` are ``None`` where not computed (a
    cross-validation fold's fit: :func:`fit_folds`)."""

    effects: List[str]
    p: np.ndarray
    names: List[str]
    values: np.ndarray
    std: Optional[np.ndarray]
    corr: Optional[np.ndarray]
    singular: Optional[np.ndarray]
    rms: float
    ssr: float
    n_obs: int
    aic: float
    bic: float
    converged: bool
    iterations: int
    prediction: np.ndarray = field(default=None, repr=False)
    predicted: np.ndarray = field(default=None, repr=False)

    def params_by_effect(self, robot: Robot) -> Dict[str, List[float]]:
        """{effect: fitted values} (SI)."""
        return {e: self.p[plant.effect_indices(robot, e)].tolist() for e in self.effects}

    def std_by_effect(self, robot: Robot) -> Dict[str, List[float]]:
        """{effect: 1-sigma of each value} (SI; NaN: not determined)."""
        out, k = {}, 0
        for e in self.effects:
            w = len(plant.effect_indices(robot, e))
            out[e] = self.std[k:k + w].tolist()
            k += w
        return out


def free_parameters(robot: Robot, effects: Sequence[str]):
    """Indices (k,) into the flat plant vector of the parameters of
    ``effects``, their typical sizes (k,) (the fit's unit) and names."""
    idx = [int(i) for e in effects for i in plant.effect_indices(robot, e)]
    names = plant.parameter_names(robot, idx)
    scale = [plant.TYPICAL[b] for b, _ in plant.parameter_blocks(robot, idx)]
    return np.array(idx, dtype=int), np.array(scale, dtype=float), names


def fit_folds(prep, effects: Sequence[str], scored: np.ndarray, start: Optional[np.ndarray] = None,
              max_iter: int = FIT_ITERATIONS, uncertainty=True) -> List[Fit]:
    """One fit of ``effects`` per row of ``scored`` ((F, N) bool over the
    prepared rows, file order: the rows each fit trains on), from the flat
    parameters ``start`` (default zeros), all in one call of the Rust core
    (folds in parallel; the rows run in the prepared execution order).
    ``uncertainty`` (bool, or (F,) bool per fit): the fits whose standard
    deviations, correlation and singular values are computed (an SVD and a
    pseudo-inverse of the Jacobian each); the others carry ``None`` there
    (cross-validation folds need only their predictions)."""
    sc = np.atleast_2d(np.asarray(scored, bool))
    return fit_candidates(prep, [effects], sc, np.zeros(len(sc), int), start, max_iter, uncertainty)


def fit_candidates(prep, candidates: Sequence[Sequence[str]], scored: np.ndarray, candidate: Sequence[int],
                   start: Optional[np.ndarray] = None, max_iter: int = FIT_ITERATIONS,
                   uncertainty=True) -> List[Fit]:
    """:func:`fit_folds` of several candidates in one call of the Rust core:
    fit ``f`` fits the effects ``candidates[candidate[f]]`` on the rows
    ``scored[f]`` ((F, N) bool). The fits run in parallel, each worker
    thread taking the next fit not yet taken; a fit's result does not
    depend on the others or on the threads."""
    robot = prep.robot
    free = [free_parameters(robot, effects) for effects in candidates]
    sc = np.atleast_2d(np.asarray(scored, bool))
    if sc.shape[1] != len(prep.theta_cmd):
        raise CdsmInputError(f"`scored`: expected (F, {len(prep.theta_cmd)}) flags, got {sc.shape}")
    which = np.asarray(candidate, int).reshape(-1)
    if len(which) != len(sc) or ((which < 0) | (which >= len(candidates))).any():
        raise CdsmInputError(f"`candidate`: expected {len(sc)} indices into the {len(candidates)} candidates, "
                             f"got {which.tolist()}")
    p0 = np.zeros(plant.size(robot)) if start is None else as_array("start", start)
    o = prep.order
    raw = robot.core.plant_fit(np.ascontiguousarray(prep.theta_cmd[o]), np.ascontiguousarray(prep.dL[o]),
                               prep.reading_codes[o].tolist(), np.ascontiguousarray(prep.measured[o]),
                               sc[:, o].reshape(-1).tolist(), [int(i) for f in free for i in f[0]],
                               [float(v) for f in free for v in f[1]], np.ascontiguousarray(p0, float), 1e-12, 100,
                               as_iterations("max_iter", max_iter), robot.threads,
                               [len(f[0]) for f in free], which.tolist())
    want = np.broadcast_to(np.asarray(uncertainty, bool), (len(raw),))
    return [_summary(list(candidates[c]), *free[c], r, o, plant.width(robot), bool(u))
            for r, u, c in zip(raw, want, which)]


def fit(prep, effects: Sequence[str], rows: Optional[np.ndarray] = None, start: Optional[np.ndarray] = None,
        max_iter: int = FIT_ITERATIONS) -> Fit:
    """Fit ``effects`` on ``rows`` (file-order indices; default: all usable
    rows) from ``start`` (flat, default the prepared start)."""
    start = getattr(prep, "start", None) if start is None else start
    scored = np.zeros(len(prep.theta_cmd), bool)
    scored[prep.rows if rows is None else np.asarray(rows, int)] = True
    return fit_folds(prep, effects, scored[None], start, max_iter)[0]


def _summary(effects, idx, scale, names, r, order, width: int, uncertainty: bool = True) -> Fit:
    """Uncertainty (``uncertainty``: else ``None``) and statistics of one fit from its Jacobian (m, k) in scaled
    parameters (given as the triangular factor R of its QR, which has the same
    ``J^T J`` and singular values): covariance ``sigma^2 (J^T J)^+`` with ``sigma^2 = ssr/(m - k)``;
    a parameter with a share in a direction the data cannot see (a singular
    value below 1e-8 of the largest, columns scaled to unit norm) has no
    determined value: its standard deviation is NaN. A fit that could not be
    evaluated at all (no finite Jacobian) determines nothing: every standard
    deviation and correlation NaN."""
    k, m = len(idx), int(r.m)
    cost = float(r.cost)
    p = np.array(r.p)
    z = p[idx] / scale if k else np.zeros(0)
    J = np.asarray(r.r_factor).reshape(-1, k) if k else np.zeros((0, 0))  # R of J = QR: same J^T J
    if not uncertainty:
        sv = std = corr = None
    elif k and m and J.size and np.isfinite(J).all() and np.isfinite(cost):
        sigma2 = cost / max(m - k, 1)
        col = np.maximum(np.linalg.norm(J, axis=0), 1e-300)
        # full V: with fewer rows than parameters the directions beyond the
        # rank are the data's blind ones too
        _, sv, vt = np.linalg.svd(J / col, full_matrices=True)
        cov_z = np.linalg.pinv(J.T @ J) * sigma2
        std = np.sqrt(np.maximum(np.diag(cov_z), 0.0)) * scale
        null = np.vstack([vt[:len(sv)][sv < 1e-8 * max(sv[0], 1e-300)] if len(sv) else np.zeros((0, k)),
                          vt[len(sv):]])
        blind = (np.linalg.norm(J, axis=0) == 0) | ((null ** 2).sum(axis=0) > 1e-2)
        std[blind] = np.nan
        d = np.sqrt(np.maximum(np.diag(cov_z), 1e-300))
        # |cov_ij| <= d_i d_j in exact arithmetic; the pseudo-inverse of a
        # rank-deficient fit can break it by rounding where d is ~0: such a
        # correlation is undetermined (NaN), not an overflow
        with np.errstate(over="ignore", invalid="ignore"):
            corr = cov_z / d[:, None] / d[None, :]
        corr = np.where(np.abs(corr) <= 1.0 + 1e-9, np.clip(corr, -1.0, 1.0), np.nan)
    elif k and m:
        sv, std, corr = np.zeros(0), np.full(k, np.nan), np.full((k, k), np.nan)
    else:
        sv, std, corr = np.zeros(0), np.zeros(k), np.zeros((k, k))
    ll = m * np.log(max(cost / max(m, 1), 1e-300))
    pe = np.asarray(r.prediction.observation).reshape(-1, width)
    oe = np.asarray(r.prediction.converged, bool)
    pred, ok = np.empty_like(pe), np.empty_like(oe)
    if len(pe):
        pred[order], ok[order] = pe, oe
    return Fit(effects, p, names, z * scale, std, corr, sv,
               float(np.sqrt(cost / max(m / 2, 1))), cost, m, ll + 2 * k, ll + k * np.log(max(m, 1)),
               bool(r.converged), int(r.iterations), pred if len(pred) else None, ok if len(ok) else None)
