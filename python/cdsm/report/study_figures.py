"""Figures of the accuracy study (:mod:`cdsm.study`; matplotlib, Agg, no
pyplot global state), for either kind of arm.

Planar arms: maps over the tip positions (x–y, mm). Spatial arms: three
orthogonal projections of the tips (x–y, x–z, y–z; cheaper and easier to read
than a 3-D scatter), the overviews on the *main plane* — the two axes along
which the tips spread most. Maps draw the largest |value| on top, so a
projection shows the worst value along each line of sight; configurations
without a value (unreachable, unsolved) are small grey crosses. Arrays come
from the study in SI units (m, rad); the figures show mm and degrees.
Colours follow the paper: dX red, dY blue, dphi green; negative values
purple (:mod:`cdsm.report.figures`). Every ``*_figure`` function returns a
:class:`matplotlib.figure.Figure`; :func:`figure_jobs` lists them for
:func:`cdsm.report.figures.render_jobs`.
"""

from __future__ import annotations

import os
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ..accuracy.montecarlo import MonteCarlo
from ..accuracy.tolerance import pooled_percentile
from ..calibration.measurements import commanded_cables
from ..display import degrees
from ..kinds import SPATIAL
from ..robot import Robot
from ..study import NEAR_SINGULAR
from .figures import (BLUE, GREEN, HUES, MAX_WIDTH_IN, RED, FigureJob, colour_bar, draw_arm, few_ticks, file_key,
                      hue_cmap, mark_missing, new_figure, place, render_jobs, report_style, seq_cmap, sym_norm,
                      tension_cmap)

__all__ = ["AXES", "PLANES", "SCENARIO_COLUMNS", "main_plane", "phi0_tips", "workspace_figure", "overview_figure",
           "scenario_figure", "detailed_scenarios", "MAX_SCENARIO_FIGURES", "DETAILED_SCENARIOS",
           "monte_carlo_figure", "singular_figure", "feasibility_figure", "hysteresis_figure", "amplification_figure",
           "amplification_titles", "figure_jobs", "all_figures", "PROTOCOL_SHORT"]

AXES = ("x", "y", "z")
#: The three orthogonal projections: (horizontal axis, vertical axis) indices.
PLANES = ((0, 1), (0, 2), (1, 2))


def _error_columns(kind) -> Tuple[Tuple[str, str], ...]:
    """Columns of an overview: (scenario error, sign), the cable's length then the kind's hole errors."""
    return tuple((e, s) for e in ("cable",) + tuple(h[0] for h in kind.hole_scenarios) for s in "-+")


#: Columns of a spatial arm's overview: (scenario error, sign).
SCENARIO_COLUMNS = _error_columns(SPATIAL)
PROTOCOL_SHORT = {"attitude0": "attitude-0", "joint": "joint-space", "sampled": "sampled",
                  "commanded": "sampled commands"}
W = MAX_WIDTH_IN


def main_plane(pose: np.ndarray) -> Tuple[int, int]:
    """The two axes (indices, ascending) along which the tip positions
    ``pose`` (N, >= 3) spread most (range)."""
    span = np.ptp(np.asarray(pose)[:, :3], axis=0)
    a, b = sorted(np.argsort(-span, kind="stable")[:2])
    return int(a), int(b)


def _tips(study, protocol: str) -> np.ndarray:
    """(N, 2) planar or (N, 3) spatial nominal tips, mm."""
    return study.workspaces[protocol].poses[:, :study.kind.dim] * 1e3


def _plane(study, protocol: str) -> Tuple[int, int]:
    """The main plane of the tips (a planar arm's: its plane)."""
    return main_plane(study.workspaces[protocol].poses[:, :study.kind.dim])


def _panel_title(study, protocol: str, plane: Tuple[int, int]) -> str:
    """A map panel's title: its projection, or (one plane) its protocol."""
    if study.kind.figure["projections"]:
        return f"{AXES[plane[0]]}–{AXES[plane[1]]} projection"
    return PROTOCOL_SHORT.get(protocol, protocol)


def _title(study, protocol: str) -> str:
    ws = study.workspaces[protocol]
    if protocol == "commanded":
        return f"{len(ws.grid)} sampled commands (±{(ws.params or {}).get('reach_m', 0) * 1e3:g} mm)"
    if protocol == "sampled":
        p = ws.params or {}
        how = "given" if p.get("method") == "given" else f"{p.get('method')}, seed {p.get('seed')}"
        return f"{len(ws.grid)} sampled configurations ({how})"
    if protocol == "attitude0":
        return (f"attitude-0 protocol (grid tip, phi = 0, pose IK): {int(ws.reachable.sum())} of {len(ws.grid)} "
                "reachable")
    return f"joint-space protocol ({ws.describe_grid()})"


def _map(fig, ax, pts, val, cmap, norm, label, plane=(0, 1), size=7.0, order=True, bar=True, bar_ticks=5):
    """Scatter of ``val`` at ``pts`` (mm) projected on ``plane``: ``order``
    True largest |val| on top, ``"low"`` smallest on top, False as given;
    non-finite values are left out (mark them with :func:`mark_missing`)."""
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
        colour_bar(fig, sc, ax, label, bar_ticks)
    return sc


