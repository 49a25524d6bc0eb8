"""Rotations of space: Rodrigues' formula, the exponential and the principal
logarithm of rotation vectors, and the wrap of an angle (``docs/spatial.md``).

Part of the independent NumPy reference (``cdsm.reference``).  Units: rad;
rotation vectors ``r = angle * axis`` with ``angle`` in ``[0, pi]``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["rotation_matrix", "exp_so3", "log_so3", "wrap_angle"]


def _skew(a: np.ndarray) -> np.ndarray:
    """``[a]x`` ``(..., 3, 3)`` of vectors ``a (..., 3)``."""
    z = np.zeros(a.shape[:-1])
    return np.stack(
        [
            np.stack([z, -a[..., 2], a[..., 1]], -1),
            np.stack([a[..., 2], z, -a[..., 0]], -1),
            np.stack([-a[..., 1], a[..., 0], z], -1),
        ],
        -2,
    )


def rotation_matrix(axis, angle) -> np.ndarray:
    """Rotation ``(..., 3, 3)`` by ``angle (...)`` rad about the unit ``axis (3,)`` or ``(..., 3)``
    (Rodrigues: ``I + sin t [a]x + (1 - cos t) [a]x^2``, evaluated as ``cos t I + sin t [a]x +
    (1 - cos t) a a^T``, the same matrix for a unit ``a`` since ``[a]x^2 = a a^T - I``: a rotation
    about a coordinate axis then has the entries ``cos t``, ``+-sin t`` and 0 of the plane's)."""
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    shape = np.broadcast_shapes(axis.shape[:-1], angle.shape)
    x, y, z = (np.broadcast_to(axis[..., i], shape) for i in range(3))
    c, s = np.cos(angle), np.sin(angle)
    v = 1.0 - c
    R = np.empty(shape + (3, 3))
    R[..., 0, 0], R[..., 0, 1], R[..., 0, 2] = c + x * x * v, x * y * v - z * s, x * z * v + y * s
    R[..., 1, 0], R[..., 1, 1], R[..., 1, 2] = y * x * v + z * s, c + y * y * v, y * z * v - x * s
    R[..., 2, 0], R[..., 2, 1], R[..., 2, 2] = z * x * v - y * s, z * y * v + x * s, c + z * z * v
    return R


def exp_so3(r) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of rotation vectors ``r (..., 3)`` rad.

    ``R = I + A [r]x + B [r]x^2`` with ``A = sin t / t``, ``B = (1 - cos t) / t^2``,
    ``t = |r|``; Taylor series below ``t = 1e-4`` (exact to rounding at 0)."""
    r = np.asarray(r, dtype=float)
    t = np.linalg.norm(r, axis=-1)
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    A = np.where(small, 1.0 - t**2 / 6.0 + t**4 / 120.0, np.sin(ts) / ts)
    B = np.where(small, 0.5 - t**2 / 24.0 + t**4 / 720.0, (1.0 - np.cos(ts)) / ts**2)
    K = _skew(r)
    return np.eye(3) + A[..., None, None] * K + B[..., None, None] * (K @ K)


def log_so3(R) -> np.ndarray:
    """Principal rotation vectors ``(..., 3)`` rad of rotation matrices ``R (..., 3, 3)``.

    ``angle = atan2(|v|, (tr R - 1)/2)`` in ``[0, pi]`` with ``v = vee(R - R^T)/2
    = sin(angle) axis``.  For ``angle <= pi/2`` the vector is ``angle / sin(angle) v``
    (ratio 1 at ``v = 0``).  Beyond, the axis comes from the symmetric part
    ``(R + R^T)/2 - cos(angle) I = (1 - cos(angle)) axis axis^T`` (its largest
    column), with the sign of ``v``; exactly at ``pi`` (``v = 0``) the axis's
    largest component is made positive (both signs are principal logarithms).
    """
    R = np.asarray(R, dtype=float)
    v = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    s = np.linalg.norm(v, axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    angle = np.arctan2(s, c)
    ratio = np.where(s > 0.0, angle / np.where(s > 0.0, s, 1.0), 1.0)
    out = ratio[..., None] * v
    near_pi = c < 0.0
    if np.any(near_pi):
        Rn, vn, cn, an = R[near_pi], v[near_pi], c[near_pi], angle[near_pi]
        B = (0.5 * (Rn + np.swapaxes(Rn, -1, -2)) - cn[:, None, None] * np.eye(3)) / (1.0 - cn)[:, None, None]
        i = np.argmax(np.diagonal(B, axis1=-2, axis2=-1), axis=-1)
        col = B[np.arange(B.shape[0]), :, i]
        axis = col / np.linalg.norm(col, axis=-1, keepdims=True)
        dot = (axis * vn).sum(-1)
        big = np.take_along_axis(axis, np.argmax(np.abs(axis), axis=-1)[:, None], -1)[:, 0]
        flip = (dot < 0.0) | ((dot == 0.0) & (big < 0.0))
        axis = np.where(flip[:, None], -axis, axis)
        out[near_pi] = an[:, None] * axis
    return out


def wrap_angle(x):
    """Wrap angles (rad) to the interval ``(-pi, pi]``."""
    x = np.asarray(x, dtype=float)
    return np.pi - np.mod(np.pi - x, 2.0 * np.pi)
