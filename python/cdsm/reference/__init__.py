"""An independent, vectorised NumPy implementation of ``docs/model.md``,
written from the document alone; the tests check the Rust core against it.

``kinematics``: forward kinematics, cable lengths, Jacobians, solves, error
scenarios, statics, elasticity and sensitivities of the planar arm.
"""

from .kinematics import *  # noqa: F401,F403
from .kinematics import __all__ as _kinematics_all

__all__ = list(_kinematics_all)