def _missing(ax, pts, mask, plane=(0, 1), label=None, size=6.0):
    if mask.any():
        i, j = plane
        mark_missing(ax, np.stack([pts[mask, i], pts[mask, j]], axis=1), label=label, size=size)


def _rings(ax, pts, mask, plane=(0, 1), label=None, color="k", size=30.0, lw=0.8):
    if mask.any():
        i, j = plane
        ax.scatter(pts[mask, i], pts[mask, j], s=size, facecolors="none", edgecolors=color, linewidths=lw,
                   label=label)


def _axes(ax, plane=(0, 1), equal=False, ticks=4):
    ax.set_xlabel(f"tip {AXES[plane[0]]} (mm)")
    ax.set_ylabel(f"tip {AXES[plane[1]]} (mm)")
    few_ticks(ax, ticks)
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True)


def _limits(pts: np.ndarray, plane) -> List[Tuple[float, float]]:
    """Axis limits of the projected tips with a 4 % margin (deterministic,
    equal for every panel of a figure)."""
    out = []
    for k in plane:
        v = pts[:, k]
        lo, hi = float(np.min(v)), float(np.max(v))
        pad = 0.04 * (hi - lo) + 1e-6
        out.append((lo - pad, hi + pad))
    return out


def _range(v: np.ndarray) -> Normalize:
    """Colour scale from the smallest to the largest finite value."""
    if not np.isfinite(v).any():
        return Normalize(0.0, 1.0)
    lo, hi = float(np.nanmin(v)), float(np.nanmax(v))
    return Normalize(lo, hi if hi > lo else lo + 1e-12 + abs(lo) * 1e-9)


def _nanmax(v) -> float:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    return float(v.max()) if v.size else float("nan")


def _g(v: float, nd: int = 3) -> str:
    return f"{v:.{nd}g}" if np.isfinite(v) else "—"


# ---------------------------------------------------------------------------
# workspace
# ---------------------------------------------------------------------------
def phi0_tips(robot: Robot, step_deg: float = 1.0, max_points: int = 200_000) -> np.ndarray:
    """Tips (m) of planar phi = 0 configurations within the joint limits,
    (K, 2): joints 1..n-1 on a ``step_deg`` grid (uniform random samples
    when that grid would exceed ``max_points``), the last joint closing
    phi = 0."""
    lim = robot.joint_limits
    n = robot.n
    if n < 2:
        return np.zeros((0, 2))
    axes = [np.arange(lim[k, 0], lim[k, 1] + 1e-12, np.radians(step_deg)) for k in range(n - 1)]
    if np.prod([float(len(a)) for a in axes]) <= max_points:
        mesh = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, n - 1)
    else:
        mesh = np.random.default_rng(0).uniform(lim[:-1, 0], lim[:-1, 1], (max_points, n - 1))
    last = -mesh.sum(axis=1)
    ok = (last >= lim[-1, 0]) & (last <= lim[-1, 1])
    th = np.concatenate([mesh[ok], last[ok, None]], axis=1)
    if len(th) > 40000:
        th = th[np.random.default_rng(0).choice(len(th), 40000, replace=False)]
    return robot.fk(th)[:, :2]


def workspace_figure(study, overlay: Optional[Callable] = None) -> Figure:
    """The workspace of the study. Planar: the tips of every protocol's
    configurations (mm), the tips reachable at phi = 0 within the joint
    limits when the attitude-0 protocol is used, the straight arm (layered
    from the widest set at the back to the attitude-0 grid's tips in front,
    so none hides another); then
    ``overlay(ax)`` (the paper's report adds its experimental range).
    Spatial: the sampled tips on the three projections, coloured by the
    third coordinate; the straight pose's tip starred."""
    robot = study.robot
    if study.kind.figure["projections"]:
        p = study.main
        pts = _tips(study, p)
        tip0 = robot.fk(np.zeros(robot.n))[:3] * 1e3
        with report_style():
            fig = new_figure(W, 3.9)
            axs = fig.subplots(1, 3)
            for ax, plane in zip(axs, PLANES):
                k = 3 - sum(plane)
                _map(fig, ax, pts, pts[:, k], "viridis", _range(pts[:, k]), f"tip {AXES[k]} (mm)", plane=plane,
                     size=5, order=False, bar_ticks=4)
                ax.plot(tip0[plane[0]], tip0[plane[1]], "*", ms=11, mfc=RED, mec="k", mew=0.6, label="straight pose")
                ax.plot(0.0, 0.0, "k+", ms=9, mew=1.4, label="base origin")
                _axes(ax, plane, equal=True, ticks=3)
                ax.set_title(f"{AXES[plane[0]]}–{AXES[plane[1]]} projection")
            axs[0].legend(loc="best", fontsize=8, framealpha=0.85)
            span = np.ptp(pts, axis=0)
            fig.suptitle(f"Workspace: {_title(study, p)}; extent "
                         + ", ".join(f"{a} {s:.0f} mm" for a, s in zip(AXES, span)), fontsize=10.5)
            place(fig, 1, 3, left=0.6, right=0.85, bottom=0.5, top=0.45, wgap=1.2)
        return fig
    with report_style():
        fig = new_figure(8.0, 8.6)
        ax = fig.subplots()
        for p, ws in study.workspaces.items():
            if p == "attitude0":
                g = ws.poses[ws.reachable, :2] * 1e3
                ax.scatter(g[:, 0], g[:, 1], s=5, c=BLUE, linewidths=0, rasterized=True, zorder=3,
                           label=f"grid tips reachable at phi = 0 ({len(g)}; {ws.n_unreachable} not)")
            else:
                tips = robot.fk(ws.grid)[:, :2] * 1e3
                what = f"joint grid {ws.describe_grid()}" if p == "joint" else "sampled configurations"
                ax.scatter(tips[:, 0], tips[:, 1], s=4, c="0.55", linewidths=0, rasterized=True, zorder=1,
                           label=f"{what}: tips, any phi ({len(tips)})")
        if "attitude0" in study.workspaces:
            t = phi0_tips(robot) * 1e3
            if len(t):
                lim = degrees(np.abs(robot.joint_limits).max())
                ax.scatter(t[:, 0], t[:, 1], s=9, c=GREEN, alpha=0.25, linewidths=0, rasterized=True, zorder=2,
                           label=f"phi = 0 within the joint limits (up to ±{lim}°)")
        draw_arm(ax, robot, np.zeros(robot.n), "k", lw=1.2, label="straight arm")
        if overlay is not None:
            overlay(ax)
        _axes(ax, equal=True, ticks=6)
        ax.legend(loc="upper left", fontsize=8.5, markerscale=2, framealpha=0.9)
        ax.set_title(f"Workspace of {robot.name}: {robot.n} joints, tips of the study's configurations")
        place(fig, 1, 1, left=0.8, right=0.2, bottom=0.6, top=0.45)
    return fig


