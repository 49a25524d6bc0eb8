"""Reports: documents (Markdown and self-contained HTML), figures, and the two
reports cdsm writes — the seed paper's study (``cdsm paper``) and the
sim-to-real diagnosis (``cdsm diagnose --report``).

=====================  ==========================================================
module                 holds
=====================  ==========================================================
``document``           the document model rendered to Markdown and HTML
``figures``            figure helpers shared by the reports (style, colours, the arm)
``paper_figures``      the figures of the paper study
``paper``              the paper report: text, tables, CSV files
``diagnosis``          the diagnosis report: findings, figures, JSON, CSV
=====================  ==========================================================
"""

from .paper import headline, write

__all__ = ["write", "headline"]
