"""Results of the elastic statics (``docs/model.md``, "Elastic arms"): the
frictionless equilibria of :meth:`cdsm.Robot.equilibrium` and their
derivatives by the implicit function theorem
(:meth:`cdsm.Robot.equilibrium_derivatives`). The work is the Rust core's
(``rust/elastic.rs``); this module names what it returns.

SI units: m, rad, N, N m, J.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

import numpy as np

from . import _cdsm
from .display import ShortRepr

__all__ = ["Equilibrium", "EquilibriumDerivatives", "ELASTIC_REASONS", "XTOL"]

#: Why an equilibrium solve ended, by code (:attr:`Equilibrium.reason`).
ELASTIC_REASONS: Tuple[str, ...] = tuple(_cdsm.ELASTIC_REASONS)

#: The default step tolerance of the solve (rad): converged when the
#: unshifted Newton step's largest component is at most this.
XTOL: float = float(_cdsm.ELASTIC_XTOL)


@dataclass(frozen=True, repr=False)
class Equilibrium(ShortRepr):
    """Frictionless equilibria of an elastic arm, one per row of commands
    (1-D fields and scalars for a single row).

    ``theta (N, n)`` rad: the configuration that minimises the potential;
    ``tension (N, m)`` N of every cable (force cables their set tension);
    ``slack (N, m)``: elastic cables at ``sigma <= 0``, carrying nothing;
    ``capped (N, m)``: at ``sigma >= max_tension``; ``converged (N,)``;
    ``reason (N,)`` the words of :data:`ELASTIC_REASONS` (``"converged"``,
    ``"iteration limit"``, ``"line search"``, ``"not finite"``, ``"not a
    minimum"``); ``iterations (N,)``; ``gradient (N,)`` N m, ``max |dU/dq|``
    at the last point evaluated (within ``xtol`` of ``theta``); ``energy (N,)`` J, the potential there.
    """

    theta: np.ndarray
    tension: np.ndarray
    slack: np.ndarray
    capped: np.ndarray
    converged: np.ndarray
    reason: np.ndarray
    iterations: np.ndarray
    gradient: np.ndarray
    energy: np.ndarray

    @classmethod
    def from_core(cls, res, n: int, m: int, single: bool) -> "Equilibrium":
        """The core's ``EquilibriumResult`` with ``n`` joints and ``m`` cables."""
        words = np.array(ELASTIC_REASONS, dtype=object)[np.asarray(res.reason, dtype=np.int64)]
        out = dict(theta=np.asarray(res.theta).reshape(-1, n), tension=np.asarray(res.tension).reshape(-1, m),
                   slack=np.asarray(res.slack).reshape(-1, m), capped=np.asarray(res.capped).reshape(-1, m),
                   converged=np.asarray(res.converged), reason=words, iterations=np.asarray(res.iterations),
                   gradient=np.asarray(res.gradient), energy=np.asarray(res.energy))
        if single:
            out = {k: v[0] for k, v in out.items()}
        return cls(**out)


@dataclass(frozen=True, repr=False)
class EquilibriumDerivatives(ShortRepr):
    """Derivatives of equilibria by the implicit function theorem, ``dq/dp =
    -H^-1 dg/dp`` (``docs/model.md``, "Derivatives"), for ``p`` the commanded
    lengths of the position cables (``*_lengths``, per m), the displacements
    (``*_displacements``, per m) and the kind's tip-wrench rows
    (``*_wrench``, per N or N m): ``theta_* (N, n, p)`` rad, ``task_* (N, t,
    p)`` (the task vector: m, and rad as angular velocities for a spatial
    arm), ``tension_* (N, m, p)`` N. A cable exactly at its slack (or cap)
    transition gives the one-sided derivative of the side its flag says.
    ``definite (N,)``: the Hessian is positive definite (else the row is
    NaN). 2-D fields for a single row.
    """

    theta_lengths: np.ndarray
    theta_displacements: np.ndarray
    theta_wrench: np.ndarray
    task_lengths: np.ndarray
    task_displacements: np.ndarray
    task_wrench: np.ndarray
    tension_lengths: np.ndarray
    tension_displacements: np.ndarray
    tension_wrench: np.ndarray
    definite: np.ndarray

    @classmethod
    def from_core(cls, res, n: int, t: int, m: int, widths: Tuple[int, int, int],
                  single: bool) -> "EquilibriumDerivatives":
        """The core's ``EquilibriumDerivatives``: ``n`` joints, ``t`` task rows, ``m``
        cables, ``widths`` the numbers of lengths, displacements and wrench rows."""
        out = {"definite": np.asarray(res.definite)}
        N = out["definite"].size
        for key, p in zip(("lengths", "displacements", "wrench"), widths):
            for part, rows in (("theta", n), ("task", t), ("tension", m)):
                out[f"{part}_{key}"] = np.asarray(getattr(res, f"{part}_{key}")).reshape(N, rows, p)
        if single:
            out = {k: v[0] for k, v in out.items()}
        return cls(**out)
