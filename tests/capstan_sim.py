"""An independent quasi-static simulation of a planar cable-driven arm with
Coulomb friction in its holes, written from first principles for the tests of
``docs/model.md`` ("Friction in the holes"): it shares no code with the plant
(neither the core's nor the NumPy reference's).

Physics (SI: m, rad, N, 1/N):

* geometry: the frames of Eq. (1)-(2) and every cable's hole points in the base
  frame; a cable is a chain of straight segments (the routing behind the base,
  then gap, traversal, gap, ... to its anchor);
* capstan at every hole: the cable slides through it (full slip), toward its
  proximal end where the cable's length distal of the hole shrinks over the
  step (the proximal side then pulls harder by ``exp(mu beta)``, ``beta`` the
  turn of the cable there), distally where it grows; a hole whose distal
  length does not move keeps its state, every hole starting as if hauled
  toward its actuator;
* statics: the part distal of a cut just past joint ``k`` is held by the
  cables crossing the cut, each with its tension in that gap, pulling at its
  hole on disk ``k`` toward the previous disk's hole (no gravity, no tip load);
  force cables carry their weight at the proximal end;
* one compliance ``k`` per cable: each segment of rest length ``l`` under
  tension ``T`` is ``l (1 + k T)`` long, whatever causes ``T``; a position
  cable's actuator fixes the cable's whole rest length (routing included);
* the controller commands each position cable's rest length: the rigid
  model's length of the commanded configuration (no feed-forward), or the
  rest length at which a frictionless cable of compliance ``k_ff`` would hold
  the arm there (the stretch fed forward from the commanded configuration);
* quasi-static sequence: every command settles from the previous state.

Full slip is exact Coulomb where a step moves every hole's distal length by
more than its sticking band (micrometres on the nylon paper arm); the commands
of the tests move them by millimetres, which :func:`simulate` checks.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares


def _rot(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s], [s, c]])


class CapstanArm:
    """The planar arm of ``robot`` (a ``cdsm.Robot`` of kind planar, read for its
    numbers only) with cable compliance ``k`` (1/N) and friction ``mu``."""

    def __init__(self, robot, k: float, mu: float):
        self.n = robot.n
        self.lb = np.asarray(robot.link_before, float)
        self.la = np.asarray(robot.link_after, float)
        self.th = np.asarray(robot.thickness, float)
        self.holes = np.asarray(robot.holes, float)  # (2n, n+1, 2, 2)
        self.weight = np.asarray(robot.lower_tension, float)
        self.route = float(robot.routing_length)
        if np.any(np.asarray(robot.gravity, float) != 0.0):
            raise ValueError("the simulation has no gravity")
        self.k, self.mu = float(k), float(mu)

    # -- geometry ---------------------------------------------------------
    def frames(self, theta):
        """Per disk k = 1..n: (R, t) of face a and face b, and joint k's position."""
        R, t = np.eye(2), np.zeros(2)
        out = []
        for k in range(self.n):
            joint = t + R @ np.array([self.lb[k], 0.0])
            R = R @ _rot(theta[k])
            ta = joint + R @ np.array([self.la[k], 0.0])
            tb = ta + R @ np.array([self.th[k], 0.0])
            out.append((R, ta, tb, joint))
            t = tb
        return out

    def points(self, theta, c):
        """Hole points ``[B_0, A_1, B_1, ..., A_e, B_e]`` of cable ``c`` (base frame)."""
        e = c // 2 + 1
        fr = self.frames(theta)
        pts = [self.holes[c, 0, 1]]
        for k in range(1, e + 1):
            R, ta, tb, _ = fr[k - 1]
            pts.append(ta + R @ self.holes[c, k, 0])
            pts.append(tb + R @ self.holes[c, k, 1])
        return np.array(pts)

    def segments(self, theta, c):
        """Lengths ``g`` (routing first) and wrap angles ``beta`` at the holes."""
        P = self.points(theta, c)
        v = np.diff(P, axis=0)
        g = np.linalg.norm(v, axis=1)
        u = np.vstack([[1.0, 0.0], v / g[:, None]])
        cross = u[:-1, 0] * u[1:, 1] - u[:-1, 1] * u[1:, 0]
        beta = np.arctan2(np.abs(cross), (u[:-1] * u[1:]).sum(1))
        return np.concatenate([[self.route], g]), beta

    def distal(self, theta, c):
        """The cable's geometric length distal of each hole (m)."""
        g, _ = self.segments(theta, c)
        return np.cumsum(g[::-1])[::-1][1:]

    # -- statics ----------------------------------------------------------
    def gap_factors(self, beta, z):
        """Tension of every segment (routing first) over the routing's."""
        return np.concatenate([[1.0], np.exp(-self.mu * np.cumsum(z * beta))])

    def routing_tensions(self, theta, z):
        """Every cable's tension behind the base (position cables from the balance)."""
        fr = self.frames(theta)
        m = 2 * self.n
        M = np.zeros((self.n, m))  # moment about joint k of cable c's unit routing tension
        for c in range(m):
            P = self.points(theta, c)
            _, beta = self.segments(theta, c)
            E = self.gap_factors(beta, z[c])
            for k in range(1, c // 2 + 2):
                A, B = P[2 * k - 1], P[2 * k - 2]
                e = (B - A) / np.linalg.norm(B - A)
                r = A - fr[k - 1][3]
                M[k - 1, c] = E[2 * k - 1] * (r[0] * e[1] - r[1] * e[0])
        T = np.zeros(m)
        T[1::2] = self.weight
        T[0::2] = np.linalg.solve(M[:, 0::2], -M[:, 1::2] @ T[1::2])
        return T

    def rest_lengths(self, theta, z):
        """The rest length each position cable needs to lie along ``theta`` (m, routing included)."""
        T0 = self.routing_tensions(theta, z)
        out = np.empty(self.n)
        for i in range(self.n):
            g, beta = self.segments(theta, 2 * i)
            out[i] = (g / (1.0 + self.k * T0[2 * i] * self.gap_factors(beta, z[2 * i]))).sum()
        return out

    def rigid_lengths(self, theta):
        """The rigid model's position-cable lengths along the arm (m)."""
        return np.array([self.segments(theta, 2 * i)[0][1:].sum() for i in range(self.n)])

    # -- the sequence -----------------------------------------------------
    def settle(self, rest, seed, z):
        sol = least_squares(lambda th: (self.rest_lengths(th, z) - rest) * 1e3, seed, xtol=1e-15,
                            ftol=1e-15, gtol=1e-15, method="lm")
        if np.abs(sol.fun).max() > 1e-9:
            raise RuntimeError(f"the simulation did not settle: {np.abs(sol.fun).max() * 1e-3} m")
        return sol.x


def simulate(robot, k: float, mu: float, theta_cmd, dL=None, feed_forward: float = 0.0, ratio: float = 3.0):
    """Tip positions ``(N, 3)`` (x, y m; phi rad) of ``robot`` (planar) strung with a
    cable of compliance ``k`` (1/N) and friction ``mu`` after each command
    ``theta_cmd (N, n)`` rad in order (plus the extra rest lengths ``dL (N, n)`` m of
    the position cables), commanded with the rigid model's lengths
    (``feed_forward = 0``) or with the frictionless stretch of a cable of
    compliance ``feed_forward`` (1/N) fed forward from the commanded
    configuration.  Raises where a step moves some hole's distal length by less
    than ``ratio`` times its sticking band (full slip would not be exact there;
    the last hole, whose distal length is fixed, keeps its start state)."""
    arm = CapstanArm(robot, k, mu)
    ff = CapstanArm(robot, feed_forward, 0.0)
    n, m = arm.n, 2 * arm.n
    z = [np.ones(2 * (c // 2 + 1)) for c in range(m)]
    prev = np.zeros(n)
    theta_cmd = np.asarray(theta_cmd, float)
    dL = np.zeros_like(theta_cmd) if dL is None else np.asarray(dL, float)
    out = []

    def directions(theta):
        dirs = []
        for c in range(m):
            step = arm.distal(theta, c) - arm.distal(prev, c)
            dirs.append(np.where(np.abs(step) > 1e-12, -np.sign(step), z[c]))
        return dirs

    for tc, extra in zip(theta_cmd, dL):
        rest = ff.rest_lengths(tc, z) + extra
        theta = tc.copy()
        for _ in range(20):
            znew = directions(theta)
            theta = arm.settle(rest, theta, znew)
            if all(np.array_equal(a, b) for a, b in zip(znew, directions(theta))):
                break
        else:
            raise RuntimeError("the sliding directions did not settle")
        T0 = arm.routing_tensions(theta, znew)
        for c in range(m):
            # the band: the distal part's stretch across the capstan cone, k 2 T sinh(mu beta) d
            _, beta = arm.segments(theta, c)
            T = T0[c] * arm.gap_factors(beta, znew[c])[1:]
            d = arm.distal(theta, c)
            band = arm.k * 2.0 * np.abs(T) * np.sinh(arm.mu * beta) * d
            step = np.abs(d - arm.distal(prev, c))
            if np.any((step < ratio * band)[:-1]):
                worst = np.min((step / band)[:-1])
                raise ValueError(f"cable {c}: a hole's distal length moved by {worst:.3g} x its band, "
                                 f"less than {ratio}")
        z, prev = znew, theta
        R, _, tb, _ = arm.frames(theta)[-1]
        out.append([tb[0], tb[1], theta.sum()])
    return np.array(out)
