"""Drawings of an arm at a configuration (:meth:`cdsm.Robot.plot`): the
disks, the backbone through the joints and every cable through its holes,
in the plane of a planar arm or in 3-D for a spatial one. Lengths in m.
"""

from __future__ import annotations

from typing import List, Optional

import numpy as np

from ..display import degrees

__all__ = ["cable_paths", "configuration_words", "draw_arm"]

#: Colours of position- and force-controlled cables.
POSITION_COLOUR, FORCE_COLOUR = "#c0392b", "#2471a3"


def cable_paths(robot, theta) -> List[np.ndarray]:
    """Each cable's holes in the base frame at ``theta`` (n,) rad: a list of
    ``(2 end + 1, 3)`` arrays (base face b, then faces a and b of the disks
    it crosses), m."""
    frames = robot.disk_frames(np.asarray(theta, dtype=float).reshape(1, -1))[0]  # (K, 2, 4, 4)
    out = []
    for e, local in zip(robot.cable_ends, robot.holes_by_cable()):
        pts = [local[0]]  # the base face b is the base frame
        for d in range(1, e + 1):
            for f in (0, 1):
                T = frames[d - 1, f]
                pts.append(T[:3, :3] @ local[2 * d - 1 + f] + T[:3, 3])
        out.append(np.array(pts))
    return out


def _disk_outline(T: np.ndarray, radius: float, angles) -> np.ndarray:
    """Points of a disk face of ``radius`` (m) in the frame ``T`` at
    ``angles`` (rad) about its normal (the face's x axis): a spatial face's
    circle, a planar face's diameter across the plane
    (:attr:`cdsm.kinds.Kind.figure`)."""
    a = np.asarray(angles, dtype=float)
    return (T[:3, :3] @ np.stack([np.zeros_like(a), radius * np.cos(a), radius * np.sin(a)]) + T[:3, 3:4]).T


def configuration_words(theta) -> str:
    """The configuration ``theta`` (n,) rad a drawing shows, in degrees: the
    straight arm; every joint at one angle; up to six joints each; more as
    the range they span."""
    deg = [degrees(t) for t in theta]
    if len(set(deg)) == 1:
        return ("straight: " if deg[0] == "0.0" else "") + f"every joint at {deg[0]}°"
    if len(deg) <= 6:
        return "theta = (" + ", ".join(deg) + ")°"
    return f"{len(deg)} joints, theta from {degrees(np.min(theta))}° to {degrees(np.max(theta))}°"


def draw_arm(robot, theta=None, ax=None, cables: bool = True, title: Optional[str] = None):
    """Draw ``robot`` at ``theta`` (n,) rad (default: straight) on ``ax`` (a
    new figure when None; 3-D axes for a spatial arm) and return the axes:
    disks grey, the backbone black, position cables red, force cables blue,
    the end frame's origin marked. Equal axis scales, metres."""
    import matplotlib.pyplot as plt

    theta = np.zeros(robot.n) if theta is None else np.asarray(theta, dtype=float).reshape(-1)
    if theta.shape != (robot.n,):
        from ..inputs import CdsmInputError

        raise CdsmInputError(f"`theta`: expected ({robot.n},) joint angles (rad), got shape {theta.shape}")
    dim, look = robot.kind.dim, robot.kind.figure
    if ax is None:
        fig = plt.figure(figsize=(6.4, 4.8))
        ax = fig.add_subplot(111, projection=look["projection"])
    frames = robot.disk_frames(theta[None])[0]
    radii = robot.radii

    def xy(p):
        return tuple(p[..., i] for i in range(dim))

    # the backbone: base, then faces a and b of each disk
    spine = np.vstack([np.zeros(3)] + [frames[d, f, :3, 3] for d in range(len(frames)) for f in (0, 1)])
    ax.plot(*xy(spine), color="black", lw=1.2, label="backbone")
    ax.plot(*xy(_disk_outline(np.eye(4), radii[0], look["disk_angles"])), color="0.45", lw=look["disk_lw"])
    for d in range(len(frames)):
        for f in (0, 1):
            ax.plot(*xy(_disk_outline(frames[d, f], radii[d + 1], look["disk_angles"])), color="0.45",
                    lw=look["disk_lw"])
    if cables:
        modes = set(robot.position_cables) | set(robot.displacement_cables)  # the commanded ones: red
        seen = set()
        for c, path in enumerate(cable_paths(robot, theta)):
            pos = c in modes
            label = ("position cable" if pos else "force cable") if pos not in seen else None
            seen.add(pos)
            ax.plot(*xy(path), color=POSITION_COLOUR if pos else FORCE_COLOUR, lw=0.9, label=label)
    ax.plot(*xy(spine[-1:]), "o", color="black", ms=4, label="end frame")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if dim == 2:
        ax.set_aspect("equal", adjustable="datalim")
    else:  # 3-D axes: equal scales by a cube of limits
        ax.set_zlabel("z (m)")
        lo, hi = spine.min(axis=0) - radii.max(), spine.max(axis=0) + radii.max()
        mid, half = (lo + hi) / 2, (hi - lo).max() / 2
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_title(f"{robot.name}\n{configuration_words(theta)}" if title is None else title, fontsize=10,
                 parse_math=False)
    ax.legend(loc="best", fontsize=8)
    return ax
