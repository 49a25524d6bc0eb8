"""Spatial arms (``kind = "spatial"``, ``docs/spatial.md``) are robots like
any other: :class:`cdsm.Robot` reads them (:meth:`cdsm.Robot.from_toml`,
:meth:`cdsm.Robot.packaged`: ``paper_spatial``, ``two_universal``,
``sjtu_snake``) and its kind says what they are. Their task-space vector is
``[x, y, z, rx, ry, rz]``: the end frame's origin (m) and its rotation as a
rotation vector (rad).

``SpatialRobot``, the class of cdsm 0.2, is :class:`cdsm.Robot` now (a
deprecated alias: it goes in the next release).
"""

from __future__ import annotations

import warnings

from .kinds import SPATIAL
from .robot import SPATIAL_MASKS, Robot

__all__ = ["SPATIAL_MASKS", "TASK"]

#: Task-space width of a spatial arm: x, y, z (m), rotation vector (rad) (the spatial kind's).
TASK = SPATIAL.task


def __getattr__(name: str):
    if name == "SpatialRobot":
        warnings.warn("cdsm.spatial.SpatialRobot is cdsm.Robot now (one class of either kind); "
                      "use cdsm.Robot", DeprecationWarning, stacklevel=2)
        return Robot
    raise AttributeError(f"module 'cdsm.spatial' has no attribute {name!r}")
