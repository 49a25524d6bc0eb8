"""The seed paper's own figures (matplotlib, Agg, no pyplot global state),
drawn only for a study of the paper's geometry (:class:`cdsm.paper.PaperStudy`):
the four load readings, the configuration diagrams of Table 2, the singular
state of Fig. 12, Table 3 measured vs ours vs the paper, and the paper's
marks on the workspace figure (its experimental range, the Table 3 points).
The study's general figures are :mod:`cdsm.report.study_figures`.

Arrays in SI units (m, rad); the figures show mm and degrees as the paper
does. In the configuration diagrams the arm before the error is blue, after
it red.
"""

from __future__ import annotations

from typing import Dict, List, Optional, Tuple

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from ..accuracy.scenarios import deviation
from .figures import (BLUE, HUES, MAX_WIDTH_IN, RED, FigureJob, colour_bar, draw_arm, few_ticks, mark_missing,
                      new_figure, place, report_style, tension_cmap)

__all__ = ["readings_figure", "table2_figures", "table2_groups", "share_range", "singular_state_figure",
           "table3_figure", "workspace_overlay", "figure_jobs", "spread", "EXAGGERATION", "LABEL_COLUMN_MM",
           "LABEL_GAP_MM"]

W = MAX_WIDTH_IN


def _axes_mm(ax, equal=False):
    ax.set_xlabel("tip X (mm)")
    ax.set_ylabel("tip Y (mm)")
    few_ticks(ax, 4)
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True)


def _scatter(fig, ax, xy, val, cmap, norm, label, size=6, order=True, bar=True):
    ok = np.isfinite(val)
    idx = np.flatnonzero(ok)
    if order:
        idx = idx[np.argsort(np.abs(val[idx]), kind="stable")]
    sc = ax.scatter(xy[idx, 0], xy[idx, 1], c=val[idx], cmap=cmap, norm=norm, s=size, linewidths=0, rasterized=True)
    if bar:
        colour_bar(fig, sc, ax, label, 5)
    return sc


def readings_figure(study) -> Figure:
    """The four load readings (weight order x plane) over the ±30° joint
    grid, one row each: left the smallest upper tension (N; negative red,
    zero grey; black rings need a slack cable); right the tip deviation
    |d(X, Y)| (µm) the elastic cables cause when the rigid model's lengths
    are commanded (crosses: slack, no taut solution)."""
    names = list(study.readings)
    rows = len(names)
    with report_style():
        fig = new_figure(W, 3.7 * rows + 0.6)
        axs = np.atleast_2d(fig.subplots(rows, 2, sharex=True, sharey=True))
        tmins = [np.nanmin(r.feasibility.tension, axis=1) for r in study.readings.values()]
        lim = max(float(np.nanmax(np.abs(t))) for t in tmins)
        el = [np.hypot(r.elastic[:, 0], r.elastic[:, 1]) * 1e6 for r in study.readings.values()]
        emax = max((float(np.nanmax(e)) for e in el if np.isfinite(e).any()), default=1.0)
        for j, (name, r) in enumerate(study.readings.items()):
            fm = r.feasibility
            xy = fm.pose[:, :2] * 1e3
            slack = ~fm.feasible
            w = "/".join(f"{v:.0f}" for v in r.weights_g)
            ax = axs[j, 0]
            _scatter(fig, ax, xy, tmins[j], tension_cmap(), Normalize(-lim, lim), "smallest upper tension (N)",
                     order=False)
            if slack.any():
                ax.scatter(xy[slack, 0], xy[slack, 1], s=9, facecolors="none", edgecolors="k", linewidths=0.4)
            plane = "vertical plane" if np.any(r.robot.gravity) else "horizontal plane"
            ax.set_title(f"{name}: {plane}, {w} g\nslack cable needed at {100 * fm.slack_fraction:.1f} %",
                         fontsize=9)
            _axes_mm(ax)
            ax = axs[j, 1]
            mark_missing(ax, xy[slack], size=4)
            _scatter(fig, ax, xy, el[j], "viridis", Normalize(0, emax), "elastic |d(X, Y)| (µm)")
            mx = float(np.nanmax(el[j])) if np.isfinite(el[j]).any() else float("nan")
            ax.set_title("elastic cables: max " + (f"{mx:.0f} µm" if np.isfinite(mx) else "— (all slack)")
                         + "\n(taut configurations; crosses: slack)", fontsize=9)
            _axes_mm(ax)
        for ax in axs.ravel():
            ax.label_outer()
        fig.suptitle("The paper's loads, four readings, over the ±30° joint grid (E A of the robot file's cable)",
                     fontsize=10.5)
        place(fig, rows, 2, left=0.75, right=0.95, bottom=0.5, top=0.85, wgap=1.2, hgap=0.7)
    return fig


