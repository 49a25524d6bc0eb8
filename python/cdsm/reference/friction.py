"""Coulomb friction of the cables in the holes: independent NumPy reference of
``docs/model.md`` ("Friction in the holes"), written from the document alone;
the reference plant (:mod:`.plant`, both kinds of arm) gives it the cables'
hole points in the base frame.

Units: SI -- m, rad, N, compliance 1/N.  Notation of the document: a cable
ending at disk ``e`` has the hole points ``P = [B_0, A_1, B_1, ..., A_e, B_e]``
(``2e + 1`` points, base frame), segments ``s = 1..2e`` from point ``s - 1`` to
point ``s`` (odd ``s = 2k - 1``: the gap before disk ``k``; even: the traversal
of disk ``k``), the routing ``s = 0`` of length ``L_r`` arriving along the base
frame's ``x``; hole ``i = 0..2e-1`` (the point ``P_i``) joins segments ``i`` and
``i + 1``.  Angles between directions are frame-invariant, so this module takes
them in the base frame (the core maps each pair into a face frame).
"""

from __future__ import annotations

import numpy as np

__all__ = ["segments", "wrap_angles", "profile", "mean_factor", "distal_lengths", "band", "mobilisation_scan",
           "PULL", "RELEASE", "STILL"]

#: A change of a distal length (m) at or below which a hole counts as still (the
#: round-off of a length that did not move).
STILL = 1e-12

#: The mobilisations of the two bounding states of the statics: (position cables, force cables).
PULL = (1.0, -1.0)
RELEASE = (-1.0, 1.0)


def segments(points: np.ndarray):
    """Lengths ``g (N, 2e)`` m and unit directions ``u (N, 2e, d)`` of the segments
    ``s = 1..2e`` of a cable whose hole points are ``points (N, 2e + 1, d)`` m."""
    v = points[:, 1:] - points[:, :-1]
    g = np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(g[..., None] > 0.0, v / np.where(g > 0.0, g, 1.0)[..., None], 0.0)
    return g, u


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The angle between direction vectors ``a``, ``b`` (..., d), rad in [0, pi]."""
    if a.shape[-1] == 2:
        cross = np.abs(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0])
    else:
        cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.arctan2(cross, (a * b).sum(-1))


def wrap_angles(points: np.ndarray) -> np.ndarray:
    """``beta (N, 2e)`` rad: the turn of the cable at each hole ``i = 0..2e-1``,
    the angle between the directions of segments ``i`` and ``i + 1`` (segment 0,
    the routing, along the base frame's ``x``)."""
    _, u = segments(points)
    N, d = points.shape[0], points.shape[-1]
    ex = np.zeros((N, 1, d))
    ex[..., 0] = 1.0
    dirs = np.concatenate([ex, u], axis=1)  # (N, 2e + 1, d): segments 0..2e
    return _angle(dirs[:, :-1], dirs[:, 1:])


def profile(beta: np.ndarray, z: np.ndarray, mu: float) -> np.ndarray:
    """``E (N, 2e + 1)``: tension of segment ``s = 0..2e`` over the routing's,
    ``E_s = exp(-mu sum_{i < s} z_i beta_i)`` (``E_0 = 1``); ``beta``, ``z`` (N, 2e)."""
    cum = np.cumsum(z * beta, axis=1)
    return np.concatenate([np.ones((beta.shape[0], 1)), np.exp(-mu * cum)], axis=1)


def mean_factor(g: np.ndarray, E: np.ndarray, routing: float) -> np.ndarray:
    """``ebar (N,)``: ``(L_r E_0 + sum_s g_s E_s) / (L_r + sum_s g_s)`` (segments
    ``s >= 1`` of lengths ``g (N, 2e)``, ``E (N, 2e + 1)``)."""
    return (routing * E[:, 0] + (g * E[:, 1:]).sum(1)) / (routing + g.sum(1))


def distal_lengths(g: np.ndarray) -> np.ndarray:
    """``d (N, 2e)`` m: the cable's length distal of hole ``i``, ``sum_{s > i} g_s``."""
    return np.cumsum(g[:, ::-1], axis=1)[:, ::-1]


def band(kappa: float, mu: float, tension: np.ndarray, d: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Half-width of the sticking band of each hole, m: ``kappa T_hat d sinh(mu beta)``
    (``tension`` the cable's ``T_hat`` broadcast against ``d``, ``beta``)."""
    return kappa * tension * d * np.sinh(mu * beta)


def mobilisation_scan(d: np.ndarray, w: np.ndarray, d0: np.ndarray) -> np.ndarray:
    """The mobilisation of every hole after each command, ``z (R, H)``.

    ``d (R, H)`` m the distal lengths at each command's configuration, ``w (R, H)``
    m the band half-widths there, ``d0 (H,)`` those of the start (the straight
    pose), where every hole starts at ``z = +1``.  Per command and hole:
    ``z <- clip(z - (d - d_prev) / w, -1, 1)`` when ``w > 0``, ``-sign(d - d_prev)``
    when ``w = 0``; unchanged when ``|d - d_prev| <=`` :data:`STILL`."""
    z = np.ones(d.shape[1])
    prev = np.asarray(d0, float)
    out = np.empty_like(d)
    for j in range(d.shape[0]):
        step = d[j] - prev
        with np.errstate(divide="ignore", invalid="ignore"):
            banded = np.clip(z - step / np.where(w[j] > 0.0, w[j], 1.0), -1.0, 1.0)
        moved = np.where(w[j] > 0.0, banded, -np.sign(step))
        z = np.where(np.abs(step) > STILL, moved, z)
        out[j] = z
        prev = d[j]
    return out