# ---------------------------------------------------------------------------
# single errors
# ---------------------------------------------------------------------------
def _overview_keys(study) -> List[List[str]]:
    """Rows of scenario keys of an overview figure: one per position cable,
    its length's errors then its hole errors (:func:`cdsm.study.scenario_set`)."""
    kind, ends = study.kind, study.robot.cable_ends
    return [[f"cable{c + 1}{s}" for s in "-+"]
            + [key.format(cable=c + 1, disk=ends[c]) + s for _, key, _ in kind.hole_scenarios for s in "-+"]
            for c in commanded_cables(study.robot)]


def overview_figure(study, protocol: str, quantity: str = "position") -> Figure:
    """Every single error of ``protocol`` as a thumbnail, each on its own
    scale (0 to its max, in the title): |d position| (mm) or, with
    ``quantity="rotation"``, the end frame's rotation (deg). Planar rows: the
    pairs, columns cable −, cable +, disk −, disk +; spatial rows: the
    position cables, columns :data:`SCENARIO_COLUMNS` (main plane). Jump
    points ringed; unreachable configurations as crosses."""
    keys = _overview_keys(study)
    rows, cols = len(keys), len(keys[0])
    if rows * cols > MAX_SCENARIO_FIGURES:
        return _overview_matrix(study, protocol, quantity, keys)
    pts = _tips(study, protocol)
    plane = _plane(study, protocol)
    ws = study.workspaces[protocol]
    unit = "mm" if quantity == "position" else "deg"
    what = study.kind.norm_label if quantity == "position" else "rotation angle"
    lims = _limits(pts, plane)
    hrow = 1.95 if cols > 4 else 2.5
    with report_style():
        fig = new_figure(W, hrow * rows + 1.25)
        axs = np.atleast_2d(fig.subplots(rows, cols, sharex=True, sharey=True))
        sc = None
        for r, row in enumerate(keys):
            for c, key in enumerate(row):
                ax = axs[r, c]
                res = study.result(key, protocol)
                v = res.position * 1e3 if quantity == "position" else np.degrees(res.rotation)
                vmax = _nanmax(v)
                scale = vmax if np.isfinite(vmax) and vmax > 0 else 1.0
                _missing(ax, pts, ~np.isfinite(v), plane, size=3)
                sc = _map(fig, ax, pts, v / scale, seq_cmap("viridis", 0.0), Normalize(0, 1), "", plane=plane,
                          size=3.5, bar=False)
                _rings(ax, pts, res.jumps.point, plane, size=14, lw=0.6)
                jumps = res.jump_count
                sep = "\n" if cols > 4 else ": "
                ax.set_title(f"{key}{sep}max {_g(vmax)} {unit}" + (f", {jumps} jumps" if jumps else ""), fontsize=8.5)
                ax.tick_params(labelsize=7.5)
                ax.set_xlim(*lims[0])
                ax.set_ylim(*lims[1])
        for ax in axs[-1]:
            ax.set_xlabel(f"tip {AXES[plane[0]]} (mm)", fontsize=8.5)
            ax.xaxis.set_major_locator(MaxNLocator(3))
        for ax in axs[:, 0]:
            ax.set_ylabel(f"tip {AXES[plane[1]]} (mm)", fontsize=8.5)
            ax.yaxis.set_major_locator(MaxNLocator(4))
        for ax in axs.ravel():
            ax.label_outer()
        place(fig, rows, cols, left=0.65, right=0.85, bottom=0.5, top=0.9 if cols > 4 else 0.75, wgap=0.12,
              hgap=0.58 if cols > 4 else 0.42)
        if sc is not None:
            cax = fig.add_axes((1 - 0.7 / W, 0.3, 0.12 / W, 0.4))
            cb = fig.colorbar(sc, cax=cax)
            cb.set_label(f"{what} / thumbnail max")
        cols_txt = study.kind.words["overview_layout"]
        fig.suptitle(f"Single errors, {what} — {_title(study, protocol)}\n{cols_txt}; black rings: jump points"
                     + ("; crosses: unreachable" if ws.n_unreachable else ""), fontsize=10)
    return fig


