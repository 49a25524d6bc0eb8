"""Figures of the paper study (matplotlib, Agg, no pyplot global state).

Every ``*_figure`` function returns a :class:`matplotlib.figure.Figure`;
:func:`cdsm.report.figures.save` writes it as PNG. Arrays come from :class:`cdsm.paper.PaperStudy`
in SI units (m, rad); the figures show mm and degrees, as the paper's figures.

Colours follow the paper: deviation in X red, in Y blue, in phi green; in the
configuration diagrams the arm before the error is blue, after it red.
"""

from __future__ import annotations

import os
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from ..accuracy.scenarios import deviation
from ..robot import Robot
from .figures import (BLUE, GREEN, HUES, RED, colour_bar, draw_arm, file_key, hue_cmap, new_figure, render_jobs,
                      report_style, few_ticks, sym_norm, tight)

__all__ = [
    "PROTOCOL_TITLES", "scenario_figure", "overview_figure",
    "monte_carlo_figure", "singular_figure", "workspace_figure", "table2_figures",
    "singular_state_figure", "table3_figure", "all_figures", "figure_jobs", "phi0_tips", "readings_figure",
]

PROTOCOL_SHORT = {"attitude0": "attitude-0", "joint": "joint-space"}
PROTOCOL_TITLES = {
    "attitude0": "attitude-0 protocol (grid tip, phi = 0, pose IK)",
    "joint": "joint-space protocol (error at the grid angles)",
}
def _xy_mm(study, protocol: str) -> np.ndarray:
    return study.workspaces[protocol].poses[:, :2] * 1e3


def _scatter_map(fig, ax, xy, val, cmap, norm, label, size=9, order=True, bar=True):
    """Scatter of ``val`` at ``xy`` (mm), largest |val| drawn last; colour bar
    (unless ``bar`` is False: a neighbour's on the same scale)."""
    ok = np.isfinite(val)
    idx = np.where(ok)[0]
    if order:
        idx = idx[np.argsort(np.abs(val[idx]))]
    sc = ax.scatter(xy[idx, 0], xy[idx, 1], c=val[idx], cmap=cmap, norm=norm, s=size,
                    linewidths=0, rasterized=True)
    if bar:
        colour_bar(fig, sc, ax, label)
    return sc


def _axes_mm(ax, equal=False):
    ax.set_xlabel("tip X (mm)")
    ax.set_ylabel("tip Y (mm)")
    few_ticks(ax)
    if equal:
        ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.3, alpha=0.5)


def _unreachable(ax, study, protocol):
    ws = study.workspaces[protocol]
    bad = ~ws.reachable
    if bad.any():
        xy = ws.poses[bad, :2] * 1e3
        ax.scatter(xy[:, 0], xy[:, 1], s=3, c="0.82", marker=".", linewidths=0, zorder=0)


# ---------------------------------------------------------------------------
# Fig. 5 / Fig. 6: one scenario
# ---------------------------------------------------------------------------
def scenario_figure(study, key: str) -> Figure:
    """Deviation dX (red), dY (blue) and dphi (green) of scenario ``key`` over
    the workspace tip positions (mm), one row per protocol; jump points
    ringed black; unreachable grid tips (attitude-0) light grey."""
    protos = [p for p in study.workspaces if any(r.protocol == p and r.scenario.key == key
                                                 for r in study.scenarios)]
    names = ["dX (mm)", "dY (mm)", "dphi (deg)"]
    with report_style():
        fig = new_figure(15, 5.0 * len(protos) + 0.6)
        axs = np.atleast_2d(fig.subplots(len(protos), 3, sharex=True, sharey=True))
        res = {protocol: study.result(key, protocol) for protocol in protos}
        vals = {protocol: [r.dS[:, 0] * 1e3, r.dS[:, 1] * 1e3, np.degrees(r.dS[:, 2])] for protocol, r in res.items()}
        # one colour scale per column, shared by the protocols
        norms = [sym_norm(np.concatenate([vals[p][j] for p in protos])) for j in range(3)]
        lines = []
        for row, protocol in zip(axs, protos):
            r = res[protocol]
            xy = _xy_mm(study, protocol)
            ws = study.workspaces[protocol]
            for ax, v, nm, hue, norm in zip(row, vals[protocol], names, HUES, norms):
                _unreachable(ax, study, protocol)
                _scatter_map(fig, ax, xy, v, hue_cmap(hue), norm, nm)
                jp = r.jumps.point
                if jp.any():
                    ax.scatter(xy[jp, 0], xy[jp, 1], s=40, facecolors="none", edgecolors="k",
                               linewidths=0.9, label=f"jump points ({int(jp.sum())})")
                    ax.legend(loc="lower left", framealpha=0.85)
                ax.set_title(f"{PROTOCOL_SHORT.get(protocol, protocol)} — {nm.split()[0]}: max "
                             f"|{nm.split()[0]}| = {np.nanmax(np.abs(v)):.3g} {nm.split()[1].strip('()')}", color=hue)
                _axes_mm(ax)
            reach = (f"{ws.n_unreachable} tips unreachable at phi = 0 (grey)" if protocol == "attitude0"
                     else "largest |value| drawn on top")
            lines.append(f"{PROTOCOL_TITLES.get(protocol, protocol)}: {int(r.ok.sum())} of {len(r.ok)} solved; "
                         f"{reach}; {int((ws.reachable & ~r.ok).sum())} without a solution after the error")
        for ax in axs.ravel():
            ax.label_outer()
        sc = study.result(key, protos[0]).scenario
        fig.suptitle(f"{sc.label}  ({sc.figure or sc.key})\n" + "\n".join(lines), fontsize=11)
        tight(fig, "scenario")
    return fig


