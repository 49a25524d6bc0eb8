"""The report of the accuracy study (``cdsm paper``) of a robot of either
kind: figures (:mod:`cdsm.report.study_figures`), CSV tables (SI units),
Markdown and a self-contained HTML page that opens with its headline — the
answers in numbers — and a table of contents, each figure in the section
that discusses it.

Every number in the text is computed from the :class:`cdsm.study.Study`;
nothing is hard-coded, and a number that does not exist is written "—" or
explained, never ``nan``. :class:`StudyReport` builds the report; the seed
paper's report (:mod:`cdsm.report.paper`) extends it with the paper's
sections for a study of the paper's geometry. :func:`cdsm.report.write`
picks the right one.
"""

from __future__ import annotations

import os
from typing import Callable, Dict, List, Optional, Tuple

import numpy as np

from .. import __version__
from ..accuracy.tolerance import pooled_percentile
from ..accuracy.workspace import MIN_LINE, REASONS
from ..calibration.measurements import commanded_cables
from ..display import degrees
from ..files import run_directory
from ..study import DEFAULT_SOLVES, NEAR_SINGULAR, PROTOCOL_NAMES, finite_rms, worst_configurations
from . import study_figures
from .document import HEADLINE, Document, literal
from .figures import FigureJob, file_key, render_pngs

__all__ = ["StudyReport", "write", "headline", "jump_words", "scenario_rows", "jump_rows", "mc_rows",
           "montecarlo_rows", "configuration_rows", "mm", "nanmax", "fmt", "sci"]


# ---------------------------------------------------------------------------
# numbers and their words
# ---------------------------------------------------------------------------
def nanmax(v) -> float:
    """The largest finite value (NaN when there is none)."""
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    return float(v.max()) if len(v) else float("nan")


def _nanmin(v) -> float:
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    return float(v.min()) if len(v) else float("nan")


def sci(x: float, nd: int = 1) -> str:
    """``x`` in scientific notation without a padded exponent (5.6e-5), "—" when not finite."""
    s = fmt(x, nd, "e")
    if s == "—":
        return s
    mant, exp = s.split("e")
    return f"{mant}e{int(exp)}"


def fmt(x, nd: int = 3, spec: str = "f") -> str:
    """``x`` with ``nd`` digits (``spec`` "f", "g" or "e"), "—" when it is
    not a finite number."""
    try:
        ok = x is not None and np.isfinite(x)
    except TypeError:
        ok = False
    return f"{x:.{nd}{spec}}" if ok else "—"


def mm(x_m, nd: int = 3) -> str:
    """A length in m as "<value> mm" ("—" when not finite)."""
    s = fmt(None if x_m is None else x_m * 1e3, nd)
    return s if s == "—" else f"{s} mm"


def _pct(a: float, nd: int = 1) -> str:
    s = fmt(None if a is None else 100.0 * a, nd)
    return s if s == "—" else f"{s} %"


def _angles(theta) -> str:
    return ", ".join(fmt(np.degrees(t), 0) for t in theta) + "°"


def _pname(p: str) -> str:
    return PROTOCOL_NAMES.get(p, p)


def _cell(spec: str, row: dict):
    """One cell of a kind's report table (:attr:`cdsm.kinds.Kind.report_tables`)
    from a row of the study's rows: ``"mm:a,b"`` / ``"deg:a/b"`` the columns
    in mm or degrees joined by ``", "`` / ``" / "``; ``"protocol"`` its
    name; ``"label_figure"`` the label and the paper's figure; ``"solved_of"``
    solved / configurations; another name the column as it is."""
    unit, _, keys = spec.rpartition(":")
    if unit:
        sep = " / " if "/" in keys else ", "
        scale = (lambda v: v * 1e3) if unit == "mm" else np.degrees
        return sep.join(fmt(scale(row[k])) for k in keys.replace("/", ",").split(","))
    if spec == "protocol":
        return _pname(row["protocol"])
    if spec == "label_figure":
        return row["label"] + (f" ({row['figure']})" if row["figure"] else "")
    if spec == "solved_of":
        return f"{row['solved']}/{row['configurations']}"
    return row[spec]


def _kind_table(doc: Document, spec, rows: List[dict], q: str) -> None:
    """A kind's report table (``spec``: (header template over ``q``, cell)
    pairs, :func:`_cell`) over ``rows``; nothing for an empty ``spec``."""
    if spec:
        doc.table([h.format(q=q) for h, _ in spec], [[_cell(c, r) for _, c in spec] for r in rows])


def _q(study) -> str:
    """The position error's name: |d(X, Y)| (planar) or |d(X, Y, Z)|."""
    return study.kind.norm_label


def _slug(study) -> str:
    return study.kind.norm_slug


# ---------------------------------------------------------------------------
# rows (SI units): the CSV files
# ---------------------------------------------------------------------------
def _row(spec, value) -> dict:
    """A CSV row of the columns ``spec`` (``(name, key)`` pairs of a kind's
    ``csv``): ``value(what, index)`` for each key ``what[:index]``."""
    row = {}
    for name, key in spec:
        what, _, index = key.partition(":")
        row[name] = value(what, int(index) if index else None)
    return row


#: The values of ``scenarios.csv`` by key (:attr:`cdsm.kinds.Kind.csv`): f(study, result, workspace, index).
_SCENARIO_VALUES = {
    "key": lambda st, r, ws, i: r.scenario.key,
    "label": lambda st, r, ws, i: r.scenario.label,
    "figure": lambda st, r, ws, i: r.scenario.figure,
    "protocol": lambda st, r, ws, i: r.protocol,
    "error": lambda st, r, ws, i: r.scenario.error,
    "cable": lambda st, r, ws, i: r.scenario.cable + 1,
    "sign": lambda st, r, ws, i: int(r.scenario.sign),
    "size": lambda st, r, ws, i: r.scenario.size,
    "configurations": lambda st, r, ws, i: len(r.ok),
    "solved": lambda st, r, ws, i: int(r.ok.sum()),
    "unreachable": lambda st, r, ws, i: ws.n_unreachable,
    "no_solution": lambda st, r, ws, i: int((ws.reachable & ~r.ok).sum()),
    "rms_position": lambda st, r, ws, i: finite_rms(r.position),
    "max_position": lambda st, r, ws, i: nanmax(r.position),
    "max_abs": lambda st, r, ws, i: nanmax(np.abs(r.dS[:, i])),
    "rms_rotation": lambda st, r, ws, i: finite_rms(r.rotation),
    "max_rotation": lambda st, r, ws, i: nanmax(r.rotation),
    "jump_points": lambda st, r, ws, i: r.jump_count,
    "jump_pairs": lambda st, r, ws, i: int(r.jumps.edge_jump.sum()),
    "near_singular_jumps": lambda st, r, ws, i: int((r.jumps.point & (st.singular[r.protocol] < NEAR_SINGULAR))
                                                    .sum()),
}


def scenario_rows(study) -> List[dict]:
    """One row per scenario and protocol (m, rad), the columns of the
    kind's ``csv["scenarios"]``. Planar arms: label, figure, protocol,
    counts, RMS and max |d(X, Y)|, max |dX|, |dY|, |dphi|, jump points and
    (grid protocols) their reasons (``jumps_*`` and ``jump_edges``, for
    ``jumps.csv``). Spatial arms: kind, cable, sign, error, counts, RMS and
    max |d(X, Y, Z)|, max |dX|, |dY|, |dZ|, RMS and max rotation, jump points
    and pairs, those at near-singular configurations."""
    spec = study.kind.csv["scenarios"]
    rows = []
    for r in study.scenarios:
        ws = study.workspaces[r.protocol]
        row = _row(spec, lambda what, i: _SCENARIO_VALUES[what](study, r, ws, i))
        if hasattr(r.jumps, "counts"):
            cnt = r.jumps.counts()
            row.update({f"jumps_{k.replace(' ', '_').replace('-', '_')}": int(cnt.get(k, 0)) for k in REASONS})
        rows.append(row)
    return rows


