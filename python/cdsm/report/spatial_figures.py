"""Figures of the spatial study (:mod:`cdsm.spatial_study`; matplotlib, Agg,
no pyplot global state).

The 3-D workspace is drawn as three orthogonal projections of the tip
positions (x–y, x–z, y–z, mm): cheaper and easier to read than a 3-D
scatter. Maps colour each tip by a value with the largest |value| drawn on
top, so a projection shows the worst value along each line of sight. The
overview figures use the *main plane*: the two axes along which the tips
spread most. Arrays come from :class:`cdsm.spatial_study.SpatialStudy` in SI
units; the figures show mm and degrees. Every ``*_figure`` function returns a
:class:`matplotlib.figure.Figure`; :func:`all_figures` writes them all.
"""

from __future__ import annotations

import os
from typing import Dict, List, Optional, Tuple

import numpy as np
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..accuracy.montecarlo import MonteCarlo
from ..accuracy.tolerance import pooled_percentile
from .figures import FigureJob, colour_bar, few_ticks, file_key, new_figure, render_jobs, report_style, tight

__all__ = ["AXES", "PLANES", "main_plane", "workspace_figure", "overview_figure", "scenario_figure",
           "monte_carlo_figure", "singular_figure", "slack_figure", "figure_jobs", "all_figures",
           "SCENARIO_COLUMNS"]

AXES = ("x", "y", "z")
#: The three orthogonal projections: (horizontal axis, vertical axis) indices.
PLANES = ((0, 1), (0, 2), (1, 2))
#: Columns of the overview figures: (scenario kind, sign).
SCENARIO_COLUMNS = (("cable", "-"), ("cable", "+"), ("radial", "-"), ("radial", "+"), ("normal", "-"),
                    ("normal", "+"))
_KIND_NAMES = {"cable": "length", "radial": "holes radial", "normal": "holes normal"}


def main_plane(pose: np.ndarray) -> Tuple[int, int]:
    """The two axes (indices, ascending) along which the tip positions
    ``pose`` (N, >= 3) spread most (range)."""
    span = np.ptp(np.asarray(pose)[:, :3], axis=0)
    a, b = sorted(np.argsort(-span, kind="stable")[:2])
    return int(a), int(b)


def _mm(study) -> np.ndarray:
    return study.pose[:, :3] * 1e3


def _map(fig, ax, pts, plane, val, cmap, norm, label, size=7.0, bar=True, order=True):
    """Scatter of ``val`` at the tips ``pts`` (N, 3) mm projected on ``plane``;
    ``order``: True largest |val| last (on top), ``"low"`` smallest on top,
    False as given."""
    i, j = plane
    ok = np.isfinite(val)
    idx = np.flatnonzero(ok)
    if order == "low":
        idx = idx[np.argsort(-val[idx], kind="stable")]
    elif order:
        idx = idx[np.argsort(np.abs(val[idx]), kind="stable")]
    sc = ax.scatter(pts[idx, i], pts[idx, j], c=val[idx], cmap=cmap, norm=norm, s=size, linewidths=0,
                    rasterized=True)
    if bar:
        colour_bar(fig, sc, ax, label, 5)
    return sc


def _axes(ax, plane, equal=True):
    ax.set_xlabel(f"tip {AXES[plane[0]]} (mm)")
    ax.set_ylabel(f"tip {AXES[plane[1]]} (mm)")
    few_ticks(ax, 4)
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3, alpha=0.5)


def _rings(ax, pts, plane, mask, label=None, color="k", size=30):
    if mask.any():
        i, j = plane
        ax.scatter(pts[mask, i], pts[mask, j], s=size, facecolors="none", edgecolors=color, linewidths=0.8,
                   label=label)


def _range(v: np.ndarray) -> Normalize:
    """Colour scale from the smallest to the largest finite value."""
    if not np.isfinite(v).any():
        return Normalize(0.0, 1.0)
    lo, hi = float(np.nanmin(v)), float(np.nanmax(v))
    return Normalize(lo, hi if hi > lo else lo + 1e-12 + abs(lo) * 1e-9)


def _subtitle(study) -> str:
    p = study.params
    return (f"{study.robot.name}: {p['configurations']} configurations sampled in the joint box "
            f"({p['method']}, seed {p['seed']})")


