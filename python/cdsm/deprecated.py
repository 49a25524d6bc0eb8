"""The module paths of cdsm 0.1 and 0.2, kept for one release as aliases that warn.

``import cdsm.errors`` (or ``cdsm.errors`` after ``import cdsm``) gives a
module holding the public names of the modules it moved to and emits a
:class:`DeprecationWarning` naming them; names that were renamed on the way
(:data:`RENAMED`) are there under their old names too. One import hook
serves every old path (:data:`MOVED`), so no alias file clutters the package.

Names renamed in place (cdsm 0.3: one meaning per name) keep their old
spelling for one release through the helpers below: :func:`module_getattr`
(a module's old names), :func:`renamed_fields` (a class's old attribute and
constructor keyword) and :func:`old_keyword` (a function's old keyword); each
warns with :func:`warn_renamed`.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import functools
import warnings
from typing import Any, Callable, Dict, Mapping, Tuple

__all__ = ["MOVED", "RENAMED", "install", "warn_renamed", "module_getattr", "renamed_fields", "old_keyword"]

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
    # cdsm 0.3: the fitted calibration is a FittedPlant
    "cdsm.model": {"Model": "cdsm.calibration.model:FittedPlant"},
    "cdsm.measurements": {"KIND_CODES": "cdsm.calibration.measurements:READING_CODES"},
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


def warn_renamed(old: str, new: str, stacklevel: int = 3) -> None:
    """The :class:`DeprecationWarning` of a name renamed in place: ``old`` is
    deprecated (one release), use ``new``. ``stacklevel`` 3 points at the
    caller of the function that calls this."""
    warnings.warn(f"{old} is deprecated and will be removed in the next release; use {new}",
                  DeprecationWarning, stacklevel=stacklevel)


def module_getattr(module: str, renamed: Mapping[str, str], namespace: Mapping[str, Any]) -> Callable[[str], Any]:
    """A module ``__getattr__`` serving the old names ``renamed`` ({old: new})
    of ``module`` (its ``__name__``) from ``namespace`` (its ``globals()``),
    each with a :class:`DeprecationWarning`."""
    def __getattr__(name: str):
        if name in renamed:
            warn_renamed(f"{module}.{name}", f"{module}.{renamed[name]}")
            return namespace[renamed[name]]
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    return __getattr__


def renamed_fields(**renamed: str):
    """Class decorator: the old attribute names ``renamed`` ({old: new}) read
    the new ones, and the constructor takes them as keywords, each with a
    :class:`DeprecationWarning`. Giving both the old and the new keyword is a
    :class:`TypeError`."""
    def decorate(cls):
        init = cls.__init__

        @functools.wraps(init)
        def __init__(self, *args, **kwargs):
            for old, new in renamed.items():
                if old in kwargs:
                    warn_renamed(f"{cls.__name__}({old}=...)", f"{cls.__name__}({new}=...)")
                    if new in kwargs:
                        raise TypeError(f"{cls.__name__}: give {new}= only ({old}= is its deprecated name)")
                    kwargs[new] = kwargs.pop(old)
            init(self, *args, **kwargs)

        cls.__init__ = __init__
        for old, new in renamed.items():
            setattr(cls, old, _old_attribute(cls.__name__, old, new))
        return cls
    return decorate


def _old_attribute(owner: str, old: str, new: str) -> property:
    def get(self):
        warn_renamed(f"{owner}.{old}", f"{owner}.{new}")
        return getattr(self, new)
    return property(get, doc=f"Deprecated name of :attr:`{new}` (one release).")


def old_keyword(where: str, old: str, new: str, old_value, value):
    """The value of a renamed keyword argument of ``where``: ``old_value``
    (the deprecated keyword ``old``, given when not None) with a
    :class:`DeprecationWarning`, else ``value`` (keyword ``new``)."""
    if old_value is None:
        return value
    warn_renamed(f"{where}({old}=...)", f"{where}({new}=...)", stacklevel=4)
    return old_value