def _overview_matrix(study, protocol: str, quantity: str, keys: List[List[str]]) -> Figure:
    """The overview of a long arm's single errors (more than
    :data:`MAX_SCENARIO_FIGURES`, too many for a thumbnail each): the largest
    and the RMS |d position| (mm) or rotation (deg) over the configurations,
    one cell per single error, one row per position cable."""
    unit = "mm" if quantity == "position" else "deg"
    what = study.kind.norm_label if quantity == "position" else "rotation angle"
    rows, cols = len(keys), len(keys[0])
    stats = np.full((2, rows, cols), np.nan)
    for r, row in enumerate(keys):
        for c, key in enumerate(row):
            res = study.result(key, protocol)
            v = res.position * 1e3 if quantity == "position" else np.degrees(res.rotation)
            if np.isfinite(v).any():
                stats[0, r, c] = np.nanmax(v)
                stats[1, r, c] = np.sqrt(np.nanmean(v ** 2))
    labels = [f"{error} {sign}" for error, sign in _error_columns(study.kind)]
    cables = [str(c + 1) for c in commanded_cables(study.robot)]
    with report_style():
        fig = new_figure(W, min(0.16 * rows + 1.6, 11.0))
        axs = fig.subplots(1, 2, sharey=True)
        for ax, m, name in zip(axs, stats, ("largest", "RMS")):
            top = _nanmax(m)
            im = ax.imshow(m, aspect="auto", cmap=seq_cmap("viridis", 0.0),
                           norm=Normalize(0, top if np.isfinite(top) and top > 0 else 1.0), interpolation="nearest")
            ax.set_xticks(range(cols), labels, rotation=40, ha="right", fontsize=7.5)
            ax.set_yticks(range(rows), cables, fontsize=6.5 if rows > 20 else 8)
            ax.set_title(f"{name} {what} ({unit}) over the configurations", fontsize=9)
            fig.colorbar(im, ax=ax, fraction=0.06, pad=0.02).set_label(unit)
        axs[0].set_ylabel("position cable")
        fig.suptitle(f"Single errors, {what} — {_title(study, protocol)}\n{study.kind.words['overview_layout']}",
                     fontsize=10)
        fig.subplots_adjust(left=0.09, right=0.97, bottom=0.12, top=0.9, wspace=0.25)
    return fig


def scenario_figure(study, key: str) -> Figure:
    """One single error. Planar: dX (red), dY (blue) and dphi (green) over
    the tips, one row per protocol, one colour scale per column (negative
    purple, zero grey). Spatial: |d(X, Y, Z)| (top) and the rotation angle
    (bottom) on the three projections. Jump points ringed; unreachable tips
    as crosses."""
    if study.kind.figure["projections"]:
        return _projections_scenario_figure(study, key)
    protos = [p for p in study.workspaces if any(r.protocol == p and r.scenario.key == key for r in study.scenarios)]
    names = ["dX (mm)", "dY (mm)", "dphi (deg)"]
    res = {p: study.result(key, p) for p in protos}
    vals = {p: [r.dS[:, 0] * 1e3, r.dS[:, 1] * 1e3, np.degrees(r.dS[:, 2])] for p, r in res.items()}
    norms = [sym_norm(np.concatenate([vals[p][j] for p in protos])) for j in range(3)]
    with report_style():
        fig = new_figure(W, 3.4 * len(protos) + 1.15)
        axs = np.atleast_2d(fig.subplots(len(protos), 3, sharex=True, sharey=True))
        lines = []
        for row, p in zip(axs, protos):
            r = res[p]
            pts = _tips(study, p)
            ws = study.workspaces[p]
            for ax, v, nm, hue, norm in zip(row, vals[p], names, HUES, norms):
                q, unit = nm.split()[0], nm.split()[1].strip("()")
                _missing(ax, pts, ~ws.reachable, size=5)
                _missing(ax, pts, ws.reachable & ~r.ok, label="no solution after the error", size=5)
                _map(fig, ax, pts, v, hue_cmap(hue), norm, nm, size=6, bar_ticks=5)
                _rings(ax, pts, r.jumps.point, label=f"jump points ({r.jump_count})", size=26)
                ax.set_title(f"{PROTOCOL_SHORT.get(p, p)}: max |{q}| {_g(_nanmax(np.abs(v)))} {unit}", color=hue,
                             fontsize=9.5)
                _axes(ax)
            if r.jump_count:
                row[0].legend(loc="lower left", fontsize=7.5, framealpha=0.85)
            miss = (f"{ws.n_unreachable} grid tips unreachable at phi = 0 (crosses)" if p == "attitude0"
                    else "largest |value| on top")
            lines.append(f"{PROTOCOL_SHORT.get(p, p)}: {int(r.ok.sum())} of {len(r.ok)} solved; {miss}; "
                         f"{int((ws.reachable & ~r.ok).sum())} without a solution after the error")
        for ax in axs.ravel():
            ax.label_outer()
        sc = res[protos[0]].scenario
        fig.suptitle(f"{sc.label}  ({sc.figure or sc.key})\n" + "\n".join(lines), fontsize=10)
        place(fig, len(protos), 3, left=0.7, right=0.75, bottom=0.5, top=0.35 + 0.2 * (len(protos) + 1),
              wgap=0.85, hgap=0.45)
    return fig