# ---------------------------------------------------------------------------
# workspace
# ---------------------------------------------------------------------------
def workspace_figure(study) -> Figure:
    """The sampled workspace: tip positions (mm) on the three projections,
    coloured by the third coordinate; the straight pose's tip starred."""
    pts = _mm(study)
    tip0 = study.robot.fk(np.zeros(study.robot.n))[:3] * 1e3
    with report_style():
        fig = new_figure(16, 5.2)
        axs = fig.subplots(1, 3)
        for ax, plane in zip(axs, PLANES):
            k = 3 - sum(plane)
            depth = pts[:, k]
            norm = Normalize(depth.min(), depth.max() if np.ptp(depth) > 0 else depth.min() + 1.0)
            _map(fig, ax, pts, plane, depth, "viridis", norm, f"tip {AXES[k]} (mm)", size=6, order=False)
            ax.plot(tip0[plane[0]], tip0[plane[1]], "*", ms=12, mfc="#d62728", mec="k", mew=0.6,
                    label="straight pose")
            ax.plot(0.0, 0.0, "k+", ms=10, mew=1.5, label="base origin")
            _axes(ax, plane)
            ax.set_title(f"{AXES[plane[0]]}–{AXES[plane[1]]} projection")
        axs[0].legend(loc="best", fontsize=8, framealpha=0.85)
        span = np.ptp(pts, axis=0)
        fig.suptitle("Workspace: " + _subtitle(study) + "\nextent "
                     + ", ".join(f"{a} {s:.1f} mm" for a, s in zip(AXES, span)), fontsize=11)
        tight(fig)
    return fig


# ---------------------------------------------------------------------------
# single errors
# ---------------------------------------------------------------------------
def _scenario_value(r, quantity: str) -> np.ndarray:
    return r.position * 1e3 if quantity == "position" else np.degrees(r.rotation)


def overview_figure(study, quantity: str = "position") -> Figure:
    """Every single-error scenario as a thumbnail on the main plane: rows the
    position-controlled cables, columns :data:`SCENARIO_COLUMNS`; colour
    |d(X, Y, Z)| (``quantity="position"``) or the rotation angle
    (``"rotation"``), each thumbnail on its own scale (0 to its max, in the
    title); jump points ringed."""
    pos = study.robot.position_cables
    pts = _mm(study)
    plane = main_plane(study.pose)
    unit = "mm" if quantity == "position" else "deg"
    what = "|d(X, Y, Z)|" if quantity == "position" else "rotation angle"
    with report_style():
        fig = new_figure(2.9 * len(SCENARIO_COLUMNS) + 0.8, 2.75 * len(pos) + 1.0)
        axs = np.atleast_2d(fig.subplots(len(pos), len(SCENARIO_COLUMNS)))  # same limits, set below (no sharing)
        lims = [(pts[:, k].min() - 0.04 * np.ptp(pts[:, k]) - 1e-9, pts[:, k].max() + 0.04 * np.ptp(pts[:, k]) + 1e-9)
                for k in plane]
        sc = None
        for row, c in zip(axs, pos):
            for ax, (kind, sign) in zip(row, SCENARIO_COLUMNS):
                r = study.result(f"{kind}{c + 1}{sign}")
                v = _scenario_value(r, quantity)
                vmax = float(np.nanmax(v)) if np.isfinite(v).any() else 0.0
                sc = _map(fig, ax, pts, plane, v / (vmax if vmax > 0 else 1.0), "viridis", Normalize(0, 1), "",
                          size=4, bar=False)
                _rings(ax, pts, plane, r.jumps.point, size=18)
                ax.set_title(f"{kind}{c + 1}{sign}: max {vmax:.3g} {unit}"
                             + (f", {r.jumps.count} jumps" if r.jumps.count else ""), fontsize=8.5)
        # ticks only on the outer axes: tick artists are the costliest part of a thumbnail
        for (i, j), ax in np.ndenumerate(axs):
            ax.set_xlim(*lims[0])
            ax.set_ylim(*lims[1])
            if i == axs.shape[0] - 1:
                ax.set_xlabel(f"tip {AXES[plane[0]]} (mm)")
                ax.xaxis.set_major_locator(MaxNLocator(3))
            else:
                ax.tick_params(axis="x", which="both", bottom=False, labelbottom=False)
            if j == 0:
                ax.set_ylabel(f"tip {AXES[plane[1]]} (mm)")
                ax.yaxis.set_major_locator(MaxNLocator(3))
            else:
                ax.tick_params(axis="y", which="both", left=False, labelleft=False)
        fig.subplots_adjust(left=0.06, right=0.9, bottom=0.07, top=0.86, wspace=0.06, hspace=0.32)
        if sc is not None:
            cax = fig.add_axes((0.915, 0.25, 0.012, 0.5))
            cb = fig.colorbar(sc, cax=cax)
            cb.set_label(f"{what} / thumbnail max")
        fig.suptitle(f"Single errors, {what} on the {AXES[plane[0]]}–{AXES[plane[1]]} projection — "
                     + _subtitle(study) + "\nrows: position-controlled cables; columns: ±1 mm length, ±0.35 mm "
                     "holes radial, ±0.35 mm holes along the disk normal; black rings: jump points", fontsize=10.5)
    return fig