def overview_figure(study, protocol: str) -> Figure:
    """All single-error scenarios as thumbnails of |d(X, Y)| (mm) under
    ``protocol``; rows: cable pair / disk, columns: cable -, cable +, disk -, disk +."""
    n = study.robot.n
    with report_style():
        fig = new_figure(16, 3.3 * n + 0.8)
        axs = np.atleast_2d(fig.subplots(n, 4, sharex=True, sharey=True))
        xy = _xy_mm(study, protocol)
        for i in range(n):
            keys = [f"cable{2 * i + 1}-", f"cable{2 * i + 1}+", f"disk{i + 1}-", f"disk{i + 1}+"]
            for ax, key in zip(axs[i], keys):
                r = study.result(key, protocol)
                v = r.position_mm
                _unreachable(ax, study, protocol)
                vmax = float(np.nanmax(v)) if np.isfinite(v).any() else 1.0
                sc = _scatter_map(fig, ax, xy, v / vmax, "viridis", Normalize(0, 1), "", size=6, bar=False)
                jp = r.jumps.point
                if jp.any():
                    ax.scatter(xy[jp, 0], xy[jp, 1], s=16, facecolors="none", edgecolors="k",
                               linewidths=0.6)
                ax.set_title(f"{r.scenario.label}\nmax {vmax:.3g} mm, {int(jp.sum())} jump pts",
                             fontsize=9.5)
                ax.tick_params(labelsize=8)
                if i == n - 1:
                    ax.set_xlabel("tip X (mm)")
                if ax is axs[i][0]:
                    ax.set_ylabel("tip Y (mm)")
        fig.suptitle(f"All single-error scenarios, |d(X, Y)| — {PROTOCOL_TITLES.get(protocol, protocol)}"
                     " (black rings: jump points)", fontsize=12)
        for ax in np.ravel(axs):
            ax.label_outer()
        # lay the panels out first: the colour bar then takes its room from them
        # (tight_layout cannot place a bar that spans several axes)
        tight(fig, "overview")
        cb = fig.colorbar(sc, ax=axs, shrink=0.6, pad=0.015, aspect=40)
        cb.set_label("|dXY| / the panel's max (in its title)")
    return fig