def _projections_scenario_figure(study, key: str) -> Figure:
    r = study.result(key)
    pts = _tips(study, r.protocol)
    rows = [(r.position * 1e3, study.kind.norm_label, "mm", seq_cmap("magma_r")),
            (np.degrees(r.rotation), "rotation", "deg", seq_cmap("cividis_r"))]
    with report_style():
        fig = new_figure(W, 7.4)
        axs = fig.subplots(2, 3)
        for ax_row, (v, name, unit, cmap) in zip(axs, rows):
            norm = _range(v)
            for ax, plane in zip(ax_row, PLANES):
                _missing(ax, pts, ~np.isfinite(v), plane, size=5)
                _map(fig, ax, pts, v, cmap, norm, f"{name} ({unit})", plane=plane, size=5,
                     bar=plane == PLANES[-1], bar_ticks=4)
                _rings(ax, pts, r.jumps.point, plane, label=f"jump points ({r.jump_count})", size=24)
                _axes(ax, plane, equal=True, ticks=3)
            ax_row[0].set_title(f"{name}: {_g(np.nanmin(v) if np.isfinite(v).any() else np.nan)} to "
                                f"{_g(_nanmax(v))} {unit}", fontsize=9.5)
        if r.jump_count:
            axs[0, 0].legend(loc="best", fontsize=7.5, framealpha=0.85)
        fig.suptitle(f"{r.scenario.label} ({key}) — {int(r.ok.sum())} of {len(r.ok)} solved; "
                     f"{_title(study, r.protocol)}", fontsize=10)
        place(fig, 2, 3, left=0.65, right=0.85, bottom=0.5, top=0.7, wgap=0.75, hgap=0.7)
    return fig


# ---------------------------------------------------------------------------
# Monte Carlo
# ---------------------------------------------------------------------------
def _mc_subtitle(study, protocol: str) -> str:
    mc = study.monte_carlo[protocol]
    p = mc.params
    holes, cables = study.kind.words["holes_per"], study.kind.words["cables_per"]
    failed = int(mc.failed.sum())
    fail = (f"failed solves: {failed} of {int(mc.count.sum() + failed)} at {int((mc.failed > 0).sum())} "
            "configurations (red rings)" if failed else "no failed solves")
    return (f"Monte Carlo: {p.get('samples')} composite errors per configuration, uniform ±"
            f"{max(p['dl_tol_m']) * 1e3:g} mm {cables} and ±{max(p['dh_tol_m']) * 1e3:g} mm {holes}, seed "
            f"{p.get('seed')}\n{_title(study, protocol)}; {fail}; percentiles within 0.5 % of the sample quantiles")


def _pooled_hist(mc: MonteCarlo) -> Tuple[np.ndarray, np.ndarray]:
    """(edges (B + 1,) m, counts (B,)) of the position error over every
    converged sample, on the study's log bins (the open end bins dropped)."""
    return MonteCarlo.hist_edges(), mc.pooled_hist()[1:-1]