def scenario_figure(study, key: str) -> Figure:
    """One scenario on the three projections: top row |d(X, Y, Z)| (mm),
    bottom row the rotation angle (deg), one colour scale per row; jump
    points ringed."""
    r = study.result(key)
    pts = _mm(study)
    rows = [(r.position * 1e3, "|d(X, Y, Z)|", "mm", "magma_r"),
            (np.degrees(r.rotation), "rotation", "deg", "cividis_r")]
    with report_style():
        fig = new_figure(15, 9.4)
        axs = fig.subplots(2, 3)
        for ax_row, (v, name, unit, cmap) in zip(axs, rows):
            norm = _range(v)
            for ax, plane in zip(ax_row, PLANES):
                _map(fig, ax, pts, plane, v, cmap, norm, f"{name} ({unit})", bar=plane == PLANES[-1])
                _rings(ax, pts, plane, r.jumps.point, label=f"jump points ({r.jumps.count})")
                _axes(ax, plane)
            ax_row[0].set_title(f"{name}: {np.nanmin(v):.3g} to {np.nanmax(v):.3g} {unit}")
        if r.jumps.count:
            axs[0, 0].legend(loc="best", fontsize=8, framealpha=0.85)
        fig.suptitle(f"{r.scenario.label} ({key}) — {int(r.ok.sum())} of {len(r.ok)} solved\n" + _subtitle(study),
                     fontsize=11)
        tight(fig, "spatial_scenario")
    return fig


# ---------------------------------------------------------------------------
# Monte Carlo
# ---------------------------------------------------------------------------
def _pooled_hist(mc: MonteCarlo) -> Tuple[np.ndarray, np.ndarray]:
    """(edges (B + 1,) m, counts (B,)) of |d(X, Y, Z)| over every converged
    sample, on the study's log bins (the open end bins dropped)."""
    edges = MonteCarlo.hist_edges()
    counts = mc.hist.sum(axis=0)[1:-1]
    return edges, counts


def monte_carlo_figure(study) -> Figure:
    """Monte-Carlo maps and histogram. Top: mean, 95th percentile and max of
    |d(X, Y, Z)| (mm) per configuration on the main plane. Bottom: the 95th
    percentile on the two other projections, and the histogram of
    |d(X, Y, Z)| over every sample with its pooled percentiles."""
    mc = study.monte_carlo
    pts = _mm(study)
    plane = main_plane(study.pose)
    others = [p for p in PLANES if p != plane][:2]
    mean, p95, mx = mc.mean[:, 3] * 1e3, mc.percentile(95.0) * 1e3, mc.max_abs[:, 3] * 1e3
    with report_style():
        fig = new_figure(16, 10)
        axs = fig.subplots(2, 3)
        for ax, (v, nm) in zip(axs[0], ((mean, "mean"), (p95, "95th pct"), (mx, "max"))):
            _map(fig, ax, pts, plane, v, "magma_r", _range(v), f"{nm} |dXYZ| (mm)")
            ax.set_title(f"{nm} |d(X, Y, Z)|: {np.nanmin(v):.3g} to {np.nanmax(v):.3g} mm")
            _axes(ax, plane)
        for ax, pl in zip(axs[1][:2], others):
            _map(fig, ax, pts, pl, p95, "magma_r", _range(p95), "95th pct |dXYZ| (mm)")
            ax.set_title(f"95th pct on the {AXES[pl[0]]}–{AXES[pl[1]]} projection")
            _axes(ax, pl)
        ax = axs[1][2]
        edges, counts = _pooled_hist(mc)
        ax.stairs(counts, edges * 1e3, fill=True, color="#1f5fbf", alpha=0.75)
        ax.set_xscale("log")
        used = np.flatnonzero(counts)
        if used.size:
            ax.set_xlim(edges[max(used[0] - 2, 0)] * 1e3, edges[min(used[-1] + 3, len(edges) - 1)] * 1e3)
        ax.set_xlabel("|d(X, Y, Z)| (mm), every sample")
        ax.set_ylabel("samples per bin")
        for q, ls in ((50.0, ":"), (95.0, "--"), (99.0, "-")):
            v = pooled_percentile(mc, q) * 1e3
            ax.axvline(v, color="k", ls=ls, lw=1.0, label=f"pooled p{q:g} {v:.3g} mm")
        ax.legend(loc="upper left", fontsize=8, framealpha=0.85)
        ax.set_title("histogram over all configurations")
        ax.grid(True, lw=0.3, alpha=0.5)
        p = mc.params
        fig.suptitle(f"Monte Carlo: {p.get('samples')} composite errors per configuration, uniform "
                     f"±{max(p['dl_tol_m']) * 1e3:g} mm per position cable and ±{max(p['dh_tol_m']) * 1e3:g} mm "
                     f"per hole coordinate, seed {p.get('seed')}; failed solves {int(mc.failed.sum())}\n"
                     + _subtitle(study) + "; percentiles to the histogram bin (≤ 3.9 % high)", fontsize=10.5)
        tight(fig)
    return fig