def jump_rows(study) -> List[dict]:
    """``jumps.csv``: per scenario and protocol the jump points and pairs;
    grid protocols by reason, sampled ones the jump points at near-singular
    configurations."""
    out = []
    for row, r in zip(scenario_rows(study), study.scenarios):
        base = dict(scenario=row["scenario"], protocol=row["protocol"], jump_points=row["jump_points"],
                    jump_pairs=int(r.jumps.edge_jump.sum()))
        if hasattr(r.jumps, "counts"):
            base.update({k: v for k, v in row.items() if k.startswith("jumps_")})
        else:
            base["jump_points_near_singular"] = int((r.jumps.point & (study.singular[r.protocol] < NEAR_SINGULAR))
                                                    .sum())
        out.append(base)
    return out


def mc_rows(study) -> List[dict]:
    """One summary row per protocol's Monte Carlo (m, rad): configurations,
    samples, failed solves (and the configurations they hit), mean of the
    mean, max mean, max 95th percentile, pooled percentiles and max of
    |d position|; planar the max |mean dX|, |mean dY|, |mean dphi|; the
    share of converged samples that need a slack cable."""
    rows = []
    k = study.kind.norm
    for p, mc in study.monte_carlo.items():
        failed = int(mc.failed.sum())
        total = int(mc.count.sum()) + failed
        mean = mc.mean
        with np.errstate(invalid="ignore"):
            mean_of_mean = float(np.nanmean(mean[:, k])) if np.isfinite(mean[:, k]).any() else float("nan")
        row = dict(protocol=p, configurations=len(mc.count), samples=mc.params.get("samples"),
                   seed=mc.params.get("seed"), attempted=total, failed=failed,
                   failed_configurations=int((mc.failed > 0).sum()),
                   mean_of_mean_m=mean_of_mean, max_mean_m=nanmax(mean[:, k]),
                   max_p95_m=nanmax(mc.percentile(95.0)), max_m=nanmax(mc.max_abs[:, k]),
                   pooled_p50_m=pooled_percentile(mc, 50.0), pooled_p95_m=pooled_percentile(mc, 95.0),
                   pooled_p99_m=pooled_percentile(mc, 99.0),
                   slack_share=(float(mc.slack.sum() / mc.count.sum()) if mc.slack is not None and mc.count.sum()
                                else float("nan")),
                   slack_configurations=int((mc.slack > 0).sum()) if mc.slack is not None else 0)
        extremes = {"max_abs_mean": lambda i: nanmax(np.abs(mean[:, i])), "max_mean": lambda i: nanmax(mean[:, i])}
        row.update(_row(study.kind.csv["mc_summary"], lambda what, i: extremes[what](i)))
        rows.append(row)
    return rows


#: The integer columns of ``montecarlo.csv`` (the others are floats).
_MC_CAST = {"samples": int, "failed": int}


def montecarlo_rows(study) -> List[dict]:
    """``montecarlo.csv``: one row per protocol and configuration: its
    angles (rad), tip (m) and the Monte-Carlo statistics (m, rad)."""
    rows = []
    spec = study.kind.csv["montecarlo"]
    for p, mc in study.monte_carlo.items():
        ws = study.workspaces[p]
        pose = ws.poses[ws.reachable]
        columns = {"tip": pose, "mean": mc.mean, "max": mc.max_abs, "std": mc.std, "p95": mc.percentile(95.0),
                   "samples": mc.count, "failed": mc.failed}
        for i in range(len(mc.count)):
            r = dict(protocol=p)
            for k, v in enumerate(mc.theta0[i]):
                r[f"theta{k + 1}_rad"] = float(v)
            r.update(_row(spec, lambda what, j, i=i: _MC_CAST.get(what, float)(
                columns[what][i] if j is None else columns[what][i, j])))
            rows.append(r)
    return rows


def configuration_rows(study) -> List[dict]:
    """``configurations.csv``: one row per protocol and configuration:
    angles (rad), pose (m, rad), reachable, singular measure, statics
    (position-cable tensions, N; held taut), the worst single error (m) and
    its scenario, whether any scenario has a jump there, and the Monte
    Carlo's 95th percentile (m), failed solves and slack samples."""
    slug = _slug(study)
    cables = commanded_cables(study.robot)
    names = study.kind.pose_columns
    rows = []
    for p, ws in study.workspaces.items():
        res = study.results(p)
        pos = np.stack([r.position for r in res], axis=1)
        keys = [r.scenario.key for r in res]
        jump = np.any([r.jumps.point for r in res], axis=0)
        fm = study.feasibility[p]
        mc = study.monte_carlo[p]
        where = np.full(len(ws.grid), -1)
        where[np.flatnonzero(ws.reachable)] = np.arange(len(mc.count))
        p95 = mc.percentile(95.0)
        for i in range(len(ws.grid)):
            r = dict(protocol=p)
            r.update({f"theta{k + 1}_rad": float(v) for k, v in enumerate(ws.theta0[i])})
            r.update({nm: float(v) for nm, v in zip(names, ws.poses[i])})
            ok = bool(ws.reachable[i])
            r.update(reachable=ok, singular_measure=float(study.singular[p][i]),
                     feasible=bool(fm.feasible[i]) and ok)
            for c, t in zip(cables, fm.tension[i]):
                r[f"tension_cable{c + 1}_n"] = float(t) if ok else float("nan")
            row = pos[i]
            fin = np.isfinite(row)
            w = int(np.argmax(np.where(fin, row, -np.inf))) if fin.any() else -1
            j = where[i]
            r.update({f"worst_single_{slug}_m": float(row[w]) if w >= 0 else float("nan"),
                      "worst_single_scenario": keys[w] if w >= 0 else "", "jump_point": bool(jump[i]),
                      f"mc_p95_{slug}_m": float(p95[j]) if j >= 0 else float("nan"),
                      "mc_failed": int(mc.failed[j]) if j >= 0 else 0,
                      "mc_slack": int(mc.slack[j]) if j >= 0 and mc.slack is not None else 0})
            rows.append(r)
    return rows


def friction_rows(study) -> List[dict]:
    """``friction.csv``: one row per protocol and reachable configuration:
    angles (rad), the position cables' tensions at the actuators with friction
    pulling and releasing (N), whether each state holds every cable taut, the
    hysteresis loop width of each position cable's ±1 mm cycle and the
    largest (m); ``mu`` the coefficient."""
    rows = []
    cables = study.robot.position_cables
    for p, ws in study.workspaces.items():
        fm = study.friction.get(p)
        if fm is None:
            continue
        for i in np.flatnonzero(ws.reachable):
            r = dict(protocol=p, mu=fm.mu)
            r.update({f"theta{k + 1}_rad": float(v) for k, v in enumerate(ws.theta0[i])})
            for c, tp, tr in zip(cables, fm.pull[i], fm.release[i]):
                r[f"pull_cable{c + 1}_n"] = float(tp)
                r[f"release_cable{c + 1}_n"] = float(tr)
            r.update(feasible_pull=bool(fm.feasible_pull[i]), feasible_release=bool(fm.feasible_release[i]))
            for c, w in zip(cables, fm.loop[i]):
                r[f"loop_cable{c + 1}_m"] = float(w)
            r["loop_width_m"] = float(fm.width[i])
            rows.append(r)
    return rows