# ---------------------------------------------------------------------------
# Fig. 7: Monte Carlo
# ---------------------------------------------------------------------------
def monte_carlo_figure(study, protocol: str) -> Figure:
    """Monte-Carlo maps under ``protocol``. Top row: mean, 95th percentile and
    max of |d(X, Y)| (mm). Bottom row (Fig. 7): mean dX (red), dY (blue), dphi (green)."""
    mc = study.monte_carlo[protocol]
    ws = study.workspaces[protocol]
    xy = ws.poses[ws.reachable, :2] * 1e3
    mean = mc.mean
    top = [(mean[:, 3] * 1e3, "mean |dXY| (mm)"), (mc.percentile(95.0) * 1e3, "95th pct |dXY| (mm)"),
           (mc.max_abs[:, 3] * 1e3, "max |dXY| (mm)")]
    bottom = [(mean[:, 0] * 1e3, "mean dX (mm)"), (mean[:, 1] * 1e3, "mean dY (mm)"),
              (np.degrees(mean[:, 2]), "mean dphi (deg)")]
    with report_style():
        fig = new_figure(15, 9.5)
        axs = fig.subplots(2, 3, sharex=True, sharey=True)
        vmax = float(np.nanmax(top[2][0]))
        for ax, (v, nm) in zip(axs[0], top):
            _scatter_map(fig, ax, xy, v, "magma_r", Normalize(0, vmax), nm, size=7)
            ax.set_title(f"{nm.replace(' (mm)', '')}: workspace max {np.nanmax(v):.3g} mm")
            _axes_mm(ax)
        for ax, (v, nm), hue in zip(axs[1], bottom, HUES):
            _scatter_map(fig, ax, xy, v, hue_cmap(hue), sym_norm(v), nm, size=7)
            ax.set_title(nm.split(" (")[0], color=hue)
            _axes_mm(ax)
        p = mc.params
        fig.suptitle(f"Monte Carlo (Fig. 7): {p.get('samples')} random groups, uniform ±"
                     f"{p['dl_tol_m'][0] * 1e3:g} mm per upper cable and ±{p['dh_tol_m'][0] * 1e3:g} mm "
                     f"per disk's holes, seed {p.get('seed')} — {PROTOCOL_TITLES.get(protocol, protocol)}\n"
                     f"{len(xy)} configurations (all reachable ones); failed solves: {int(mc.failed.sum())}; "
                     "percentile to the histogram bin (≤ 3.9 % high)", fontsize=11)
        for ax in np.ravel(axs):
            ax.label_outer()
        tight(fig, "montecarlo")
    return fig


# ---------------------------------------------------------------------------
# singular states
# ---------------------------------------------------------------------------
def singular_figure(study) -> Figure:
    """sigma_min / sigma_max of the pose Jacobian (attitude row scaled to m)
    over the workspace, per protocol (log colour scale; low = near-singular)."""
    protos = list(study.workspaces)
    with report_style():
        fig = new_figure(7.2 * len(protos), 5.6)
        axs = np.atleast_1d(fig.subplots(1, len(protos)))
        for ax, p in zip(axs, protos):
            ws = study.workspaces[p]
            sv = study.singular[p]
            ratio = np.where(ws.reachable, sv[:, -1] / np.maximum(sv[:, 0], 1e-300), np.nan)
            xy = ws.poses[:, :2] * 1e3
            _unreachable(ax, study, p)
            lo = max(float(np.nanmin(ratio[ratio > 0])) if (ratio > 0).any() else 1e-4, 1e-4)
            _scatter_map(fig, ax, xy, np.maximum(ratio, lo), "cividis",
                         LogNorm(lo, max(float(np.nanmax(ratio)), lo * 10)),
                         "sigma_min / sigma_max", size=8, order=False)
            i0 = np.nanargmin(np.where(np.isfinite(ratio), ratio, np.inf))
            ax.scatter([xy[i0, 0]], [xy[i0, 1]], s=90, facecolors="none", edgecolors=RED, linewidths=1.5,
                       label=f"lowest ratio {ratio[i0]:.2g}\n(theta = "
                             + ", ".join(f"{np.degrees(t):.0f}" for t in np.nan_to_num(ws.theta0[i0])) + " deg)")
            ax.legend(loc="lower left", framealpha=0.85)
            ax.set_title(PROTOCOL_TITLES.get(p, p))
            _axes_mm(ax)
        fig.suptitle("Singular states: conditioning of the pose Jacobian d[X, Y, L·phi]/dtheta "
                     "(all joints zero loses X, Fig. 12; for 3 joints every theta_2 = 0 is singular)",
                     fontsize=11)
        tight(fig)
    return fig