# ---------------------------------------------------------------------------
# Table 2 and Fig. 12: configuration diagrams
# ---------------------------------------------------------------------------
#: The joint-angle change is drawn this many times larger where it is small.
EXAGGERATION = 10.0


def _diagram(ax, robot, theta0, theta, ok, title, target=None, dS=None):
    draw_arm(ax, robot, theta0, BLUE, label="before the error")
    if ok:
        draw_arm(ax, robot, theta, RED, lw=1.6, label="after the error")
        if np.degrees(np.abs(theta - theta0).max()) * EXAGGERATION <= 30.0:
            ex = theta0 + EXAGGERATION * (theta - theta0)
            draw_arm(ax, robot, ex, RED, ls="--", lw=1.1, disks=False, alpha=0.75,
                     label=f"after, angle change ×{EXAGGERATION:g}")
        else:
            ax.plot([], [], ls="--", color=RED, label="(no ×10 view: change already large)")
    else:
        ax.text(0.5, 0.04, "no configuration after this error\n(the cable solve has no solution)",
                transform=ax.transAxes, ha="center", va="bottom", color=RED, fontsize=9,
                bbox=dict(fc="w", ec=RED, lw=0.8))
    if target is not None:
        ax.plot(target[0] * 1e3, target[1] * 1e3, "k+", ms=10, mew=1.5)
    txt = title
    if ok and dS is not None:
        txt += f"\ndX {dS[0] * 1e3:+.3f} mm, dY {dS[1] * 1e3:+.3f} mm, dphi {np.degrees(dS[2]):+.3f}°"
    ax.set_title(txt, fontsize=9.5)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    ax.grid(True)


def share_range(axs, margin: float = 0.05) -> None:
    """One X and one Y range on every axes of ``axs`` (panels of one size,
    placed): the union of what they show, widened by ``margin`` of its span
    and, for equal-aspect panels, widened further along one axis to the
    panels' own aspect, so each fills its box."""
    lo = np.min([ax.dataLim.min for ax in axs], axis=0)
    hi = np.max([ax.dataLim.max for ax in axs], axis=0)
    mid, half = (lo + hi) / 2, (hi - lo) * (0.5 + margin)
    if axs[0].get_aspect() != "auto":
        box = axs[0].get_position().size * axs[0].figure.get_size_inches()  # width, height (in)
        half = np.maximum(half, half[::-1] * np.array([box[0] / box[1], box[1] / box[0]]))
    for ax in axs:
        ax.set_xlim(mid[0] - half[0], mid[0] + half[0])
        ax.set_ylim(mid[1] - half[1], mid[1] + half[1])
        if ax.get_aspect() != "auto":
            ax.set_adjustable("box")  # the ranges already have the box's aspect


def table2_groups(study) -> Dict[Tuple, List[dict]]:
    """Table 2's entries grouped by (pose, condition), in table order."""
    groups: Dict[Tuple, List[dict]] = {}
    for e in study.table2:
        groups.setdefault((tuple(np.round(e["pose"], 6)), e["condition"]), []).append(e)
    return groups


