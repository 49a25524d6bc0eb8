"""The module paths of cdsm 0.1 and 0.2, kept for one release as aliases that warn.

``import cdsm.errors`` (or ``cdsm.errors`` after ``import cdsm``) gives a
module holding the public names of the modules it moved to and emits a
:class:`DeprecationWarning` naming them; names that were renamed on the way
(:data:`RENAMED`) are there under their old names too. One import hook
serves every old path (:data:`MOVED`), so no alias file clutters the package.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from typing import Dict, Tuple

__all__ = ["MOVED", "RENAMED", "install"]

#: old module -> the modules its public names live in now (first wins on a clash)
MOVED: Dict[str, Tuple[str, ...]] = {
    "cdsm.errors": ("cdsm.accuracy.scenarios", "cdsm.accuracy.montecarlo", "cdsm.progress"),
    "cdsm.workspace": ("cdsm.accuracy.workspace", "cdsm.accuracy.sensitivity"),
    "cdsm.statics": ("cdsm.accuracy.statics",),
    "cdsm.tolerance": ("cdsm.accuracy.tolerance", "cdsm.accuracy.sensitivity"),
    "cdsm.design_config": ("cdsm.accuracy.configurations",),
    "cdsm.montecarlo": ("cdsm.accuracy.distributed", "cdsm.accuracy.montecarlo"),
    "cdsm.measurements": ("cdsm.calibration.measurements",),
    "cdsm.diagnose": ("cdsm.calibration.diagnosis", "cdsm.calibration.fit"),
    "cdsm.design": ("cdsm.calibration.experiment",),
    "cdsm.model": ("cdsm.calibration.model", "cdsm.calibration.compensation"),
    "cdsm.diagnose_report": ("cdsm.report.diagnosis",),
    "cdsm.plotting": ("cdsm.report.figures", "cdsm.report.study_figures", "cdsm.report.paper_figures"),
    # cdsm 0.2: one study and one report for both kinds of arm
    "cdsm.spatial_study": ("cdsm.study",),
    "cdsm.report.spatial": ("cdsm.report.study", "cdsm.study"),
    "cdsm.report.spatial_figures": ("cdsm.report.study_figures",),
}

#: old module -> {old name: "module:new name"} for names renamed when they moved
RENAMED: Dict[str, Dict[str, str]] = {
    "cdsm.spatial_study": {"SpatialScenario": "cdsm.study:Scenario",
                           "SpatialScenarioResult": "cdsm.study:ScenarioResult", "SpatialStudy": "cdsm.study:Study"},
    "cdsm.report.spatial_figures": {"slack_figure": "cdsm.report.study_figures:feasibility_figure"},
}


class _AliasLoader(importlib.abc.Loader):
    def create_module(self, spec):
        return None  # the default module object

    def exec_module(self, module) -> None:
        targets = MOVED[module.__name__]
        warnings.warn(f"{module.__name__} is deprecated and will be removed in the next release; "
                      f"use {' and '.join(targets)}", DeprecationWarning, stacklevel=7)
        names = []
        for t in targets:
            mod = importlib.import_module(t)
            for name in getattr(mod, "__all__", ()):
                if name not in module.__dict__:
                    setattr(module, name, getattr(mod, name))
                    names.append(name)
        for old, new in RENAMED.get(module.__name__, {}).items():
            mod, name = new.split(":")
            setattr(module, old, getattr(importlib.import_module(mod), name))
            names.append(old)
        module.__all__ = names
        module.__doc__ = f"Deprecated alias of {', '.join(targets)}."


class _AliasFinder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path, target=None):
        if fullname in MOVED:
            return importlib.machinery.ModuleSpec(fullname, _AliasLoader())
        return None


def install() -> None:
    """Put the alias hook on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _AliasFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _AliasFinder())