def feasibility_figure(study) -> Figure:
    """Slack-cable map: initial configurations whose upper cables are all taut
    (tension > 0 N under the robot's lower weights) vs those that need a slack
    cable, over the workspace, per protocol; colour = smallest upper tension (N)."""
    protos = list(study.feasibility)
    with report_style():
        fig = new_figure(7.2 * len(protos), 5.6)
        axs = np.atleast_1d(fig.subplots(1, len(protos)))
        for ax, p in zip(axs, protos):
            ws, fm = study.workspaces[p], study.feasibility[p]
            xy = ws.poses[:, :2] * 1e3
            tmin = np.where(ws.reachable, np.nanmin(fm.tension, axis=1), np.nan)
            _unreachable(ax, study, p)
            lim = float(np.nanmax(np.abs(tmin))) if np.isfinite(tmin).any() else 1.0
            _scatter_map(fig, ax, xy, tmin, "RdBu", Normalize(-lim, lim), "smallest upper tension (N)",
                         size=8, order=False)
            slack = ws.reachable & ~fm.feasible
            ax.scatter(xy[slack, 0], xy[slack, 1], s=40, facecolors="none", edgecolors="k", linewidths=0.8,
                       label=f"slack cable needed: {int(slack.sum())} of {int(ws.reachable.sum())}")
            ax.legend(loc="lower left", framealpha=0.85)
            ax.set_title(PROTOCOL_TITLES.get(p, p))
            _axes_mm(ax)
        w = ", ".join(f"{t / 9.80665 * 1e3:.0f}" for t in study.robot.lower_tension)
        g = study.robot.gravity
        plane = "no gravity" if not np.any(g) else f"gravity ({g[0]:g}, {g[1]:g}) m/s²"
        fig.suptitle(f"Feasibility of hybrid control: upper-cable tensions with lower weights {w} g "
                     f"({plane}, no tip load)", fontsize=11)
        tight(fig)
    return fig


def readings_figure(study) -> Figure:
    """The load readings (weight order x plane) over the ±30° joint grid: top,
    the smallest upper tension (N; black rings need a slack cable); bottom,
    the tip deviation |d(X, Y)| (µm) the elastic cables cause when the rigid
    model's lengths are commanded (grey: slack)."""
    names = list(study.readings)
    with report_style():
        fig = new_figure(5.2 * len(names), 9.4)
        axs = np.atleast_2d(fig.subplots(2, len(names), sharex=True, sharey=True))
        tmins = [np.nanmin(r.feasibility.tension, axis=1) for r in study.readings.values()]
        lim = max(float(np.nanmax(np.abs(t))) for t in tmins)
        el = [np.hypot(r.elastic[:, 0], r.elastic[:, 1]) * 1e6 for r in study.readings.values()]
        emax = max((float(np.nanmax(e)) for e in el if np.isfinite(e).any()), default=1.0)
        for j, (name, r) in enumerate(study.readings.items()):
            fm = r.feasibility
            xy = fm.pose[:, :2] * 1e3
            ax = axs[0, j]
            _scatter_map(fig, ax, xy, tmins[j], "RdBu", Normalize(-lim, lim), "smallest upper tension (N)",
                         size=7, order=False, bar=j == len(names) - 1)
            slack = ~fm.feasible
            ax.scatter(xy[slack, 0], xy[slack, 1], s=22, facecolors="none", edgecolors="k", linewidths=0.5)
            w = "/".join(f"{v:.0f}" for v in r.weights_g)
            ax.set_title(f"{name}: {r.plane}, {w} g\nslack cable needed: {100 * fm.slack_fraction:.1f} %")
            _axes_mm(ax)
            ax = axs[1, j]
            ax.scatter(xy[slack, 0], xy[slack, 1], s=3, c="0.82", marker=".", linewidths=0)
            _scatter_map(fig, ax, xy, el[j], "viridis", Normalize(0, emax), "elastic |d(X, Y)| (µm)", size=7,
                         bar=j == len(names) - 1)
            mx = float(np.nanmax(el[j])) if np.isfinite(el[j]).any() else float("nan")
            ax.set_title(f"elastic cables: max {mx:.0f} µm (taut configurations)")
            _axes_mm(ax)
        for ax in np.ravel(axs):
            ax.label_outer()
        fig.suptitle("The paper's loads, four readings, over the ±30° joint grid (E A of the robot file's cable)",
                     fontsize=11.5)
        tight(fig)
    return fig


AMPLIFICATION_TITLES = {
    "cable_worst": "worst case, mm of tip per mm on every upper cable",
    "cable_rms": "RMS, mm of tip per mm (uniform ±1) on every upper cable",
    "hole_worst": "worst case, mm of tip per mm on every disk's hole height",
    "hole_rms": "RMS, mm of tip per mm (uniform ±1) on every hole height",
}