def table2_figures(study, which: Optional[List[int]] = None) -> List[Tuple[str, Figure]]:
    """Table 2 configuration diagrams: one figure per (pose, condition) (all,
    or the groups ``which``), one panel per error, every panel on the same
    X and Y range; blue before, red after, red dashed after with the
    joint-angle change exaggerated ×10. Returns
    [(name, Figure)]."""
    out = []
    for gi, ((pose, cond), items) in enumerate(table2_groups(study).items()):
        if which is not None and gi not in which:
            continue
        with report_style():
            cols = min(len(items), 2)
            rows = -(-len(items) // cols)
            fig = new_figure(W if cols == 2 else 6.0, 4.3 * rows + 1.3)
            axs = np.atleast_1d(fig.subplots(rows, cols)).ravel()
            for ax, e in zip(axs, items):
                _diagram(ax, study.robot, e["theta0"], e["theta"], e["ok"], e["error"], target=e["pose"], dS=e["dS"])
                ax.legend(loc="lower left", fontsize=7.5, framealpha=0.9)
            for ax in axs[len(items):]:
                ax.set_visible(False)
            th = ", ".join(f"{np.degrees(t):.1f}" for t in items[0]["theta0"])
            fig.suptitle(f"Table 2 — pose [{pose[0]:g} m, {pose[1]:g} m, {pose[2]:g} rad], {cond}\n"
                         f"initial theta = ({th})° (pose IK, theta_2 ≤ 0 branch); + marks the commanded tip",
                         fontsize=10)
            place(fig, rows, cols, left=0.7, right=0.2, bottom=0.5, top=1.15, wgap=0.75, hgap=0.95)
            share_range(axs[:len(items)])
        out.append((f"table2_{gi + 1}", fig))
    return out


def singular_state_figure(study, dL: float = -1e-3) -> Figure:
    """Fig. 12: the straight (singular) pose, ``dL`` (m) on cable 1, before and
    after; right panel zooms on the tip."""
    robot = study.robot
    n = robot.n
    dl = np.zeros(n)
    dl[0] = dL
    t0 = np.zeros((1, n))
    d = deviation(robot, t0, dL=dl)
    theta, ds, ok = d.solution.theta[0], d.dS[0], bool(d.ok[0])
    sv = np.linalg.svd(robot.fk_jacobian(t0)[0][:2], compute_uv=False)
    with report_style():
        fig = new_figure(W, 4.4)
        ax1, ax2 = fig.subplots(1, 2, gridspec_kw=dict(width_ratios=[1.6, 1]))
        _diagram(ax1, robot, t0[0], theta, ok,
                 f"{dL * 1e3:+g} mm on cable 1 at theta = 0 (tip {robot.fk(t0[0])[0] * 1e3:.0f}, 0 mm)", dS=ds)
        ax1.legend(loc="upper left", fontsize=8)
        tip0 = robot.fk(t0[0])[:2] * 1e3
        tip1 = robot.fk(theta)[:2] * 1e3
        ax2.plot(*tip0, "o", color=BLUE, ms=9, label="tip before")
        ax2.plot(*tip1, "o", color=RED, ms=9, label="tip after")
        ax2.annotate("", tip1, tip0, arrowprops=dict(arrowstyle="->", lw=1.5))
        ax2.set_xlim(tip0[0] - 3, tip0[0] + 3)
        ax2.set_ylim(tip0[1] - 1, tip0[1] + 3.5)
        ax2.set_aspect("equal")
        ax2.grid(True)
        ax2.set_xlabel("X (mm)")
        ax2.set_ylabel("Y (mm)")
        ax2.legend(loc="upper left", fontsize=8)
        ax2.set_title(f"tip, zoomed: dX = {ds[0] * 1e3:+.4f} mm, dY = {ds[1] * 1e3:+.4f} mm\n"
                      "singular values of d[X,Y]/dtheta: " + ", ".join(f"{s * 1e3:.3g}" for s in sv)
                      + " mm/rad (X lost)", fontsize=9)
        fig.suptitle("Fig. 12 — singular state: all joints zero; dX/dtheta = 0 (the pose Jacobian loses X), "
                     "so dX is second order", fontsize=10)
        place(fig, 1, 2, left=0.75, right=0.2, bottom=0.55, top=0.75, wgap=0.9)
    return fig


# ---------------------------------------------------------------------------
# Table 3
# ---------------------------------------------------------------------------
def table3_figure(study) -> Figure:
    """Table 3: measured vs ours vs the paper's theoretical deviation (mm) per
    point, dX and dY; hollow diamonds: ours from the plain theta = 0 IK seed."""
    t = study.table3
    labels = [str(p) for p in t["point"]]
    x = np.arange(len(labels))
    with report_style():
        fig = new_figure(W, 7.0)
        axs = fig.subplots(2, 1, sharex=True)
        for j, (ax, nm) in enumerate(zip(axs, ["dX", "dY"])):
            w = 0.27
            ax.bar(x - w, t["measured"][:, j] * 1e3, w, color="0.55", label="measured\n(paper's prototype)")
            ax.bar(x, t["ours"][:, j] * 1e3, w, color=HUES[j], label="ours (theta_2 ≤ 0 branch)")
            ax.bar(x + w, t["paper"][:, j] * 1e3, w, color="w", ec=HUES[j], hatch="//", label="paper's theoretical")
            diff = np.abs(t["ours_plain_seed"][:, j] - t["ours"][:, j]) > 1e-6
            if diff.any():
                ax.scatter(x[diff], t["ours_plain_seed"][diff, j] * 1e3, marker="D", s=45, facecolors="none",
                           edgecolors="k", zorder=4, label="ours, plain seed\n(mirror branch)")
            ax.axhline(0, color="k", lw=0.6)
            ax.set_ylabel(f"{nm} (mm)")
            ax.grid(True, axis="y")
            ax.set_title(f"{nm}: largest |ours − paper| = "
                         f"{np.abs(t['ours'][:, j] - t['paper'][:, j]).max() * 1e3:.1e} mm, largest |measured − ours| "
                         f"= {np.abs(t['measured'][:, j] - t['ours'][:, j]).max() * 1e3:.3f} mm", fontsize=9.5)
        axs[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        axs[1].set_xticks(x)
        axs[1].set_xticklabels([f"{lab}\n({p[0] * 1e3:.0f}, {p[1] * 1e3:.0f})" for lab, p in zip(labels, t["pose"])])
        axs[1].set_xlabel("experiment point (commanded tip X, Y in mm, phi = 0)")
        fig.suptitle("Table 3 — tip displacement for −1 mm on cable 1: measured vs ours vs paper (attitude-0 pose IK)",
                     fontsize=10)
        place(fig, 2, 1, left=0.75, right=2.35, bottom=0.85, top=0.75, hgap=0.5)
    return fig


def workspace_overlay(study):
    """``overlay(ax)`` for the study's workspace figure: the paper's
    experimental range (X 190–230 mm, Y −100–100 mm, its Fig. 9) and the
    Table 3 points, stars (hollow where the paper's IK branch exceeds the
    joint limits)."""
    def overlay(ax):
        ax.add_patch(Rectangle((190, -100), 40, 200, fill=False, ec="k", ls="--", lw=1.2,
                               label="paper's experimental range (Fig. 9)"))
        p = study.table3["pose"] * 1e3
        ok = study.table3["within_limits"]
        ax.scatter(p[ok, 0], p[ok, 1], marker="*", s=110, c=RED, ec="k", lw=0.5, zorder=5,
                   label="Table 3 points within the limits")
        ax.scatter(p[~ok, 0], p[~ok, 1], marker="*", s=110, c="w", ec=RED, lw=1.2, zorder=5,
                   label="Table 3 points beyond the limits (paper's branch)")
        # labels in a column right of the range, spread apart, each joined
        # to its star by a leader line (points 2-6 lie within 15 mm)
        ys = spread(p[:, 1], LABEL_GAP_MM)
        for lab, q, y in zip(study.table3["point"], p, ys):
            ax.annotate(str(lab), q[:2], xytext=(LABEL_COLUMN_MM, y), textcoords="data", fontsize=8, va="center",
                        arrowprops=dict(arrowstyle="-", lw=0.6, color="0.3", shrinkA=1, shrinkB=5))
    return overlay


#: Where the Table 3 labels of the workspace figure stand (tip X, mm) and
#: their least vertical distance apart (mm).
LABEL_COLUMN_MM, LABEL_GAP_MM = 242.0, 9.0


def spread(y, gap: float) -> np.ndarray:
    """Positions for labels at ``y`` (K,) at least ``gap`` apart, each group
    of labels that would crowd centred on its points' mean, in the order of
    ``y`` (ties in their given order)."""
    y = np.asarray(y, float)
    order = np.argsort(y, kind="stable")
    groups = [[i] for i in order]  # runs of labels placed as one block
    merged = True
    while merged:
        merged = False
        for k in range(len(groups) - 1):
            a, b = groups[k], groups[k + 1]
            top_a = y[a].mean() + gap * (len(a) - 1) / 2
            bottom_b = y[b].mean() - gap * (len(b) - 1) / 2
            if bottom_b - top_a < gap:
                groups[k:k + 2] = [a + b]
                merged = True
                break
    out = np.empty_like(y)
    for g in groups:
        out[g] = y[g].mean() + gap * (np.arange(len(g)) - (len(g) - 1) / 2)
    return out


def figure_jobs(study) -> List[FigureJob]:
    """The paper's own figures as jobs ``(name, make)``: ``readings``,
    ``table2_<k>``, ``fig12_singular_state``, ``table3``."""
    jobs: List[FigureJob] = []
    if study.readings:
        jobs.append(("readings", lambda: [("readings", readings_figure(study))]))
    for g in range(len(table2_groups(study))):
        jobs.append((f"table2_{g + 1}", lambda g=g: table2_figures(study, [g])))
    jobs.append(("fig12_singular_state", lambda: [("fig12_singular_state", singular_state_figure(study))]))
    if study.table3 is not None:
        jobs.append(("table3", lambda: [("table3", table3_figure(study))]))
    return jobs