#: The least tip movement (m) by a hole error that the ratio "holes against
#: lengths" divides by: below it the hole error acts to second order or not
#: at all and the ratio measures rounding (1e-17 m), not the arm.
RATIO_FLOOR_M = 1e-6


def jump_words(h: Dict[str, object], p: str) -> str:
    """The jumps of protocol ``p`` from the :func:`headline` numbers ``h``,
    in the words the report and the command line both use: the
    configurations on a jump (each once) and the jump points (a
    configuration once per scenario that jumps there)."""
    return (f"{h[f'jump_configurations_{p}']} configurations on a jump in {h[f'jump_scenarios_{p}']} of "
            f"{h[f'scenarios_{p}']} scenarios ({h[f'jump_points_{p}']} jump points: a configuration counted once "
            "per scenario that jumps there)")


def headline(study) -> Dict[str, object]:
    """The headline numbers (SI) of the study, for the report's first
    section and the command line: per protocol ``p`` the unreachable count,
    the largest single error ``worst_single_m_p`` (|d position|, m) and its
    scenario, the largest rotation, jump points (summed over scenarios) and
    jump configurations, the Monte Carlo's largest error, largest
    per-configuration 95th percentile, pooled 95th percentile, failed solves
    (of attempted), slack share; the singular minimum and near-singular
    count; the share held taut; and the error budget's top group, its share,
    the linear 95th percentile and the common tolerance scale for the
    target."""
    out: Dict[str, object] = dict(kind=study.kind, protocols=study.protocols)
    aliases = study.kind.headline_aliases  # the names of cdsm 0.2's planar summary
    for p, ws in study.workspaces.items():
        res = study.results(p)
        worst = [(nanmax(r.position), r.scenario.key) for r in res]
        w = max(worst, key=lambda t: t[0] if np.isfinite(t[0]) else -1.0) if worst else (float("nan"), "")
        out[f"unreachable_{p}"] = ws.n_unreachable
        out[f"configurations_{p}"] = len(ws.grid)
        out[f"worst_single_m_{p}"] = w[0]
        out[f"worst_single_scenario_{p}"] = w[1]
        out[f"worst_single_rotation_rad_{p}"] = max((nanmax(r.rotation) for r in res), default=float("nan"))
        out[f"jump_points_{p}"] = sum(r.jump_count for r in res)
        out[f"jump_configurations_{p}"] = int(np.any([r.jumps.point for r in res], axis=0).sum()) if res else 0
        out[f"jump_scenarios_{p}"] = sum(r.jump_count > 0 for r in res)
        out[f"scenarios_{p}"] = len(res)
        s = study.singular[p]
        out[f"singular_min_{p}"] = _nanmin(s)
        out[f"near_singular_{p}"] = int(np.sum(s < NEAR_SINGULAR))
        fm = study.feasibility[p]
        out[f"taut_share_{p}"] = float(np.mean(fm.feasible[ws.reachable])) if ws.reachable.any() else float("nan")
    for row in mc_rows(study):
        p = row["protocol"]
        out[f"mc_max_m_{p}"] = row["max_m"]
        out[f"mc_max_p95_m_{p}"] = row["max_p95_m"]
        out[f"mc_pooled_p95_m_{p}"] = row["pooled_p95_m"]
        out[f"mc_failed_{p}"] = row["failed"]
        out[f"mc_attempted_{p}"] = row["attempted"]
        out[f"mc_failed_configurations_{p}"] = row["failed_configurations"]
        out[f"mc_slack_share_{p}"] = row["slack_share"]
        out.update({f"{alias}_{p}": out[f"{name}_{p}"] for alias, name in aliases["mc"]})
    for p in study.workspaces:
        out.update({f"{alias}_{p}": out[f"{name}_{p}"] for alias, name in aliases["single"]})
    b = study.budget
    if b is not None and len(b.share) and b.share.sum() > 0:
        top = int(np.argmax(b.share))
        out.update(budget_top_group=b.groups[top], budget_top_share=float(b.share[top]), linear_p95_m=b.linear_m,
                   target_m=study.params["target_m"],
                   tolerance_scale_for_target=float(study.params["target_m"] / b.linear_m)
                   if b.linear_m > 0 else float("nan"))
    return out


# ---------------------------------------------------------------------------
# the report
# ---------------------------------------------------------------------------
Section = Tuple[str, str, Callable[[Document], None]]