def amplification_figure(study, protocol: str) -> Figure:
    """First-order amplification of cable-length and hole-height errors into
    the tip position over the workspace (analytic sensitivities, Rust core)."""
    maps = study.amplification[protocol]
    xy = maps["xy"] * 1e3
    with report_style():
        fig = new_figure(12.5, 9.4)
        axs = fig.subplots(2, 2, sharex=True, sharey=True)
        for ax, (key, title) in zip(axs.ravel(), AMPLIFICATION_TITLES.items()):
            v = maps[key]
            pos = v[np.isfinite(v) & (v > 0)]
            norm = LogNorm(max(float(pos.min()), 1e-3), float(pos.max())) if pos.size else Normalize(0, 1)
            _unreachable(ax, study, protocol)
            _scatter_map(fig, ax, xy, np.where(v > 0, v, np.nan), "viridis", norm, "mm / mm", size=7,
                         order=False)
            ax.set_title(title, fontsize=9.5)
            _axes_mm(ax)
        fig.suptitle(f"First-order tip-error amplification — {PROTOCOL_TITLES.get(protocol, protocol)}",
                     fontsize=11)
        for ax in np.ravel(axs):
            ax.label_outer()
        tight(fig, "amplification")
    return fig


# ---------------------------------------------------------------------------
# Fig. 9: workspace
# ---------------------------------------------------------------------------
def phi0_tips(robot: Robot, step_deg: float = 1.0, max_points: int = 200_000) -> np.ndarray:
    """Tips (m) of phi = 0 configurations within the joint limits, (K, 2):
    joints 1..n-1 on a ``step_deg`` grid (uniform random samples when that
    grid would exceed ``max_points``), the last joint closing phi = 0."""
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


def workspace_figure(study) -> Figure:
    """Fig. 9-like workspace (mm): tips of the ±30° joint grid (any phi), tips
    reachable at phi = 0 within the joint limits, the paper's experimental
    range X 0.19–0.23 m, Y −0.1–0.1 m, and the Table 3 points."""
    robot = study.robot
    with report_style():
        fig = new_figure(8.0, 9.5)
        ax = fig.subplots()
        ws = next(iter(study.workspaces.values()))
        grid_tips = robot.fk(ws.grid)[:, :2] * 1e3
        ax.scatter(grid_tips[:, 0], grid_tips[:, 1], s=4, c="0.6", linewidths=0,
                   label=f"±30° grid tips, any phi ({len(grid_tips)})")
        a0 = study.workspaces.get("attitude0")
        if a0 is not None:
            g = a0.poses[a0.reachable, :2] * 1e3
            ax.scatter(g[:, 0], g[:, 1], s=5, c=BLUE, linewidths=0,
                       label=f"grid tips reachable at phi = 0 ({len(g)}; {a0.n_unreachable} not)")
        t = phi0_tips(robot) * 1e3
        if len(t):
            lim = np.degrees(robot.joint_limits[:, 1].max())
            ax.scatter(t[:, 0], t[:, 1], s=2, c=GREEN, alpha=0.35, linewidths=0,
                       label=f"phi = 0 within the joint limits (±{lim:.0f}°)")
        if study.table3 is not None:
            ax.add_patch(Rectangle(
                (190, -100), 40, 200, fill=False, ec="k", ls="--", lw=1.2,
                label="paper's experimental range (Fig. 9)"))
            p = study.table3["pose"] * 1e3
            lim_ok = study.table3["within_limits"]
            ax.scatter(p[lim_ok, 0], p[lim_ok, 1], marker="*", s=110, c=RED, ec="k", lw=0.5, zorder=5,
                       label="Table 3 points within the limits")
            ax.scatter(p[~lim_ok, 0], p[~lim_ok, 1], marker="*", s=110, c="w", ec=RED, lw=1.2, zorder=5,
                       label="Table 3 points beyond ±35° (paper's branch)")
            for lab, q in zip(study.table3["point"], p):
                ax.annotate(str(lab), q[:2], xytext=(4, 3), textcoords="offset points", fontsize=8)
        _axes_mm(ax, equal=True)
        ax.legend(loc="upper left", fontsize=8.5, markerscale=2, framealpha=0.9)
        grid = next(iter(study.workspaces.values())).describe_grid()
        ax.set_title(f"Workspace (Fig. 9): joint grid {grid} and the phi = 0 reach")
        tight(fig)
    return fig