# ---------------------------------------------------------------------------
# singular measure, slack
# ---------------------------------------------------------------------------
def singular_figure(study) -> Figure:
    """sigma_min / sigma_max of the position Jacobian on the three
    projections (log colour; low = near-singular); the lowest ringed red."""
    pts = _mm(study)
    v = study.singular
    good = v[np.isfinite(v) & (v > 0)]
    lo = max(float(good.min()) if good.size else 1e-4, 1e-4)
    hi = max(float(good.max()) if good.size else 1.0, lo * 10)
    i0 = int(np.nanargmin(np.where(np.isfinite(v), v, np.inf)))
    with report_style():
        fig = new_figure(16, 5.2)
        axs = fig.subplots(1, 3)
        for ax, plane in zip(axs, PLANES):
            _map(fig, ax, pts, plane, np.maximum(v, lo), "cividis", LogNorm(lo, hi), "sigma_min / sigma_max",
                 size=6, bar=plane == PLANES[-1], order=False)
            sel = np.zeros(len(v), bool)
            sel[i0] = True
            _rings(ax, pts, plane, sel, color="#d62728", size=90,
                   label=f"lowest {v[i0]:.2g} (theta = " + ", ".join(f"{np.degrees(t):.0f}" for t in study.theta[i0])
                   + " deg)")
            _axes(ax, plane)
        axs[0].legend(loc="best", fontsize=8, framealpha=0.85)
        fig.suptitle("Singular measure: smallest over largest singular value of the position Jacobian "
                     "(directions the arm never moves in left out)\n" + _subtitle(study), fontsize=10.5)
        tight(fig)
    return fig


def slack_figure(study) -> Figure:
    """Statics: the smallest position-cable tension (N) at each configuration
    on the three projections, smallest drawn on top; configurations that need
    a slack cable marked with black crosses."""
    pts = _mm(study)
    t = study.tensions
    least = np.full(len(t), np.nan)
    held = study.feasible & np.isfinite(t).all(axis=1)
    least[held] = t[held].min(axis=1)
    slack = ~study.feasible
    norm = Normalize(float(np.nanmin(least)), float(np.nanmax(least))) if held.any() else Normalize(0, 1)
    with report_style():
        fig = new_figure(16, 5.2)
        axs = fig.subplots(1, 3)
        for ax, plane in zip(axs, PLANES):
            _map(fig, ax, pts, plane, least, "viridis", norm, "smallest position-cable tension (N)", size=6,
                 bar=plane == PLANES[-1], order="low")
            if slack.any():
                i, j = plane
                ax.scatter(pts[slack, i], pts[slack, j], marker="x", s=14, c="k", linewidths=0.8,
                           label=f"slack cable needed ({int(slack.sum())})")
                ax.legend(loc="best", fontsize=8, framealpha=0.85)
            _axes(ax, plane)
        g = study.robot.gravity
        fig.suptitle(f"Statics: {100 * study.feasible_share:.1f} % of the configurations are held with every "
                     f"position cable taut (force cables at their set tension, gravity [{g[0]:g}, {g[1]:g}, "
                     f"{g[2]:g}] m/s², no tip load)\n" + _subtitle(study), fontsize=10.5)
        tight(fig)
    return fig


# ---------------------------------------------------------------------------
# everything
# ---------------------------------------------------------------------------
def figure_jobs(study, detail: bool = True) -> List[FigureJob]:
    """The figures of the study as jobs ``(name, make)``, costliest first;
    ``detail``: also one figure per scenario (``scenario_<key>``)."""
    jobs: List[FigureJob] = []

    def one(name, make):
        jobs.append((name, lambda: [(name, make())]))

    one("scenarios_position", lambda: overview_figure(study, "position"))
    one("scenarios_rotation", lambda: overview_figure(study, "rotation"))
    one("montecarlo", lambda: monte_carlo_figure(study))
    one("workspace", lambda: workspace_figure(study))
    one("singular", lambda: singular_figure(study))
    one("slack", lambda: slack_figure(study))
    if detail:
        for r in study.scenarios:
            one(f"scenario_{file_key(r.scenario.key)}", lambda k=r.scenario.key: scenario_figure(study, k))
    return jobs


def all_figures(study, outdir: "str | os.PathLike[str]", progress: bool = False, workers: Optional[int] = None,
                detail: bool = True) -> Dict[str, str]:
    """Write every figure of the study as ``outdir/<name>.png`` (in forked
    worker processes where the platform forks: :func:`cdsm.report.figures.render_jobs`);
    returns {name: path} in report order."""
    return render_jobs(lambda s: figure_jobs(s, detail), study, outdir, progress=progress, workers=workers)