class StudyReport:
    """The report of a :class:`cdsm.study.Study` (either kind). Subclasses
    (the paper's report) add sections (:meth:`outline`), headline answers
    (:meth:`headline_items`), CSV tables (:meth:`tables`) and figures
    (:meth:`figure_jobs`)."""

    #: the run manifest's command name
    command = "cdsm paper"
    #: the files the report writes beside ``figures/`` (:meth:`tables`, then the report itself)
    FILES = ("scenarios.csv", "jumps.csv", "montecarlo.csv", "configurations.csv", "friction.csv", "report.md",
             "report.html")

    def __init__(self, study, detail: bool = True):
        self.study = study
        self.robot = study.robot
        self.detail = bool(detail)
        self.numbers = headline(study)

    # -- names ---------------------------------------------------------------
    def title(self) -> str:
        return f"Tip-positioning accuracy of {literal(self.robot.name)}"

    def html_title(self) -> str:
        return f"cdsm accuracy study — {self.robot.name}"

    # -- figures --------------------------------------------------------------
    def workspace_overlay(self) -> Optional[Callable]:
        return None

    def figure_jobs(self) -> List[FigureJob]:
        return study_figures.figure_jobs(self.study, detail=self.detail, overlay=self.workspace_overlay())

    # -- CSV --------------------------------------------------------------------
    def tables(self) -> Dict[str, List[dict]]:
        """{file name: rows} of the CSV files."""
        srows = scenario_rows(self.study)
        return {"scenarios.csv": [{k: v for k, v in r.items() if not k.startswith("jumps_") and k != "jump_edges"}
                                  for r in srows],
                "jumps.csv": jump_rows(self.study),
                "montecarlo.csv": montecarlo_rows(self.study),
                "configurations.csv": configuration_rows(self.study),
                "friction.csv": friction_rows(self.study)}

    def file_notes(self) -> List[str]:
        q = _q(self.study)
        return [f"`scenarios.csv` — per single error and protocol: solved counts, RMS and max {q}, max per axis "
                "(m, rad), jump points",
                "`jumps.csv` — jump points per scenario and protocol (grid protocols by reason)",
                f"`montecarlo.csv` — per protocol and configuration: joint angles (rad), tip (m), Monte-Carlo mean, "
                f"95th percentile and max of {q} (m), failed solves",
                "`friction.csv` — per protocol and reachable configuration: the position tensions with friction "
                "pulling and releasing (N), taut in each state, the hysteresis loop width of every position cable's "
                "±1 mm cycle (m)",
                "`configurations.csv` — per protocol and configuration: joint angles, pose, singular measure, "
                "position-cable tensions (N), the worst single error and the Monte Carlo's 95th percentile (m), "
                "failed and slack samples",
                "`figures/*.png` — every figure of this report"]

    # -- the document -----------------------------------------------------------
    def intro(self) -> str:
        st, r = self.study, self.robot
        prm = st.params
        pos, disp = r.position_cables, r.displacement_cables
        force = [c for c in range(r.cables) if c not in pos and c not in disp]
        kind = str(st.kind)
        cables = (f"{r.cables} cables ({len(pos)} position-controlled"
                  + (f", {len(disp)} commanded in displacement" if disp else "")
                  + (f", {len(force)} force-controlled" if force else "") + ")")
        return (f"Robot **{literal(r.name)}**: a {kind} arm of {r.n} joints and {cables}; cdsm {__version__}. "
                f"Monte Carlo: {prm['samples']} samples, seed {prm['seed']}. All computed quantities are SI (m, rad, "
                "N) in the CSV files; the text and figures show mm and degrees.")

    def headline_items(self) -> List[str]:
        """The answers, in numbers."""
        return list(self.answers().values())

    def answers(self) -> Dict[str, str]:
        """The headline's answers by topic (``largest``, ``montecarlo``,
        ``jumps``, ``statics``, ``tolerances``), in order."""
        st, h = self.study, self.numbers
        q = _q(st)
        items: Dict[str, str] = {}
        protos = st.protocols
        parts = [f"{mm(h[f'worst_single_m_{p}'], 2)} ({_pname(p)}, `{h[f'worst_single_scenario_{p}']}`)"
                 for p in protos]
        items["largest"] = (f"**Largest single error**: {q} up to " + "; ".join(parts)
                            + " — see [single errors](#single-errors) and [where the errors are largest](#largest).")
        mcs = []
        for p in protos:
            fail = h[f"mc_failed_{p}"]
            ftxt = ("no failed solves" if not fail else
                    f"**{fail} of {h[f'mc_attempted_{p}']} solves failed ({_pct(fail / h[f'mc_attempted_{p}'], 2)}) "
                    f"at {h[f'mc_failed_configurations_{p}']} configurations — flagged**")
            mcs.append(f"{_pname(p)}: largest {mm(h[f'mc_max_m_{p}'], 2)}, per-configuration 95th percentile up to "
                       f"{mm(h[f'mc_max_p95_m_{p}'], 2)}, pooled 95th percentile {mm(h[f'mc_pooled_p95_m_{p}'], 2)}; "
                       f"{ftxt}")
        tol = self._tolerance_words()
        items["montecarlo"] = f"**Monte Carlo** ({tol}): " + "; ".join(mcs) + " — see [Monte Carlo](#montecarlo)."
        jt = []
        for p in protos:
            jt.append(f"{_pname(p)}: {jump_words(h, p)}, {h[f'near_singular_{p}']} near-singular "
                      f"(measure < {NEAR_SINGULAR:g})")
        items["jumps"] = "**Jump points and singular states**: " + "; ".join(jt) + " — see [jumps](#jumps)."
        sl = []
        for p in protos:
            if self.study.workspaces[p].commands is not None:  # equilibria: a slack tendon is part of them
                sl.append(f"{_pname(p)}: {_pct(h[f'taut_share_{p}'])} of the equilibria converged")
                continue
            sl.append(f"{_pname(p)}: {_pct(h[f'taut_share_{p}'])} of the configurations held with every position "
                      f"cable taut, {_pct(h[f'mc_slack_share_{p}'], 2)} of the perturbed samples need a slack cable")
        items["statics"] = "**Statics**: " + "; ".join(sl) + " — see [statics](#statics)."
        if "budget_top_group" in h:
            items["tolerances"] = (f"**Tolerances**: {h['budget_top_group']} carries {_pct(h['budget_top_share'], 0)} "
                                   f"of the linear tip-error variance; for a pooled 95th percentile of "
                                   f"{mm(h['target_m'], 1)}, scale every tolerance by "
                                   f"{fmt(h['tolerance_scale_for_target'], 3, 'g')} (linear first guess) — see "
                                   "[sensitivities and tolerances](#sensitivity).")
        return items

    def _tolerance_words(self) -> str:
        prm = self.study.params
        dl, dh = max(prm["dl_tol_m"]) * 1e3, max(prm["dh_tol_m"]) * 1e3
        words = self.study.kind.words
        cables = "every commanded cable's length" if self.robot.displacement_cables else words['cables_every']
        return f"uniform ±{dl:g} mm on {cables}, ±{dh:g} mm on {words['holes_each']}"

    def outline(self) -> List[Section]:
        """The sections after the headline, in order: (id, title, builder)."""
        return [("arm", "The arm and the protocol", self.arm_section),
                ("single-errors", "Single errors", self.single_errors_section),
                ("largest", "Where the errors are largest", self.largest_section),
                ("jumps", "Jump points and singular states", self.jumps_section),
                ("montecarlo", "Monte Carlo", self.montecarlo_section),
                ("statics", "Statics: slack cables", self.statics_section),
                ("friction", "Friction in the holes", self.friction_section),
                ("sensitivity", "Sensitivities and tolerances", self.sensitivity_section),
                ("limits", "What this study does not cover", self.limits_section),
                ("files", "Files", self.files_section)]

    def build(self, pngs: Dict[str, bytes]) -> Document:
        """The document; ``pngs`` ({name: PNG bytes}) the figures drawn."""
        self.pngs = pngs
        doc = Document(self.title())
        doc.section(HEADLINE, "Headline")
        doc.p(self.intro())
        doc.ul(self.headline_items())
        for sid, title, make in self.outline():
            doc.section(sid, title)
            make(doc)
        return doc

    def fig(self, doc: Document, name: str, caption: str) -> None:
        if name in self.pngs:
            doc.fig(name, caption)

    # -- sections ----------------------------------------------------------------
    def arm_section(self, doc: Document) -> None:
        st, r = self.study, self.robot
        pos, disp = r.position_cables, r.displacement_cables
        force = [c for c in range(r.cables) if c not in pos and c not in disp]
        lim = r.joint_limits
        rows = [["kind", st.kind], ["joints", str(r.n)],
                ["cables", f"{r.cables}: position-controlled " + (", ".join(str(c + 1) for c in pos) or "none")
                 + ("; commanded in displacement " + ", ".join(str(c + 1) for c in disp) if disp else "")
                 + ("; force-controlled " + ", ".join(f"{c + 1} ({r.cable_tensions[c]:g} N)" for c in force)
                    if force else "")],
                ["joint limits", ", ".join(f"[{degrees(a)}°, {degrees(b)}°]" for a, b in lim)],
                ["straight length", mm(r.straight_length, 1)],
                ["gravity", "none (horizontal plane)" if not np.any(r.gravity) else
                 "(" + ", ".join(f"{v:g}" for v in r.gravity) + ") m/s²"]]
        if st.kind.words["force_row"]:
            rows.insert(3, [st.kind.words["force_row"], ", ".join(f"{r.cable_tensions[c]:.3g}" for c in force) + " N"])
        doc.table(["the arm", ""], rows)
        doc.p(f"**Protocol.** {st.protocol_reason[0].upper() + st.protocol_reason[1:]}.")
        items = []
        for p, ws in st.workspaces.items():
            k = len(ws.grid)
            if p == "attitude0":
                within = int(np.sum(ws.ik.within_limits & ws.reachable)) if ws.ik is not None else 0
                items.append(f"**attitude-0 protocol**: tip (X, Y) of each of the {k} grid configurations "
                             f"({ws.describe_grid()}), attitude set to phi = 0, pose IK (theta_2 ≤ 0 branch), then "
                             f"the error. **{ws.n_unreachable} of {k}** grid tips are unreachable at phi = 0 "
                             f"(counted, drawn as crosses, never dropped silently); {int(ws.reachable.sum())} are "
                             f"studied, {within} of them with IK angles within the joint limits.")
            elif p == "joint":
                items.append(f"**joint-space protocol**: the error is applied at the {k} grid angles themselves "
                             f"({ws.describe_grid()}); all {int(ws.reachable.sum())} are initial states.")
            elif p == "commanded":
                prm = ws.params or {}
                reach = prm.get("reach_m", 0) * 1e3
                items.append(f"**sampled command-space protocol**: {k} commands in the box ±{reach:g}"
                             f" mm on every commanded cable (a scrambled Sobol sequence, seed {prm.get('seed')}), the "
                             f"nominal arm settled at each in order; {int(ws.reachable.sum())} equilibria converged "
                             f"(the others counted as unreachable). Each error is settled at its own equilibrium from "
                             f"the same commands; jumps judged against each configuration's {prm.get('k')} nearest "
                             "neighbours in command space.")
            else:
                prm = ws.params or {}
                how = ("the configurations given" if prm.get("method") == "given" else
                       f"{'a scrambled Sobol sequence' if prm.get('method') == 'sobol' else prm.get('method')}, "
                       f"seed {prm.get('seed')}")
                items.append(f"**sampled joint-space protocol**: {k} joint-angle sets in the joint box ({how}; "
                             "limits wider than ±180° clipped to ±180°), the error applied at each; jumps judged "
                             f"against each configuration's {prm.get('k')} nearest neighbours in joint space.")
        doc.ul(items)
        main = st.workspaces[st.main]
        span = np.ptp(main.poses[main.reachable][:, :st.kind.dim], axis=0) * 1e3
        doc.p("Workspace of the study's configurations: tip extent " + ", ".join(
            f"{a} {fmt(s, 1)} mm" for a, s in zip("xyz", span)) + ".")
        cap = st.kind.words["workspace_caption"].format(
            attitude0=", those reachable at phi = 0 and the phi = 0 reach within the joint limits"
            if "attitude0" in st.workspaces else "")
        self.fig(doc, "workspace", cap)

    def _by_end(self, error: str) -> Dict[int, float]:
        """{disk: RMS |d position| (m) over both signs and the cables ending
        there} of one scenario error (:attr:`cdsm.study.Scenario.error`, main protocol)."""
        st, ends = self.study, self.robot.cable_ends
        out: Dict[int, List[np.ndarray]] = {}
        for r in st.results():
            if r.scenario.error == error:
                out.setdefault(ends[r.scenario.cable], []).append(r.position)
        return {d: finite_rms(np.concatenate(v)) for d, v in sorted(out.items())}

    def single_errors_section(self, doc: Document) -> None:
        st = self.study
        q = _q(st)
        srows = scenario_rows(st)
        doc.p(st.kind.words["single_errors"])
        _kind_table(doc, st.kind.report_tables["single_errors"], srows, q)
        for para in self.single_findings():
            doc.p(para)
        many = len({r.scenario.key for r in st.scenarios}) > study_figures.MAX_SCENARIO_FIGURES
        for p in st.workspaces:
            if many:
                self.fig(doc, f"overview_{p}", f"Every single error, the largest and the RMS {q} over the "
                         f"configurations — {_pname(p)}; one cell per single error, one row per position cable.")
                self.fig(doc, f"rotation_{p}", "Every single error, the largest and the RMS rotation angle of the end "
                         f"frame — {_pname(p)}.")
                continue
            self.fig(doc, f"overview_{p}", f"Every single error, {q} over the configurations — {_pname(p)}; each "
                     "thumbnail on its own scale (its max in the title); black rings: jump points.")
            self.fig(doc, f"rotation_{p}", f"Every single error, the end frame's rotation angle — {_pname(p)}; each "
                     "thumbnail on its own scale.")
        for sc in [r.scenario for r in st.results()]:
            cap = st.kind.words["scenario_caption"].format(label=sc.label, figure=sc.figure or sc.key, key=sc.key, q=q)
            self.fig(doc, f"scenario_{file_key(sc.key)}", cap)
        if not self.detail:
            doc.p("The one-figure-per-scenario maps were left out (`--no-scenario-figures`); the overviews above "
                  "map every scenario.")
        elif len(study_figures.detailed_scenarios(st)) < len({r.scenario.key for r in st.scenarios}):
            doc.p(f"One map each for the {study_figures.DETAILED_SCENARIOS} single errors with the largest position "
                  f"error of the {len({r.scenario.key for r in st.scenarios})} (past "
                  f"{study_figures.MAX_SCENARIO_FIGURES} scenarios a map each would bury the report); the overviews "
                  "above map every scenario, and the table lists them all.")

    def single_findings(self) -> List[str]:
        """Paragraphs on what the single errors show (main protocol)."""
        st = self.study
        q = _q(st)
        out = []
        hole_error, hole_key, _ = st.kind.hole_scenarios[0]  # the first hole error beside the length's
        length, holes = self._by_end("cable"), self._by_end(hole_error)
        if len(length) > 1:
            shrink = all(a >= b for a, b in zip(list(length.values()), list(length.values())[1:]))
            out.append(f"**Toward the tip** ({_pname(st.main)}). RMS {q} of a ±1 mm length error, by the disk its "
                       "cable ends at: " + ", ".join(f"disk {d} {mm(v)}" for d, v in length.items())
                       + f"; of a ±0.35 mm {st.kind.words['hole_error']}: "
                       + ", ".join(f"disk {d} {mm(v)}" for d, v in holes.items()) + ". "
                       + ("A length error matters less the nearer the tip its cable ends." if shrink else
                          "A length error does not matter less the nearer the tip its cable ends on this arm."))
        ratios, pairs = [], 0
        for r in st.results():
            if r.scenario.error != "cable":
                continue
            s = "+" if r.scenario.sign > 0 else "-"
            c = r.scenario.cable
            hk = hole_key.format(cable=c + 1, disk=self.robot.cable_ends[c]) + s
            b = st.result(hk).position
            a = r.position
            m = np.isfinite(a) & np.isfinite(b)
            pairs += int(m.sum())
            m &= b >= RATIO_FLOOR_M
            ratios.append(a[m] / b[m])
        rr = np.concatenate(ratios) if ratios else np.zeros(0)
        if pairs:
            floor = f"{RATIO_FLOOR_M * 1e6:g} µm"
            small = pairs - rr.size
            what = st.kind.words["hole_pair"]
            text = (f"**Holes against lengths.** Per configuration and cable, {q}(±1 mm length) / {q}(±0.35 mm "
                    f"{what})")
            if rr.size:
                lo, med, hi = np.percentile(rr, [5, 50, 95])
                text += (f", where the hole error moves the tip by at least {floor} ({rr.size} of {pairs}): 5th "
                         f"percentile {lo:.1f}, median {med:.1f}, 95th percentile {hi:.1f}.")
            else:
                text += (f": none to give, the hole error moves the tip by less than {floor} at all {pairs} (it "
                         "acts to second order or not at all).")
            if small and rr.size:
                text += (f" At {small} of {pairs} the hole error moves the tip by less than {floor} (there it acts "
                         "to second order or not at all), so the ratio would only divide by rounding; left out.")
            out.append(text)
        if "attitude0" in st.workspaces:  # a planar arm's protocol
            n = self.robot.n
            a0 = [finite_rms(st.result(f"disk{n}{s}", "attitude0").position) for s in "-+"]
            other = [p for p in st.workspaces if p != "attitude0"]
            jt = [finite_rms(st.result(f"disk{n}{s}", other[0]).position) for s in "-+"] if other else None
            out.append(f"**Disk {n}'s hole error is second order under attitude 0.** The upper cable of pair {n} "
                       f"crosses joints 1..{n}; a hole-height error dh changes its length, to first order, by "
                       f"−dh·(theta_1 + … + theta_{n}) = −dh·phi, which is zero when phi = 0. RMS {q}: "
                       f"{mm(a0[0], 4)} / {mm(a0[1], 4)} (−/+) under the attitude-0 protocol"
                       + (f", {mm(jt[0])} / {mm(jt[1])} under the {_pname(other[0])} where phi ≠ 0." if jt else "."))
        if any(h[0] == "normal" for h in st.kind.hole_scenarios):
            normal = self._by_end("normal")
            rn = [normal[d] / holes[d] for d in holes if holes[d] > 0 and d in normal]
            if rn:
                out.append(f"**Holes along the disk normal** against the same error along the radius: RMS ratio "
                           f"normal / radial per disk {min(rn):.2f} to {max(rn):.2f}.")
        rot = [(r.scenario.key, nanmax(r.rotation) / max(r.scenario.size, 1e-300)) for r in st.results()]
        rot = [t for t in rot if np.isfinite(t[1])]
        if rot:
            k, v = max(rot, key=lambda t: t[1])
            out.append(f"**Rotation.** The largest end-frame rotation per mm of error is "
                       f"{np.degrees(v) * 1e-3:.3f}°/mm ({k}); every scenario's is in `scenarios.csv`.")
        return out

    def largest_section(self, doc: Document) -> None:
        st = self.study
        q = _q(st)
        doc.p(f"The configurations with the largest Monte-Carlo 95th percentile of {q}, per protocol, with the "
              "largest single error there and what is special about them (near-singular: singular measure below "
              f"{NEAR_SINGULAR:g}; on a jump: some scenario jumps there; slack: a position cable would go slack).")
        for p in st.workspaces:
            rows = []
            for w in worst_configurations(st, p, 5):
                marks = [m for m, on in (("near-singular", w["singular"] < NEAR_SINGULAR), ("on a jump", w["jump"]),
                                         ("slack", not w["taut"]),
                                         (f"{w['failed']} failed solves", w["failed"] > 0)) if on]
                tip = ", ".join(fmt(v * 1e3, 1) for v in w["pose"][:st.kind.dim])
                rows.append([_angles(w["theta"]), tip, fmt(w["p95_m"] * 1e3), fmt(w["max_m"] * 1e3),
                             f"{fmt(w['single_m'] * 1e3)} ({w['single']})", fmt(w["singular"], 3, "g"),
                             ", ".join(marks) or "—"])
            if len(st.workspaces) > 1:
                doc.h(3, _pname(p))
            doc.table(["theta", "tip (mm)", f"MC 95th pct {q} (mm)", f"MC max {q} (mm)", "largest single error (mm)",
                       "singular measure", "special"], rows)
        h = self.numbers
        for p in st.workspaces:
            a = nanmax(st.monte_carlo[p].percentile(95.0))
            b = _nanmin(st.monte_carlo[p].percentile(95.0))
            doc.p(f"{_pname(p)}: the per-configuration 95th percentile ranges from {mm(b)} to {mm(a)}; the largest "
                  f"single error is {mm(h[f'worst_single_m_{p}'])} (`{h[f'worst_single_scenario_{p}']}`). Every "
                  "configuration's numbers are in `configurations.csv`.")

    def jumps_section(self, doc: Document) -> None:
        st = self.study
        q = _q(st)
        grid = [p for p in st.workspaces if p in ("joint", "attitude0")]
        if grid:
            doc.p(f"Grid protocols: a jump is a grid-neighbour pair whose {q} changes by more than 4× the change "
                  "across the adjacent pairs of the same grid line, by more than 10 % of the map's 95th percentile "
                  "and by more than 0.05 mm. Reasons: **branch switch** (the initial IK answer jumps to another "
                  "solution), **cable fold** (an upper cable near its longest or shortest length: |dL_i/dtheta_i| "
                  "below 10 % of its straight-pose value), **near-singular** (the pose Jacobian nearly loses rank, "
                  "sigma_min/sigma_max < 0.02), **reach boundary** (a neighbour unreachable at phi = 0), else "
                  "**steep**.")
        for p in [p for p in ("sampled", "commanded") if p in st.workspaces]:
            k = (st.workspaces[p].params or {}).get("k")
            space = "joint" if p == "sampled" else "command"
            doc.p(f"Sampled configurations: each is compared with its {k} nearest neighbours in {space} space. A "
                  f"pair is a jump when its change of the position deviation exceeds 10 % of the map's 95th "
                  "percentile and 0.05 mm, and its slope (change per rad of joint-space distance) exceeds 4× the "
                  "median slope over the neighbour pairs of both its ends. Only the jumps at near-singular "
                  "configurations are named.")
        rows = jump_rows(st)
        jr = [r for r in rows if r["jump_points"] > 0]
        if jr:
            if any("jump_points_near_singular" in r for r in jr) and not any("jumps_steep" in r for r in jr):
                doc.table(["scenario", "protocol", "jump points", "jump pairs", "at near-singular configurations"],
                          [[r["scenario"], _pname(r["protocol"]), r["jump_points"], r["jump_pairs"],
                            r["jump_points_near_singular"]] for r in jr])
            else:
                doc.table(["scenario", "protocol", "jump points", "jump pairs"] + list(REASONS),
                          [[r["scenario"], _pname(r["protocol"]), r["jump_points"], r["jump_pairs"]]
                           + [r.get("jumps_" + k.replace(" ", "_").replace("-", "_"), "—") for k in REASONS]
                           for r in jr])
        elif all(len(ws.neighbours) == 0 for ws in st.workspaces.values()):
            ws = next(iter(st.workspaces.values()))
            doc.p(f"Jump points were not searched: the grid ({ws.describe_grid()}) has fewer than {MIN_LINE} values "
                  "per joint, too few to judge a change against its neighbours.")
        else:
            doc.p("No jump points were found in any scenario: the deviation maps are smooth over these "
                  "configurations.")
        what = ("the tip position's Jacobian by the commanded cables' lengths (the plant's implicit-function "
                "sensitivities at the equilibrium: a slack tendon's column is zero; a nearly straight arm hardly "
                "moves its tip along the backbone)" if self.robot.is_elastic else st.kind.words["singular_rows"])
        doc.p(f"Singular measure: the smallest over the largest singular value of {what}.")
        for p in st.workspaces:
            s = st.singular[p]
            fin = np.isfinite(s)
            sing = fin & (s < 1e-6)
            near = fin & (s < NEAR_SINGULAR)
            extra = ""
            if st.kind.singular == "pose" and self.robot.n == 3 and sing.any():
                th = np.where(np.isfinite(st.workspaces[p].theta0), st.workspaces[p].theta0, 0.0)
                if np.all(np.abs(th[sing, 1]) < 1e-6):
                    extra = (" All of the singular ones have theta_2 = 0: for three joints the pose Jacobian is "
                             "singular exactly when joints 1, 2, 3 are collinear, not only when all joints are zero.")
            doc.p(f"{_pname(p)}: smallest {fmt(_nanmin(s), 3, 'g')}, median "
                  f"{fmt(float(np.median(s[fin])) if fin.any() else float('nan'), 3, 'g')}; {int(sing.sum())} "
                  f"configurations singular (< 1e-6), {int(near.sum())} near-singular (< {NEAR_SINGULAR:g}), of "
                  f"{int(fin.sum())}.{extra}")
        if st.kind.singular == "pose":  # the straight arm's pose Jacobian loses X
            sv0 = np.linalg.svd(self.robot.fk_jacobian(np.zeros(self.robot.n))[:2], compute_uv=False)
            doc.p("At theta = 0 the position Jacobian d[X, Y]/dtheta has singular values "
                  f"{', '.join(f'{s * 1e3:.3g}' for s in sv0)} mm/rad: X is lost, so a cable error moves the tip in "
                  "Y to first order and in X only to second order.")
        self.fig(doc, "singular", "Singular measure over the configurations (log scale; low = near-singular); red "
                 "ring: the lowest.")

    def montecarlo_section(self, doc: Document) -> None:
        st = self.study
        q = _q(st)
        rows = mc_rows(st)
        p0 = next(iter(st.monte_carlo.values())).params
        few = (f" {p0.get('samples')} is the default sample count over "
               f"{sum(len(ws.grid) for ws in st.workspaces.values())} configurations: it keeps a study at "
               f"{DEFAULT_SOLVES / 1e6:g} million solves (`--samples` sets it)."
               if st.params.get("samples_default") and p0.get("samples") < st.kind.default_samples else "")
        doc.p(f"{p0.get('samples')} random composite errors per configuration ({self._tolerance_words()}), "
              f"seed {p0.get('seed')}, streamed in chunks of {p0.get('chunk')} samples with bounded memory; "
              + ("every converged sample is also checked for a slack position cable" if p0.get("check_slack", True)
                 else "each sample a plant parameter vector settled at its own equilibrium from the same commands")
              + ". Percentiles are read from the study's "
              "histogram (232 log bins per decade, the middle of the quantile's bin: within 0.5 % of the sample "
              "quantile); pooled percentiles merge "
              "every configuration's samples." + few)
        head = ["protocol", "configurations", "failed solves", f"mean of mean {q} (mm)", f"max mean {q} (mm)",
                f"max 95th pct {q} (mm)", "pooled p50 / p95 / p99 (mm)", f"max {q} (mm)"]
        body = []
        for r in rows:
            fail = ("0" if not r["failed"] else
                    f"**{r['failed']} of {r['attempted']} ({_pct(r['failed'] / r['attempted'], 2)}) at "
                    f"{r['failed_configurations']} configurations**")
            body.append([_pname(r["protocol"]), r["configurations"], fail, fmt(r["mean_of_mean_m"] * 1e3),
                         fmt(r["max_mean_m"] * 1e3), fmt(r["max_p95_m"] * 1e3),
                         " / ".join(fmt(r[k] * 1e3) for k in ("pooled_p50_m", "pooled_p95_m", "pooled_p99_m")),
                         fmt(r["max_m"] * 1e3)])
        doc.table(head, body)
        for r in rows:
            if r["failed"]:
                doc.p(f"**Flag — failed solves ({_pname(r['protocol'])}).** {r['failed']} of {r['attempted']} "
                      f"perturbed cable solves did not converge, at {r['failed_configurations']} of "
                      f"{r['configurations']} configurations (listed in `configurations.csv`, column `mc_failed`). "
                      "The statistics are over the converged samples; the pooled percentiles count every failure "
                      "as larger than every bin, so they are bounds. A failure means the perturbed lengths have no "
                      "configuration near the nominal one (a cable fold, a singular state or the joint limits).")
        _kind_table(doc, st.kind.report_tables["mc_mean"], rows, q)
        if st.kind.words["mean_note"]:
            doc.p(st.kind.words["mean_note"])
        for r in rows:
            if np.isfinite(r["slack_share"]):
                doc.p(f"{_pname(r['protocol'])}: {_pct(r['slack_share'])} of the converged samples need a slack "
                      f"position cable (statics at the perturbed configuration), at {r['slack_configurations']} of "
                      f"{r['configurations']} configurations.")
        for p in st.monte_carlo:
            cap = (f"Monte Carlo — {_pname(p)}: mean, 95th percentile and max of {q} per configuration"
                   + st.kind.words["mc_caption"]
                   + "; red rings: configurations with failed solves.")
            self.fig(doc, f"montecarlo_{p}", cap)

    def statics_section(self, doc: Document) -> None:
        st, r = self.study, self.robot
        if any(ws.commands is not None for ws in st.workspaces.values()):
            self.equilibrium_statics(doc)
            return
        g = r.gravity
        grav = "no gravity" if not np.any(g) else "gravity (" + ", ".join(f"{v:g}" for v in g) + ") m/s²"
        force = st.kind.words["force_statics"].format(
            newtons=", ".join(f"{r.cable_tensions[c]:.3g}" for c in range(r.cables) if c not in r.position_cables))
        doc.p(f"Tensions of the position-controlled cables at every initial configuration: {force}, {grav}, no tip "
              "load; " + ("the balance's one solution (as many position cables as joints)"
                          if len(r.position_cables) == r.n else
                          "the minimum-norm set at or above 0 N (more position cables than joints)") + ".")
        for p, ws in st.workspaces.items():
            fm = st.feasibility[p]
            ok = ws.reachable
            slack = ok & ~fm.feasible
            held = ok & fm.feasible & np.isfinite(fm.tension).all(axis=1)
            least = fm.tension[held].min(axis=1) if held.any() and fm.tension.shape[1] else np.zeros(0)
            doc.p(f"{_pname(p)}: {int(slack.sum())} of {int(ok.sum())} configurations "
                  f"({_pct(slack.sum() / max(ok.sum(), 1))}) need a slack position cable"
                  + (f"; where all are taut the smallest tension is {least.min():.3g} N (median of the smallest "
                     f"{np.median(least):.3g} N)." if least.size else "."))
        self.fig(doc, "feasibility", "Statics: the smallest position-cable tension at each configuration (negative "
                 "red: a cable would have to push; zero grey); rings: a slack cable is needed.")

    def equilibrium_statics(self, doc: Document) -> None:
        """The statics of an elastic arm: its tendons' tensions at the equilibria of the commands."""
        st = self.study
        doc.p("The configurations are equilibria (joint springs, the tendons' series stiffness, gravity): a tendon "
              "paid out past its rest length hangs slack and carries nothing — part of the equilibrium, not a "
              "failure. The tensions of the commanded cables at each equilibrium are in `configurations.csv`.")
        for p, ws in st.workspaces.items():
            fm = st.feasibility[p]
            ok = ws.reachable & fm.feasible
            t = fm.tension[ok]
            slack = (t <= 0.0).sum(axis=1) if len(t) else np.zeros(0, int)
            doc.p(f"{_pname(p)}: {int(ok.sum())} of {len(ws.grid)} equilibria converged"
                  + (f"; slack tendons per configuration: median {np.median(slack):g}, at most {slack.max()}; the "
                     f"largest tension {t.max():.3g} N" if len(t) else "") + ".")
        self.fig(doc, "feasibility", "Statics: the smallest commanded-cable tension at each equilibrium (zero grey: "
                 "a slack tendon); rings: the equilibrium did not converge.")

    def friction_section(self, doc: Document) -> None:
        st, r = self.study, self.robot
        if not st.friction:
            doc.p("Does not apply: an elastic arm's statics is its frictionless equilibrium (the friction of its "
                  "joints is a separate model)." if any(ws.commands is not None for ws in st.workspaces.values())
                  else "Not computed.")
            return
        fm0 = next(iter(st.friction.values()))
        ea = r.axial_stiffness
        doc.p(f"Coulomb friction of every cable in every hole, mu = {fm0.mu:g} (oiled or greased steel on metal; "
              "published coefficients in `docs/model.md`, \"Friction in the holes\"): across a turn of angle beta "
              "a cable's tension changes by exp(±mu beta), the sign set by the direction it slides. Two bounding "
              "states of the statics: *pulling* (the actuators haul the arm, the position cables slide toward "
              "them, the force cables away) and *releasing* (the opposite); the tensions are those at the "
              "actuators. The hysteresis: each position cable in turn runs 0, +1, 0, −1, 0 mm at the commanded "
              f"configuration, through the plant with the robot file's cable (E·A = {ea:.4g} N, routing length "
              f"{r.routing_length:g} m) and this mu; the loop width is the distance between the tip positions "
              "at 0 reached from +1 mm and from −1 mm (the largest over the cables).")
        for p, ws in st.workspaces.items():
            fm = st.friction.get(p)
            if fm is None:
                continue
            ok = ws.reachable
            free = st.feasibility[p].feasible & ok
            w = fm.width[ok]
            fin = w[np.isfinite(w)]
            with np.errstate(invalid="ignore", divide="ignore"):
                ratio = (fm.pull / fm.release)[ok & fm.feasible_release & fm.feasible_pull]
            ratio = ratio[np.isfinite(ratio)]
            words = (f"{_pname(p)}: held taut at {int(free.sum())} of {int(ok.sum())} configurations without "
                     f"friction, {int((fm.feasible_pull & ok).sum())} pulling, "
                     f"{int((fm.feasible_release & ok).sum())} releasing")
            if ratio.size:
                words += (f"; pulling over releasing tension, median {np.median(ratio):.3g}, "
                          f"range {ratio.min():.3g}–{ratio.max():.3g}")
            cyc = fm.cycled[ok]
            if fin.size:
                words += (f"; hysteresis loop width median {np.median(fin) * 1e6:.3g} µm, max "
                          f"{fin.max() * 1e6:.3g} µm ({int(cyc.sum() - fin.size)} configurations where a command did "
                          "not settle)")
            if not cyc.all():
                words += (f"; the cycles ran at {int(cyc.sum())} evenly spread of the {cyc.size} configurations "
                          "(each settles the whole arm five times per cable)")
            doc.p(words + ".")
        doc.p("With a steel cable the stretch under the loads is micrometres, so is the loop: friction in the holes "
              "alone cannot make a lost motion of tens of micrometres per millimetre unless the cable is far more "
              "compliant than the robot file's (every number per configuration is in `friction.csv`).")
        self.fig(doc, "hysteresis", "Friction in the holes: the tip's hysteresis loop width (µm) over a ±1 mm "
                 "cycle of each position cable (the largest), robot file's cable stiffness.")

    def sensitivity_section(self, doc: Document) -> None:
        st = self.study
        q = _q(st)
        what_h = st.kind.words["holes_every"]
        through = "equilibrium" if st.robot.displacement_cables else "cable solve"
        doc.p(f"First-order sensitivities of the tip position (analytic, the implicit function theorem through the "
              f"{through}): the worst-case and RMS amplification of a unit error on every "
              f"{'commanded' if st.robot.displacement_cables else 'position'} cable and on {what_h} into {q}.")
        for p, m in st.amplification.items():
            parts = []
            for key, what in (("cable_rms", "cable length"), ("hole_rms", "holes")):
                v = m[key][np.isfinite(m[key])]
                if v.size:
                    parts.append(f"{what}: RMS amplification median {np.median(v):.2f}, max {v.max():.2f} mm/mm")
            doc.p(f"{_pname(p)} — " + ("; ".join(parts) if parts else "no finite sensitivity") + ".")
            self.fig(doc, f"amplification_{p}", f"First-order amplification of cable and hole errors into the tip — "
                     f"{_pname(p)} (log colour scale).")
        b = st.budget
        if b is None:
            return
        target = st.params["target_m"]
        mc = st.monte_carlo[st.main]
        mc95 = pooled_percentile(mc, 95.0)
        doc.p(f"**Error budget and tolerances** ({_pname(st.main)}, {b.configurations} configurations). Under the "
              f"linear model the pooled 95th percentile of {q} at the study's tolerances is {mm(b.linear_m)}; the "
              f"Monte Carlo gives {mm(mc95)}"
              + (f" (linear / Monte Carlo = {b.linear_m / mc95:.2f})" if np.isfinite(mc95) and mc95 > 0 else "")
              + f". The share of each error group in the linear variance of the tip position, and the linear first "
              f"guess of tolerances for a pooled 95th percentile of {mm(target, 1)}: every tolerance scaled alike, "
              "or each group adding equally to the variance (`cdsm tolerance` verifies a choice by Monte Carlo).")
        ratio, equal = b.for_target(target, "ratio"), b.for_target(target, "equal-effect")
        order = np.argsort(-b.share, kind="stable")
        doc.table(["error group", "tolerance now (mm)", "share of variance", "RMS effect (mm/mm)",
                   f"scaled alike for {target * 1e3:g} mm (mm)", f"equal effect for {target * 1e3:g} mm (mm)"],
                  [[b.groups[g], fmt(b.tolerance[g] * 1e3, 3), _pct(b.share[g]), fmt(b.rms[g], 3),
                    fmt(ratio[g] * 1e3, 3), fmt(equal[g] * 1e3, 3) if np.isfinite(equal[g]) else "any (no effect)"]
                   for g in order])

    def limits_section(self, doc: Document) -> None:
        st = self.study
        items = ["**Measurements.** This is a study of the nominal model's sensitivity to manufacturing errors; "
                 "the gap to a real arm needs measurements: `cdsm diagnose DATA.csv --robot R.toml` fits every "
                 "candidate unmodelled effect (backlash, cable elasticity, hole clearance, ...) to them.",
                 ("**Tendon stretch and springs** are in the equilibria (the tendons' series stiffness, the joint "
                  "springs); joint friction and the other effects of the diagnosis library are not."
                  if self.robot.is_elastic else
                  "**Cable stretch.** The cables are rigid here; the statics give the tensions, "
                  "`Robot.solve_cables_elastic` the elastic configuration.")]
        if st.kind.words["limit_notes"]:
            items.append(st.kind.words["limit_notes"])
        if "sampled" in st.workspaces or "commanded" in st.workspaces:
            items.append("**Jump reasons.** Between sampled neighbours only the jumps at near-singular "
                         "configurations are named; the grid protocols also name branch switches, cable folds and "
                         "the reach boundary.")
        if st.kind.grid_protocols and "attitude0" not in st.workspaces:
            items.append("**The attitude-0 protocol** is left out for this arm (see [the protocol](#arm)).")
        doc.ul(items)

    def files_section(self, doc: Document) -> None:
        doc.ul(self.file_notes())

    # -- writing ------------------------------------------------------------------
    def write(self, out: "str | os.PathLike[str]", progress: bool = False,
              workers: Optional[int] = None, overwrite: bool = False) -> Dict[str, str]:
        """Write figures, the CSV tables, ``report.md`` and ``report.html``
        into ``out``, owned by this run while it writes
        (:func:`cdsm.files.run_directory`: refused while another run writes
        there, or when it holds files of these names that no cdsm run wrote,
        unless ``overwrite``). Returns {name: path} (``report_md``,
        ``report_html``, one ``<stem>_csv`` per table, ``figures``,
        ``manifest``). The directory's manifest
        (:data:`cdsm.files.RUN_MANIFEST`) says incomplete while it is
        written and lists every file this run wrote once done; the HTML
        page embeds the figures as this run drew them."""
        with run_directory(out, self.command, self.FILES, overwrite=overwrite) as run:
            jobs = self.figure_jobs()
            pngs = render_pngs(lambda _: jobs, self, progress=progress, workers=workers)
            paths: Dict[str, str] = {"figures": os.path.join(run.out, "figures")}
            for name, data in pngs.items():
                run.write(f"figures/{name}.png", data, "figure")
            for name, rows in self.tables().items():
                paths[f"{name[:-4]}_csv"] = run.write_csv(name, rows)
            doc = self.build(pngs)
            paths["report_md"] = run.write_text("report.md", doc.markdown("figures", pngs), "report")
            paths["report_html"] = run.write_text("report.html", doc.html(pngs, self.html_title()), "report")
            paths["manifest"] = run.finish()
        return paths


def write(study, out: "str | os.PathLike[str]", progress: bool = False, detail: bool = True,
          workers: Optional[int] = None, overwrite: bool = False) -> Dict[str, str]:
    """Write the report of ``study`` (the general one; :func:`cdsm.report.write`
    adds the paper's sections for the paper's geometry) into ``out``;
    ``detail``: also one figure per scenario. See :meth:`StudyReport.write`."""
    return StudyReport(study, detail).write(out, progress=progress, workers=workers, overwrite=overwrite)