def monte_carlo_figure(study, protocol: str) -> Figure:
    """Monte-Carlo maps of ``protocol``. Top row: mean, 95th percentile and
    max of |d position| (mm) per configuration (spatial: on the main plane).
    Bottom row, planar (the paper's Fig. 7): mean dX (red), dY (blue), dphi
    (green); spatial: the 95th percentile on the two other projections and
    the histogram over every sample. Configurations with failed solves
    ringed red."""
    mc = study.monte_carlo[protocol]
    ws = study.workspaces[protocol]
    pts = _tips(study, protocol)[ws.reachable]
    plane = _plane(study, protocol)
    kind = study.kind
    layout = kind.figure
    q = f"|{kind.quantities[kind.norm]}|"
    top = [(mc.mean[:, kind.norm] * 1e3, f"mean {q} (mm)"), (mc.percentile(95.0) * 1e3, f"95th pct {q} (mm)"),
           (mc.max_abs[:, kind.norm] * 1e3, f"max {q} (mm)")]
    failed = mc.failed > 0
    with report_style():
        fig = new_figure(W, 7.6)
        axs = fig.subplots(2, 3)
        vmax = _nanmax(top[2][0])
        norm = Normalize(0, vmax if np.isfinite(vmax) and vmax > 0 else 1.0)
        for ax, (v, nm) in zip(axs[0], top):
            _map(fig, ax, pts, v, seq_cmap("magma_r"), norm, nm, plane=plane, size=5, bar_ticks=4)
            _rings(ax, pts, failed, plane, color=RED, size=22)
            ax.set_title(f"{nm.replace(' (mm)', '')}: max {_g(_nanmax(v))} mm", fontsize=9.5)
            _axes(ax, plane, equal=layout["equal"], ticks=layout["ticks"])
        if layout["projections"]:
            p95 = top[1][0]
            for ax, pl in zip(axs[1][:2], [pl for pl in PLANES if pl != plane][:2]):
                _map(fig, ax, pts, p95, seq_cmap("magma_r"), norm, f"95th pct {q} (mm)", plane=pl, size=5,
                     bar_ticks=4)
                ax.set_title(f"95th pct, {AXES[pl[0]]}–{AXES[pl[1]]} projection", fontsize=9.5)
                _axes(ax, pl, equal=True, ticks=3)
            ax = axs[1][2]
            edges, counts = _pooled_hist(mc)
            ax.stairs(counts, edges * 1e3, fill=True, color=BLUE, alpha=0.75)
            ax.set_xscale("log")
            used = np.flatnonzero(counts)
            if used.size:
                ax.set_xlim(edges[max(used[0] - 2, 0)] * 1e3, edges[min(used[-1] + 3, len(edges) - 1)] * 1e3)
            ax.set_xlabel(f"{q} (mm), every sample")
            ax.set_ylabel("samples per bin")
            for pc, ls in ((50.0, ":"), (95.0, "--"), (99.0, "-")):
                v = pooled_percentile(mc, pc) * 1e3
                if np.isfinite(v):
                    ax.axvline(v, color="k", ls=ls, lw=1.0, label=f"pooled p{pc:g} {v:.3g} mm")
            ax.legend(loc="upper left", fontsize=7.5, framealpha=0.85)
            ax.set_title("histogram over all configurations", fontsize=9.5)
            ax.grid(True)
        else:
            bottom = [(mc.mean[:, 0] * 1e3, "mean dX (mm)"), (mc.mean[:, 1] * 1e3, "mean dY (mm)"),
                      (np.degrees(mc.mean[:, 2]), "mean dphi (deg)")]
            for ax, (v, nm), hue in zip(axs[1], bottom, HUES):
                _map(fig, ax, pts, v, hue_cmap(hue), sym_norm(v), nm, size=5, bar_ticks=5)
                ax.set_title(nm.split(" (")[0] + " (signed)", color=hue, fontsize=9.5)
                _axes(ax)
            for ax in axs.ravel():
                ax.label_outer()
        fig.suptitle(_mc_subtitle(study, protocol), fontsize=9.5)
        place(fig, 2, 3, left=0.7, right=0.85, bottom=0.5, top=0.85, wgap=layout["mc_wgap"], hgap=0.7)
    return fig


# ---------------------------------------------------------------------------
# singular states, statics, amplification
# ---------------------------------------------------------------------------
def _panels(study) -> List[Tuple[str, Tuple[int, int]]]:
    """(protocol, plane) of each panel of a one-row map figure: planar one
    per protocol, spatial the main protocol on the three projections."""
    if study.kind.figure["projections"]:
        return [(study.main, pl) for pl in PLANES]
    return [(p, (0, 1)) for p in study.workspaces]


def _row_figure(study, height: float = 4.6):
    panels = _panels(study)
    fig = new_figure(W, height)
    axs = np.atleast_1d(fig.subplots(1, len(panels)))
    return fig, axs, panels


def singular_figure(study) -> Figure:
    """The singular measure over the configurations (log colour; low =
    near-singular): planar sigma_min / sigma_max of the pose Jacobian
    d[X, Y, L·phi]/dtheta, one panel per protocol; spatial of the position
    Jacobian on the three projections. The lowest ringed red."""
    layout = study.kind.figure
    with report_style():
        fig, axs, panels = _row_figure(study)
        for ax, (p, plane) in zip(axs, panels):
            v = study.singular[p]
            pts = _tips(study, p)
            good = v[np.isfinite(v) & (v > 0)]
            lo = max(float(good.min()) if good.size else 1e-4, 1e-4)
            hi = max(float(good.max()) if good.size else 1.0, lo * 10)
            _missing(ax, pts, ~np.isfinite(v), plane, size=5)
            last = plane == panels[-1][1]
            _map(fig, ax, pts, np.maximum(v, lo), "cividis", LogNorm(lo, hi), "sigma_min / sigma_max", plane=plane,
                 size=5, order=False, bar=last, bar_ticks=4)
            if np.isfinite(v).any():
                i0 = int(np.nanargmin(np.where(np.isfinite(v), v, np.inf)))
                sel = np.zeros(len(v), bool)
                sel[i0] = True
                th = study.workspaces[p].theta0[i0]
                _rings(ax, pts, sel, plane, color=RED, size=80, lw=1.4,
                       label=f"lowest {v[i0]:.2g}\n(theta = " + ", ".join(f"{np.degrees(t):.0f}" for t in th) + "°)")
                ax.legend(loc="lower left", fontsize=7.5, framealpha=0.85)
            near = int(np.sum(v < NEAR_SINGULAR))
            ax.set_title(_panel_title(study, p, plane) + f": {near} below {NEAR_SINGULAR:g}", fontsize=9.5)
            _axes(ax, plane, equal=layout["equal"], ticks=layout["ticks"])
        what = study.kind.words["singular_of"]
        fig.suptitle(f"Singular states: smallest over largest singular value of the {what}", fontsize=10)
        place(fig, 1, len(panels), left=0.7, right=0.85, bottom=0.5, top=0.45, wgap=layout["row_wgap"])
    return fig


