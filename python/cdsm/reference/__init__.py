"""An independent, vectorised NumPy implementation of ``docs/model.md``,
written from the document alone; the tests check the Rust core against it.

``robot``: one description of an arm of either kind (:class:`Robot`) and the
reader of both robot-file forms (:func:`read_robot`).
``kinematics``: forward kinematics, cable lengths, Jacobians, solves, error
scenarios, statics, elasticity and sensitivities of the planar arm.
``plant``: the plant, nominal model plus unmodelled effects (backlash,
actuation, hole clearance, elastic settling, friction in the holes,
observation).
``friction``: Coulomb friction of the cables in the holes (capstan profile,
wrap angles, sticking bands, the mobilisation scan), shared by both plants.
``spatial``: the spatial arms of ``docs/spatial.md`` (robot files, kinematics,
cables, solves, statics); a submodule only (``reference.spatial.fk``), as its
names would shadow the planar ones.
``spatial_plant``: the plant of spatial arms (parameter layout, the moved arm,
backlash, actuation, hole clearance at a 3-D bend, settling, observation
``[x, y, z, rx, ry, rz]``); a submodule only (``reference.spatial_plant.predict``).
"""

from .robot import *  # noqa: F401,F403
from .robot import __all__ as _robot_all
from .kinematics import *  # noqa: F401,F403
from .kinematics import __all__ as _kinematics_all
from .plant import *  # noqa: F401,F403
from .plant import __all__ as _plant_all
from . import friction  # noqa: F401
from . import spatial  # noqa: F401
from . import spatial_plant  # noqa: F401

__all__ = list(_robot_all) + list(_kinematics_all) + list(_plant_all)
