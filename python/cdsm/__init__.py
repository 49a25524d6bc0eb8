"""cdsm — kinematics and tip-positioning accuracy of cable-driven serpentine
manipulators, with a Rust core. SI units everywhere (m, rad, N, kg).

=====================  ==========================================================
module                 holds
=====================  ==========================================================
``robot``              :class:`Robot` (either kind: kinematics, solves, statics) and :class:`Solution`
``kinds``              the arm's kind as data (:class:`cdsm.kinds.Kind`: task axes, masks, quantities, words)
``spatial``            the spatial kind's constants (``kind = "spatial"``: 3-D joints and holes)
``accuracy``           error studies of the nominal model (scenarios, Monte Carlo, tolerances)
``calibration``        the gap to a real arm (measurements, plant, diagnosis, compensation)
``study``              the accuracy study of any robot, either kind (``cdsm paper``)
``paper``              the seed paper's layer on the study (its tables, claims, loads)
``report``             Markdown/HTML reports and figures
``cli``                the ``cdsm`` command
``interop``            other tools' descriptions: CASPR models in, MuJoCo MJCF and URDF out
``reference``          an independent NumPy implementation the tests check the core against
=====================  ==========================================================
"""

import importlib as _importlib

from . import deprecated as _deprecated
from ._cdsm import CdsmInputError
from .calibration.model import FittedPlant
from .inputs import CdsmDataWarning
from .robot import Robot, Solution

__all__ = ["Robot", "Solution", "CdsmInputError", "CdsmDataWarning", "FittedPlant", "accuracy", "calibration", "report"]
__version__ = "0.2.0"

_deprecated.install()


def __getattr__(name: str):
    """Subpackages on first use, and the 0.1 and 0.2 names (deprecated aliases)."""
    if name == "SpatialRobot":
        import warnings

        warnings.warn("cdsm.SpatialRobot is cdsm.Robot now (one class of either kind); use cdsm.Robot",
                      DeprecationWarning, stacklevel=2)
        return Robot
    if name == "Model":
        _deprecated.warn_renamed("cdsm.Model", "cdsm.FittedPlant")
        return FittedPlant
    if name in ("accuracy", "calibration", "report", "paper", "study", "reference", "cli", "interop") \
            or f"cdsm.{name}" in _deprecated.MOVED:
        return _importlib.import_module(f"cdsm.{name}")
    raise AttributeError(f"module 'cdsm' has no attribute {name!r}")