def feasibility_figure(study) -> Figure:
    """Statics at the study's configurations: the smallest position-cable
    tension (N; negative red: a cable would have to push; zero grey,
    positive blue), slack configurations ringed (planar, one panel per
    protocol) or crossed black (spatial, three projections). Gravity of the
    robot file, force cables at their set tension, no tip load."""
    layout = study.kind.figure
    robot = study.robot
    g = robot.gravity
    with report_style():
        fig, axs, panels = _row_figure(study)
        for ax, (p, plane) in zip(axs, panels):
            ws, fm = study.workspaces[p], study.feasibility[p]
            pts = _tips(study, p)
            with np.errstate(invalid="ignore"):
                tmin = np.where(ws.reachable & np.isfinite(fm.tension).all(axis=1), np.nanmin(fm.tension, axis=1)
                                if fm.tension.shape[1] else np.nan, np.nan)
            lim = _nanmax(np.abs(tmin))
            lim = lim if np.isfinite(lim) and lim > 0 else 1.0
            _missing(ax, pts, ~ws.reachable, plane, size=5)
            last = plane == panels[-1][1]
            _map(fig, ax, pts, tmin, tension_cmap(), Normalize(-lim, lim), "smallest position-cable tension (N)",
                 plane=plane, size=5, order="low", bar=last, bar_ticks=5)
            slack = ws.reachable & ~fm.feasible
            if slack.any():
                i, j = plane
                ax.scatter(pts[slack, i], pts[slack, j], marker="o", s=24, facecolors="none", edgecolors="k",
                           linewidths=0.7, label=f"slack cable needed: {int(slack.sum())} of {int(ws.reachable.sum())}")
                ax.legend(loc="lower left", fontsize=7.5, framealpha=0.85)
            ax.set_title(_panel_title(study, p, plane) + f": {int(slack.sum())} slack", fontsize=9.5)
            _axes(ax, plane, equal=layout["equal"], ticks=layout["ticks"])
        grav = "no gravity" if not np.any(g) else "gravity (" + ", ".join(f"{v:g}" for v in g) + ") m/s²"
        force = [t for c, t in enumerate(robot.cable_tensions) if c not in robot.position_cables]
        what = study.kind.words["force_loads"].format(grams=", ".join(f"{t / 9.80665 * 1e3:.0f}" for t in force))
        fig.suptitle(f"Statics: smallest position-cable tension ({what}, {grav}, no tip load); rings: a slack cable "
                     "is needed", fontsize=10)
        place(fig, 1, len(panels), left=0.7, right=0.85, bottom=0.5, top=0.45, wgap=layout["row_wgap"])
    return fig


def hysteresis_figure(study) -> Figure:
    """Friction in the holes: the tip's hysteresis loop width (µm, the
    largest over the position cables' ±1 mm cycles) at each configuration
    (:func:`cdsm.accuracy.statics.friction_map`; the configurations it
    cycled); grey: not reachable or a command did not settle."""
    layout = study.kind.figure
    with report_style():
        fig, axs, panels = _row_figure(study)
        for ax, (p, plane) in zip(axs, panels):
            ws, fm = study.workspaces[p], study.friction[p]
            pts = _tips(study, p)[fm.cycled]
            w = np.where(ws.reachable, fm.width, np.nan)[fm.cycled] * 1e6
            lim = _nanmax(w)
            lim = lim if np.isfinite(lim) and lim > 0 else 1.0
            _missing(ax, pts, ~np.isfinite(w), plane, size=5)
            last = plane == panels[-1][1]
            _map(fig, ax, pts, w, "viridis", Normalize(0.0, lim), "loop width (µm)", plane=plane, size=5,
                 order=True, bar=last, bar_ticks=5)
            ax.set_title(_panel_title(study, p, plane) + f": max {lim:.3g} µm", fontsize=9.5)
            _axes(ax, plane, equal=layout["equal"], ticks=layout["ticks"])
        fm0 = next(iter(study.friction.values()))
        fig.suptitle(f"Friction in the holes (mu = {fm0.mu:g}): tip hysteresis over a ±1 mm cycle of each position "
                     f"cable, E·A = {study.robot.axial_stiffness:.3g} N", fontsize=10)
        place(fig, 1, len(panels), left=0.7, right=0.85, bottom=0.5, top=0.45, wgap=layout["row_wgap"])
    return fig