# ---------------------------------------------------------------------------
# Table 2 and Fig. 12: configuration diagrams
# ---------------------------------------------------------------------------
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
        txt += (f"\ndX {dS[0] * 1e3:+.3f} mm, dY {dS[1] * 1e3:+.3f} mm, "
                f"dphi {np.degrees(dS[2]):+.3f}°")
    ax.set_title(txt, fontsize=9.5)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("X (mm)")
    ax.set_ylabel("Y (mm)")
    ax.grid(True, lw=0.3, alpha=0.5)


def _table2_groups(study) -> Dict[Tuple, List[dict]]:
    groups: Dict[Tuple, List[dict]] = {}
    for e in study.table2:
        groups.setdefault((tuple(np.round(e["pose"], 6)), e["condition"]), []).append(e)
    return groups


def table2_figures(study, which: Optional[List[int]] = None) -> List[Tuple[str, Figure]]:
    """Table 2 configuration diagrams: one figure per (pose, condition) (all,
    or the groups ``which``), one panel per error; blue before, red after, red
    dashed after with the joint angle change exaggerated ×10. Returns
    [(name, Figure)]."""
    out = []
    for gi, ((pose, cond), items) in enumerate(_table2_groups(study).items()):
        if which is not None and gi not in which:
            continue
        with report_style():
            cols = min(len(items), 2)
            rows = -(-len(items) // cols)
            fig = new_figure(6.6 * cols, 5.0 * rows + 1.1)
            axs = np.atleast_1d(fig.subplots(rows, cols)).ravel()
            for ax, e in zip(axs, items):
                _diagram(ax, study.robot, e["theta0"], e["theta"], e["ok"], e["error"],
                         target=e["pose"], dS=e["dS"])
            for ax in axs[len(items):]:
                ax.set_visible(False)
            for ax in axs[:len(items)]:
                ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
            th = ", ".join(f"{np.degrees(t):.1f}" for t in items[0]["theta0"])
            fig.suptitle(f"Table 2 — pose [{pose[0]:g} m, {pose[1]:g} m, {pose[2]:g} rad], {cond}\n"
                         f"initial theta = ({th})° (pose IK, theta_2 ≤ 0 branch); + marks the commanded tip; "
                         "blue before, red after the error", fontsize=11)
            tight(fig, "table2")
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
        fig = new_figure(14, 5.2)
        ax1, ax2 = fig.subplots(1, 2, gridspec_kw=dict(width_ratios=[1.6, 1]))
        _diagram(ax1, robot, t0[0], theta, ok,
                 f"{dL * 1e3:+g} mm on cable 1 at theta = 0 (tip {robot.fk(t0[0])[0] * 1e3:.0f}, 0 mm)",
                 dS=ds)
        ax1.legend(loc="upper left", fontsize=8.5)
        tip0 = robot.fk(t0[0])[:2] * 1e3
        tip1 = robot.fk(theta)[:2] * 1e3
        ax2.plot(*tip0, "o", color=BLUE, ms=9, label="tip before")
        ax2.plot(*tip1, "o", color=RED, ms=9, label="tip after")
        ax2.annotate("", tip1, tip0, arrowprops=dict(arrowstyle="->", lw=1.5))
        ax2.set_xlim(tip0[0] - 3, tip0[0] + 3)
        ax2.set_ylim(tip0[1] - 1, tip0[1] + 3.5)
        ax2.set_aspect("equal")
        ax2.grid(True, lw=0.3)
        ax2.set_xlabel("X (mm)")
        ax2.set_ylabel("Y (mm)")
        ax2.legend(loc="upper left")
        ax2.set_title(f"tip, zoomed: dX = {ds[0] * 1e3:+.4f} mm, dY = {ds[1] * 1e3:+.4f} mm\n"
                      f"singular values of d[X,Y]/dtheta: " + ", ".join(f"{s * 1e3:.3g}" for s in sv)
                      + " mm/rad (X lost)", fontsize=9.5)
        fig.suptitle("Fig. 12 — singular state: all joints zero; dX/dtheta = 0 (the pose Jacobian loses X), "
                     "so dX is second order", fontsize=11)
        tight(fig)
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
        fig = new_figure(12, 7.5)
        axs = fig.subplots(2, 1, sharex=True)
        for j, (ax, nm) in enumerate(zip(axs, ["dX", "dY"])):
            w = 0.27
            ax.bar(x - w, t["measured"][:, j] * 1e3, w, color="0.55", label="measured (paper's prototype)")
            ax.bar(x, t["ours"][:, j] * 1e3, w, color=HUES[j], label="ours (theta_2 ≤ 0 branch)")
            ax.bar(x + w, t["paper"][:, j] * 1e3, w, color="w", ec=HUES[j], hatch="//",
                   label="paper's theoretical")
            diff = np.abs(t["ours_plain_seed"][:, j] - t["ours"][:, j]) > 1e-6
            if diff.any():
                ax.scatter(x[diff], t["ours_plain_seed"][diff, j] * 1e3, marker="D", s=45,
                           facecolors="none", edgecolors="k", zorder=4,
                           label="ours, plain theta = 0 seed (mirror branch)")
            ax.axhline(0, color="k", lw=0.6)
            ax.set_ylabel(f"{nm} (mm)")
            ax.grid(True, axis="y", lw=0.3)
            ax.set_title(f"{nm}: largest |ours − paper| = "
                         f"{np.abs(t['ours'][:, j] - t['paper'][:, j]).max() * 1e3:.1e} mm, "
                         f"largest |measured − ours| = "
                         f"{np.abs(t['measured'][:, j] - t['ours'][:, j]).max() * 1e3:.3f} mm")
            ax.legend(loc="upper right", fontsize=8.5)
        axs[1].set_xticks(x)
        axs[1].set_xticklabels([f"{lab}\n({p[0] * 1e3:.0f}, {p[1] * 1e3:.0f})"
                                for lab, p in zip(labels, t["pose"])])
        axs[1].set_xlabel("experiment point (commanded tip X, Y in mm, phi = 0)")
        fig.suptitle("Table 3 — tip displacement for −1 mm on cable 1: measured vs ours vs paper "
                     "(attitude-0 pose IK)", fontsize=11.5)
        tight(fig)
    return fig


# ---------------------------------------------------------------------------
# everything
# ---------------------------------------------------------------------------
def figure_jobs(study) -> List[Tuple[str, Callable[[], List[Tuple[str, Figure]]]]]:
    """The figures of the study as jobs ``(name, make)``, costliest first;
    ``make()`` returns ``[(file name, Figure)]``."""
    jobs: List[Tuple[str, Callable[[], List[Tuple[str, Figure]]]]] = []

    def one(name, make):
        jobs.append((name, lambda: [(name, make())]))

    for p in study.workspaces:
        one(f"overview_{p}", lambda p=p: overview_figure(study, p))
    if study.readings:
        one("readings", lambda: readings_figure(study))
    for p in study.monte_carlo:
        one(f"montecarlo_{p}", lambda p=p: monte_carlo_figure(study, p))
    for g in range(len(_table2_groups(study))):
        jobs.append((f"table2_{g + 1}", lambda g=g: table2_figures(study, [g])))
    for p in study.amplification:
        one(f"amplification_{p}", lambda p=p: amplification_figure(study, p))
    one("singular", lambda: singular_figure(study))
    if study.feasibility:
        one("feasibility", lambda: feasibility_figure(study))
    one("workspace", lambda: workspace_figure(study))
    one("fig12_singular_state", lambda: singular_state_figure(study))
    if study.table3 is not None:
        one("table3", lambda: table3_figure(study))
    for k in dict.fromkeys(r.scenario.key for r in study.scenarios):
        one(f"scenario_{file_key(k)}", lambda k=k: scenario_figure(study, k))
    return jobs


def all_figures(study, outdir: "str | os.PathLike[str]", progress: bool = False,
                workers: Optional[int] = None) -> Dict[str, str]:
    """Write every figure of the study as ``outdir/<name>.png``; returns
    {name: path}. ``workers`` processes render them (default: one per core;
    forked, so only where the platform forks — elsewhere one). Shows a
    progress line when ``progress`` (:func:`cdsm.report.figures.render_jobs`)."""
    return render_jobs(figure_jobs, study, outdir, progress=progress, workers=workers)
