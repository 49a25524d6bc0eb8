"""cdsm — kinematics and tip-positioning accuracy of cable-driven serpentine
manipulators, with a Rust core. SI units everywhere (m, rad, N, kg)."""

from ._cdsm import CdsmInputError
from .robot import Robot, Solution
from . import errors
from .model import Model

__all__ = ["Robot", "Solution", "CdsmInputError", "errors", "Model"]
__version__ = "0.1.0"
