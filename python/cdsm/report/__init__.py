"""Reports: documents (Markdown and self-contained HTML), figures, and the
reports cdsm writes — the accuracy study of any robot (``cdsm paper``; the
seed paper's sections added for the paper's geometry) and the sim-to-real
diagnosis (``cdsm diagnose --report``). Every report opens with its
headline, then a table of contents.

=====================  ==========================================================
module                 holds
=====================  ==========================================================
``document``           the document model rendered to Markdown and HTML
``figures``            figure helpers shared by the reports (style, layout, colours, the arm)
``study``              the study's report, either kind: text, tables, CSV files
``study_figures``      the study's figures (planar x–y maps, spatial projections)
``paper``              the paper's sections on the study's report (its geometry only)
``paper_figures``      the paper's own figures (Tables 2 and 3, Fig. 12, its loads)
``diagnosis``          the diagnosis report: findings, figures, JSON, CSV
=====================  ==========================================================
"""

from __future__ import annotations

import os
from typing import Dict, Optional

from . import paper as _paper
from . import study as _study

__all__ = ["write", "headline", "report_for"]


def report_for(study, detail: bool = True) -> "_study.StudyReport":
    """The report of ``study``: the paper's (:class:`cdsm.report.paper.PaperReport`)
    for a :class:`cdsm.paper.PaperStudy`, else the study's
    (:class:`cdsm.report.study.StudyReport`)."""
    from ..paper import PaperStudy

    return (_paper.PaperReport if isinstance(study, PaperStudy) else _study.StudyReport)(study, detail)


def write(study, out: "str | os.PathLike[str]", progress: bool = False, detail: bool = True,
          workers: Optional[int] = None, overwrite: bool = False) -> Dict[str, str]:
    """Write the report of ``study`` into ``out``: figures, CSV tables,
    ``report.md`` and ``report.html`` (:meth:`cdsm.report.study.StudyReport.write`:
    refused while another run writes there, or into a directory holding
    files of these names that no cdsm run wrote unless ``overwrite``);
    ``detail``: also one figure per single error. Returns {name: path}."""
    return report_for(study, detail).write(out, progress=progress, workers=workers, overwrite=overwrite)


def headline(study) -> Dict[str, object]:
    """The headline numbers (SI) of ``study`` (and the paper's, for a paper study)."""
    return report_for(study).numbers
