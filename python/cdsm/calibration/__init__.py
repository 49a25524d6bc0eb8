"""Calibration: the gap between the nominal model and a real arm (SI units:
m, rad, N).

=====================  ==========================================================
module                 holds
=====================  ==========================================================
``measurements``       measurement tables (CSV) and the data shipped with cdsm
``plant``              the real arm as the nominal model plus candidate effects;
                       the virtual prototype that makes data from hidden effects
``fit``                least-squares fit of effects to measurements
``diagnosis``          which effect explains the gap, where it lies, how far it shrinks
``experiment``         the next measurements that separate tied candidates
``model``              the plant with fitted parameters (:class:`FittedPlant`) and its file (``cdsm-model``)
``compensation``       cable commands that put the fitted plant's tip on targets
=====================  ==========================================================
"""

from .. import deprecated
from .compensation import Compensation, compensate
from .diagnosis import Diagnosis, diagnose, prepare
from .experiment import Suggestion, suggest
from .fit import Fit, fit
from .measurements import Measurements, packaged, read_csv
from .model import FittedPlant
from .plant import EFFECTS, VirtualPrototype

__all__ = ["Measurements", "read_csv", "packaged", "EFFECTS", "VirtualPrototype", "fit", "Fit",
           "diagnose", "Diagnosis", "prepare", "suggest", "Suggestion", "FittedPlant", "compensate",
           "Compensation"]

#: ``Model`` (cdsm 0.2's name of :class:`FittedPlant`) warns for one release.
__getattr__ = deprecated.module_getattr(__name__, {"Model": "FittedPlant"}, globals())