def amplification_titles(study) -> dict:
    """Panel titles of :func:`amplification_figure` by map key."""
    holes, cables = study.kind.words["holes_every"], study.kind.words["cables_every"]
    return {"cable_worst": f"worst case, mm of tip per mm on {cables}",
            "cable_rms": f"RMS, mm of tip per mm (uniform ±1) on {cables}",
            "hole_worst": f"worst case, mm of tip per mm on {holes}",
            "hole_rms": f"RMS, mm of tip per mm (uniform ±1) on {holes}"}


def amplification_figure(study, protocol: str) -> Figure:
    """First-order amplification of cable-length and hole errors into the
    tip position over the configurations of ``protocol`` (analytic
    sensitivities; log colour scale; spatial: main plane)."""
    maps = study.amplification[protocol]
    pts = _tips(study, protocol)
    plane = _plane(study, protocol)
    with report_style():
        fig = new_figure(W, 8.4)
        axs = fig.subplots(2, 2, sharex=True, sharey=True)
        for ax, (key, title) in zip(axs.ravel(), amplification_titles(study).items()):
            v = maps[key]
            pos = v[np.isfinite(v) & (v > 0)]
            norm = LogNorm(max(float(pos.min()), 1e-3), max(float(pos.max()), 2e-3)) if pos.size else Normalize(0, 1)
            _missing(ax, pts, ~np.isfinite(v), plane, size=5)
            _map(fig, ax, pts, np.where(v > 0, v, np.nan), "viridis", norm, "mm / mm", plane=plane, size=6,
                 order=False, bar_ticks=5)
            ax.set_title(title, fontsize=9)
            _axes(ax, plane)
        for ax in axs.ravel():
            ax.label_outer()
        fig.suptitle(f"First-order tip-error amplification — {_title(study, protocol)}", fontsize=10)
        place(fig, 2, 2, left=0.75, right=0.85, bottom=0.5, top=0.7, wgap=1.0, hgap=0.45)
    return fig


# ---------------------------------------------------------------------------
# everything
# ---------------------------------------------------------------------------
#: Single errors a study draws one map each for: all of them up to this many,
#: else the :data:`DETAILED_SCENARIOS` with the largest errors (the overview
#: figures map every scenario, the tables list them all).
MAX_SCENARIO_FIGURES = 24
DETAILED_SCENARIOS = 12


def detailed_scenarios(study) -> List[str]:
    """Keys of the single errors that get a map of their own, in the study's
    order: every one when there are at most :data:`MAX_SCENARIO_FIGURES`,
    else the :data:`DETAILED_SCENARIOS` with the largest position error over
    the configurations (any protocol)."""
    keys = list(dict.fromkeys(r.scenario.key for r in study.scenarios))
    if len(keys) <= MAX_SCENARIO_FIGURES:
        return keys
    worst: Dict[str, float] = {}
    for r in study.scenarios:
        v = r.position
        m = float(np.nanmax(v)) if np.isfinite(v).any() else -1.0
        worst[r.scenario.key] = max(worst.get(r.scenario.key, -1.0), m)
    top = set(sorted(keys, key=lambda k: -worst[k])[:DETAILED_SCENARIOS])
    return [k for k in keys if k in top]


def figure_jobs(study, detail: bool = True, overlay: Optional[Callable] = None) -> List[FigureJob]:
    """The study's figures as jobs ``(name, make)``, costliest first:
    ``overview_<protocol>`` (and ``rotation_<protocol>`` for spatial arms),
    ``montecarlo_<protocol>``, ``amplification_<protocol>``, ``singular``,
    ``feasibility``, ``hysteresis``, ``workspace`` (with ``overlay``) and, with ``detail``,
    ``scenario_<key>`` for the single errors of :func:`detailed_scenarios`."""
    jobs: List[FigureJob] = []

    def one(name, make):
        jobs.append((name, lambda: [(name, make())]))

    for p in study.workspaces:
        one(f"overview_{p}", lambda p=p: overview_figure(study, p))
        if study.kind.figure["rotation_overview"]:
            one(f"rotation_{p}", lambda p=p: overview_figure(study, p, "rotation"))
    for p in study.monte_carlo:
        one(f"montecarlo_{p}", lambda p=p: monte_carlo_figure(study, p))
    for p in study.amplification:
        one(f"amplification_{p}", lambda p=p: amplification_figure(study, p))
    one("singular", lambda: singular_figure(study))
    one("feasibility", lambda: feasibility_figure(study))
    if study.friction:
        one("hysteresis", lambda: hysteresis_figure(study))
    one("workspace", lambda: workspace_figure(study, overlay))
    if detail:
        for k in detailed_scenarios(study):
            one(f"scenario_{file_key(k)}", lambda k=k: scenario_figure(study, k))
    return jobs


def all_figures(study, outdir: "str | os.PathLike[str]", progress: bool = False, workers: Optional[int] = None,
                detail: bool = True) -> Dict[str, str]:
    """Write the study's figures (:func:`figure_jobs`) as ``outdir/<name>.png``
    in forked worker processes where the platform forks
    (:func:`cdsm.report.figures.render_jobs`); returns {name: path}."""
    return render_jobs(lambda s: figure_jobs(s, detail), study, outdir, progress=progress, workers=workers)
