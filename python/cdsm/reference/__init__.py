"""An independent, vectorised NumPy implementation of ``docs/model.md`` and
``docs/spatial.md``, written from the documents alone (it never calls the Rust
core); the tests check the core against it.  One reference over both kinds of
arm: every name takes a :class:`Robot` of either kind (or a ``cdsm.Robot`` of a
planar arm, read through :meth:`Robot.like`).

``robot``: the description of an arm (:class:`Robot`), its kind as data
(:class:`Kind`, :data:`KINDS`: the task space, the IK masks, the plant's parameter
layout; the algorithms ask it instead of branching), the reader of both robot-file
forms (:func:`read_robot`) and the planar layout (:class:`PlanarView`).
``rotations``: rotation matrices, the exponential and logarithm of rotation vectors.
``kinematics``: the chain's frames, the task vector (planar ``[x, y, phi]``,
spatial ``[x, y, z, rx, ry, rz]``), Jacobians, cable points, lengths and their
derivatives.
``solve``: the damped least squares, the cable solve, the pose IK, error
scenarios (deviations) and tip sensitivities.
``statics``: the moment balance, tensions (square and minimum-norm above a
floor) and cable elasticity.
``closed_form``: the planar case in closed form (Eq. 4-5 coefficients, the
closed-form cable solve and pose IK).
``plant``: the plant of either kind, the nominal model plus unmodelled effects
(the parameter layouts of ``docs/model.md``, the effects as moves of the arm's
numbers, backlash, actuation, hole clearance, settling, friction, observation).
``friction``: Coulomb friction of the cables in the holes (capstan profile, wrap
angles, sticking bands, the mobilisation scan); ``sequence``: the rows of a data set.
``elastic``: elastic arms (joint springs, cables commanded in displacement through a
series stiffness, slack cables): the forward statics as the minimum of the potential
energy, its derivatives, joint Coulomb friction along a sequence (``ref.elastic.*``).
"""

from .robot import *  # noqa: F401,F403
from .robot import __all__ as _robot_all
from .rotations import *  # noqa: F401,F403
from .rotations import __all__ as _rotations_all
from .kinematics import *  # noqa: F401,F403
from .kinematics import __all__ as _kinematics_all
from .solve import *  # noqa: F401,F403
from .solve import __all__ as _solve_all
from .statics import *  # noqa: F401,F403
from .statics import __all__ as _statics_all
from .closed_form import *  # noqa: F401,F403
from .closed_form import __all__ as _closed_form_all
from .plant import *  # noqa: F401,F403
from .plant import __all__ as _plant_all
from . import elastic, friction  # noqa: F401

__all__ = (list(_robot_all) + list(_rotations_all) + list(_kinematics_all) + list(_solve_all)
           + list(_statics_all) + list(_closed_form_all) + list(_plant_all))
