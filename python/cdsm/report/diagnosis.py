"""The report of ``cdsm diagnose``: where the sim-to-real gap lies, which effect
explains it and how far it shrinks on held-out rows — Markdown, a
self-contained HTML page (figures embedded), the figures as PNG, the per-row
residuals as CSV and the diagnosis as JSON. SI units in the files; the text
and figures show µm / mm / mrad / %.

Every sentence is computed from the :class:`cdsm.calibration.diagnosis.Diagnosis`; nothing
is hard-coded. Entry points: :func:`write` (all files), :func:`findings` (the
words, as a dict of paragraphs), :func:`summary` (a few lines for the CLI).

Sign convention: the *gap* of a row is measured − model (m), i.e. minus the
residual of :func:`cdsm.calibration.diagnosis.residuals`.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass
from typing import Dict, List, Tuple

import numpy as np
from matplotlib.ticker import MaxNLocator

from .. import __version__
from ..calibration import diagnosis as diagnose
from ..calibration import plant, stats
from ..files import run_directory
from .document import HEADLINE, Document, literal
from .figures import BLUE, GREEN, RED, new_figure, place, png_bytes, report_style

__all__ = ["FILES", "write", "findings", "summary", "param_rows", "bound_notes", "headline_items", "next_steps",
           "figures", "residual_map_figure", "residual_bars_figure", "candidates_figure", "features_figure",
           "test_rows", "tests_text"]

#: the files the report writes beside ``figures/`` (:func:`write`)
FILES = ("report.md", "report.html", "diagnosis.json", "residuals.csv", "suggested.csv")

# words for the rank correlation of a feature with the residual size:
# (meaning when rho > 0, meaning when rho < 0)
_MEANING = {
    "singularity (sigma_min/sigma_max)": (
        "the gap grows away from singular states (large sigma_min/sigma_max)",
        "the gap grows toward singular states (small sigma_min/sigma_max: joints nearly collinear)"),
    "max |joint angle| (rad)": (
        "the gap grows as the arm bends more (larger joint angles)",
        "the gap is largest near the straight arm (small joint angles)"),
    "tip sensitivity to cables (m/m)": (
        "the gap grows where the tip is most sensitive to cable lengths (near jump points and cable folds, "
        "where a length error is amplified)",
        "the gap is largest where the tip is least sensitive to cable lengths"),
    "X (m)": ("the gap grows toward larger X (the far end of the workspace)",
              "the gap grows toward smaller X (the near end of the workspace)"),
    "Y (m)": ("the gap grows toward positive Y", "the gap grows toward negative Y"),
    "cable with dL (index)": ("the gap depends on which cable carries the commanded change (higher pairs larger)",
                              "the gap depends on which cable carries the commanded change (lower pairs larger)"),
    "|theta_2| (rad)": ("the gap grows with |theta_2|",
                        "the gap is largest near theta_2 = 0 (collinear joints: the singular reach boundary)"),
    "min upper tension (N)": (
        "the gap grows with cable tension (a load-dependent effect such as stretch)",
        "the gap grows where an upper cable is close to slack (low tension)"),
}


# ---------------------------------------------------------------------------
# numbers and units
# ---------------------------------------------------------------------------
def _um(v: float, nd: int = 1) -> str:
    """A length in m as µm (or mm when >= 1 mm)."""
    if v is None or not np.isfinite(v):
        return "—"
    if abs(v) >= 1e-3:
        return f"{v * 1e3:.3f} mm"
    return f"{v * 1e6:.{nd}f} µm"


def _suffix(unit: str) -> str:
    """A unit after a number: a space before it, none before ``°``."""
    return f" {unit}" if unit and unit != "°" else unit


def _pm(v: float, s: float, scale: float, unit: str, nd: int) -> str:
    u = _suffix(unit)
    if s is None or not np.isfinite(s) or s <= 0.0:
        # NaN: the fit found a direction the data do not see (diagnose.fit)
        return f"{v * scale:+.{nd}f}{u} (not determined by these data)"
    return f"{v * scale:+.{nd}f} ± {s * scale:.{nd}f}{u}"


def _shown_as(unit: str, big: float) -> Tuple[float, str, int]:
    """(scale, unit shown, decimals) of a parameter in SI ``unit`` whose
    value or std reaches ``big``: m as mm (≥ 1 mm) or µm, rad as mrad
    (below 0.1 rad) or degrees, others (dimensionless, 1/N) as they are
    with three significant digits of the larger, at least four decimals."""
    if unit == "m":
        return (1e3, "mm", 3) if big >= 1e-3 else (1e6, "µm", 1)
    if unit == "rad":
        return (1e3, "mrad", 2) if big < 0.1 else (180.0 / math.pi, "°", 2)
    nd = min(12, max(4, 2 - math.floor(math.log10(big)))) if big > 0 else 4
    return 1.0, "" if unit == "1" else unit, nd


def _fmt_param(unit: str, v: float, s: float) -> str:
    """A parameter ± std in the unit :func:`_shown_as` picks for it; a
    compliance with the stiffness it means."""
    scale, shown, nd = _shown_as(unit, max(abs(v), abs(s) if np.isfinite(s) else 0.0))
    txt = _pm(v, s, scale, shown, nd)
    return txt + (f" (E·A ≈ {1.0 / v:.3g} N)" if unit == "1/N" and v > 0 else "")


def _fitted(robot, fit) -> List[Tuple[str, int, str, str, float, float]]:
    """(effect, flat index, label, SI unit, value, std) of every parameter of
    a fit's effects, labelled from the plant's layout."""
    labels = plant.parameter_labels(robot)
    vals, stds = fit.params_by_effect(robot), fit.std_by_effect(robot)
    out = []
    for e in fit.effects:
        for k, i in enumerate(plant.effect_indices(robot, e)):
            _, lab, unit = labels[int(i)]
            out.append((e, int(i), lab, unit, float(vals[e][k]), float(stds[e][k])))
    return out


def param_rows(d: diagnose.Diagnosis, cand: diagnose.Candidate) -> List[Tuple[str, str, str, float, float]]:
    """(effect, parameter label, readable value ± std, value SI, std SI) of
    every parameter of a candidate's fit on all usable rows, each in its own
    unit (:func:`cdsm.calibration.plant.parameter_labels`)."""
    return [(e, lab, _fmt_param(unit, v, s), v, s) for e, _, lab, unit, v, s in _fitted(d.prep.robot, cand.fit)]


def bound_notes(d: diagnose.Diagnosis, cand: diagnose.Candidate) -> List[str]:
    """A sentence for each parameter of a candidate's fit that sits at a
    bound of the physical domain with a standard error larger than its
    value: the bound stopped the fit, the data did not place it."""
    robot = d.prep.robot
    lo, hi = plant.bounds(robot)
    out = []
    for e, i, lab, unit, v, s in _fitted(robot, cand.fit):
        if not (np.isfinite(s) and s > abs(v)):
            continue
        for side, b in (("lower", lo[i]), ("upper", hi[i])):
            if np.isfinite(b) and abs(v - b) <= 1e-9 * max(abs(b), s):
                scale, shown, _ = _shown_as(unit, max(abs(v), s))
                bound = f"{b * scale:g}{_suffix(shown)}"
                out.append(f"`{e}` {lab} = {_fmt_param(unit, v, s)} sits at its {side} bound ({bound}) with a "
                           "standard error larger than its value: the edge of the physical domain stopped the "
                           "fit, not the data, so this number is not a measurement of it.")
    return out


# ---------------------------------------------------------------------------
# per-row quantities
# ---------------------------------------------------------------------------
def _row_names(d: diagnose.Diagnosis) -> List[str]:
    labels = d.prep.meas.labels
    key = next((k for k in ("point", "label", "id", "name") if k in labels), None)
    return [f"row {i + 1}" + (f" (point {labels[key][i]})" if key else "") for i in range(len(d.prep.meas))]


def _commanded_tip(d: diagnose.Diagnosis) -> np.ndarray:
    """(N, k) commanded tip position (m) of the nominal model, one column per
    position axis of the arm (X, Y; spatial X, Y, Z); for rows whose command
    was not solved the commanded pose's coordinates (NaN where none)."""
    axes = [a for a in ("X", "Y", "Z") if f"{a} (m)" in d.features]
    tip = np.stack([d.features[f"{a} (m)"] for a in axes], 1).astype(float)
    bad = ~d.prep.usable
    if bad.any():
        pose = d.prep.meas.pose_cmd
        tip[bad] = np.nan
        if pose is not None:
            k = min(pose.shape[1], len(axes))
            tip[np.ix_(bad, np.arange(k))] = pose[bad, :k]
    return tip


def _map_axes(d: diagnose.Diagnosis) -> Tuple[List[int], List[str]]:
    """The two position axes a residual map shows: X, Y of a planar arm; of
    a spatial one the two along which the rows' tips spread most (the
    lateral plane of a continuum robot along ``x``)."""
    names = [a for a in ("X", "Y", "Z") if f"{a} (m)" in d.features]
    if len(names) == 2:
        return [0, 1], names
    rows = d.prep.rows
    spread = [float(np.ptp(np.asarray(d.features[f"{a} (m)"], float)[rows])) if len(rows) else 0.0 for a in names]
    pick = sorted(np.argsort(spread, kind="stable")[::-1][:2].tolist())
    return pick, [names[i] for i in pick]


def _in_base_frame(d: diagnose.Diagnosis, gap: np.ndarray, fit) -> np.ndarray:
    """``gap`` (N, k) m as measured, in the robot's base frame: registered
    data are read in the measuring frame ``y = R f + t``, so a gap turns by
    ``R^T`` of the frame ``fit`` registered (unchanged in the base frame)."""
    if not d.prep.registered:
        return gap
    a = fit.p[plant.effect_indices(d.prep.robot, "frame_misalignment")]
    if gap.shape[1] == 2:
        c, s = np.cos(a[0]), np.sin(a[0])
        r = np.array([[c, -s], [s, c]])
    else:
        from scipy.spatial.transform import Rotation

        r = Rotation.from_rotvec(a[:3]).as_matrix()
    return gap @ r


def _gaps(d: diagnose.Diagnosis) -> Tuple[np.ndarray, np.ndarray]:
    """(N, 2) gap = measured − model (m) of the baseline and of the final
    model (fit on all usable rows); NaN for flagged rows."""
    return -diagnose.residuals(d, "baseline"), -diagnose.residuals(d, "final")


def _heldout_full(d: diagnose.Diagnosis, cand: diagnose.Candidate) -> np.ndarray:
    out = np.full(len(d.prep.meas), np.nan)
    out[d.prep.rows] = cand.heldout
    return out


def _strength(rho: float, n: int) -> str:
    a = abs(rho)
    word = "strong" if a >= 0.7 else "moderate" if a >= 0.4 else "weak"
    thr = stats.normal_isf(0.025) / math.sqrt(max(n - 1, 1))
    return word + ("" if a > thr else f", within chance for {n} rows (|ρ| < {thr:.2f})")


def _ranked_features(d: diagnose.Diagnosis, size: np.ndarray) -> List[Tuple[str, float]]:
    rows = d.prep.rows
    out = []
    for k, v in d.features.items():
        rho = stats.spearman(np.asarray(v, float)[rows], size[rows])
        out.append((k, rho))
    fin = sorted([x for x in out if np.isfinite(x[1])], key=lambda x: -abs(x[1]))
    return fin + [x for x in out if not np.isfinite(x[1])]


def _similarity(d: diagnose.Diagnosis, a: diagnose.Candidate, b: diagnose.Candidate) -> float:
    """Cosine similarity of the corrections (prediction − nominal prediction)
    that the fits of ``a`` and ``b`` make over the usable rows."""
    rows = d.prep.rows
    base = d.baseline.fit.prediction[rows, :2]
    ca = (a.fit.prediction[rows, :2] - base).ravel()
    cb = (b.fit.prediction[rows, :2] - base).ravel()
    den = float(np.linalg.norm(ca) * np.linalg.norm(cb))
    return float(ca @ cb / den) if den > 0 and np.isfinite(den) else float("nan")


# ---------------------------------------------------------------------------
# the words
# ---------------------------------------------------------------------------
def findings(d: diagnose.Diagnosis) -> Dict[str, List[str]]:
    """The report's conclusions as paragraphs, keyed ``answer``, ``where``,
    ``which``, ``shrink``, ``identifiability``, ``flagged``. All numbers are
    computed from ``d``."""
    f = _Facts.of(d)
    return {"answer": _answer(d, f), "where": _where(d, f), "which": _which(d, f), "shrink": _shrink(d, f),
            "identifiability": _identifiability(d), "flagged": _flagged(d, f)}


@dataclass(frozen=True)
class _Facts:
    """The numbers every section of :func:`findings` reads, computed once."""

    names: List[str]
    rows: np.ndarray
    nu: int
    b_rms: float
    f_rms: float
    floor: float
    g_base: np.ndarray
    g_final: np.ndarray
    size_b: np.ndarray
    size_f: np.ndarray
    cv: str
    shrink: float

    @classmethod
    def of(cls, d: diagnose.Diagnosis) -> "_Facts":
        rows = d.prep.rows
        nu = len(rows)
        b_rms, f_rms = d.baseline.heldout_rms, d.final().heldout_rms
        g_base, g_final = _gaps(d)
        cv = ("leave-one-out" if d.folds >= nu else f"{d.folds}-fold") + " cross-validation"
        if d.prep.groups is not None:
            cv += f" (whole groups of {literal(d.prep.group_column)} held out together)"
        return cls(_row_names(d), rows, nu, b_rms, f_rms, d.noise_floor, g_base, g_final,
                   np.linalg.norm(g_base, axis=1), np.linalg.norm(g_final, axis=1), cv,
                   100.0 * (1.0 - f_rms / b_rms) if b_rms > 0 else 0.0)


def _noise_words(d: diagnose.Diagnosis) -> str:
    """How the noise was found, with its value."""
    ne = d.noise_estimate
    if ne.source == "repeats":
        return (f"{_um(d.noise)} per axis and reading, estimated from {ne.groups} groups of repeated commands "
                f"approached from the same direction (95 % interval {_um(ne.ci[0])}–{_um(ne.ci[1])})")
    if ne.source == "neighbours":
        return (f"{_um(d.noise)} per axis and reading, estimated from neighbouring rows of each motion (no "
                f"repeated commands; 95 % interval {_um(ne.ci[0])}–{_um(ne.ci[1])}): see the support limits")
    if ne.source == "given":
        return f"{_um(d.noise)} per axis and reading, as given"
    return f"{_um(d.noise)} per axis and reading, **assumed** (no repeated commands in the data and none given)"


def _answer(d: diagnose.Diagnosis, f: _Facts) -> List[str]:
    """The answer: the verdict, the noise, the frame, what the search and the outliers add."""
    out: List[str] = []
    prep, b_rms, f_rms, floor = d.prep, f.b_rms, f.f_rms, f.floor
    v = d.verdict_detail
    ne = d.noise_estimate
    against = ("F against the noise of neighbouring rows" if ne.source == "neighbours" else "F against pure error"
               if v.test == "F" else "chi-square against the noise")
    lof = (f"lack-of-fit test ({against}): "
           f"p = {v.p_value:.2g}")
    if d.verdict == "no gap":
        nb = v.nominal_bound.bound if v.nominal_bound else float("nan")
        out.append(
            f"**No gap beyond measurement noise** (verdict: no gap). The nominal model's held-out RMS position "
            f"error is {_um(b_rms)}, within its adequacy bound {_um(nb)} ({nb / floor:.2f}× the noise floor "
            f"{_um(floor)}: see [the tests](#tests)), and the {lof}; no effect of the library improves it "
            "significantly. Answer: **none**.")
    elif d.verdict == "unexplained":
        top = d.singles[0] if d.singles else None
        extra = (f" The best single candidate, `{top.name}`, reaches {_um(top.heldout_rms)}, which "
                 f"{_support_words(d)} cannot tell apart from the nominal model on these rows."
                 if top is not None else "")
        out.append(
            f"**The gap stays unexplained** (verdict: unexplained). The nominal model misses the measurements "
            f"by {_um(b_rms)} held-out RMS ({b_rms / floor:.1f}× the noise floor {_um(floor)}), and no "
            f"effect of the library ({len(d.singles)} tried) reduces it significantly.{extra} "
            "Answer: **none** — the cause lies outside the library (or the data are too few to tell).")
    else:
        what = ("explains the gap down to the noise level" if d.verdict == "explained" else
                "explains part of the gap; what is left is more than noise")
        out.append(
            f"**`{d.best}` {what}** (verdict: {d.verdict}). Held-out RMS position error ({f.cv}): nominal model "
            f"{_um(b_rms)} → with `{d.best}` {_um(f_rms)} ({f.shrink:.0f} % smaller; noise floor {_um(floor)}, "
            f"final/floor = {f_rms / floor:.2f}; {lof}).")
    out.append(f"Noise: {_noise_words(d)}; the floor is √2 × {'√2 × ' if prep.readings > 1 else ''}σ = "
               + _um(floor) + (" (displacements are differences of two readings)"
                               if prep.readings > 1 else "") + "."
               + (f" The final model would be adequate at a noise of {_um(v.noise_needed)} or more."
                  if ne.source == "assumed" and not v.final_adequate else ""))
    if prep.registered:
        reg = (f"The data were registered: the measuring frame was fitted with every candidate (started from a "
               f"Kabsch fit). Held-out RMS of the {'chosen' if d.chosen else 'nominal'} model in the identity "
               f"frame {_um(d.identity.heldout_rms)}, registered {_um(d.final().heldout_rms)}: the frame is "
               + ("named (`frame_misalignment`): it beats the identity frame." if d.registration_named else
                  "not named: it does not beat the identity frame significantly."))
        if prep.frame == "auto":
            reg += (f" (The data lie {_um(prep.offset)} RMS from the nominal predictions, beyond 5 % of the arm's "
                    "length: an instrument's own frame.)")
        out.append(reg)
    elif prep.reading == "absolute" and prep.frame == "auto":
        out.append(f"The data lie {_um(prep.offset)} RMS from the nominal predictions, within 5 % of the "
                   "arm's length: taken in the robot's base frame, with `frame_misalignment` a candidate "
                   "effect like any other.")
    if d.dropped:
        out.append("Backward elimination dropped " + ", ".join(f"`{e}`" for e in d.dropped)
                   + ": with the other effects in, the model does not need it.")
    if d.search is not None:
        out.append(_search_words(d.search))
    if d.outliers:
        out.append(outlier_note(d, f.names))
    return out


def _search_words(s) -> str:
    """What the search beyond forward selection tried and found."""
    fitted = len(s.tried)
    txt = (f"Search beyond forward selection ({s.reason}): {s.family} combinations (every pair, triples "
           f"among the best five) screened on the linearised plant, {fitted} fitted in full, each tested "
           f"at {s.alpha:.2g} against the nominal model and every smaller combination.")
    if s.picked is None:
        txt += " None is supported."
    elif s.replaced:
        txt += f" It found `{s.picked}`, which replaces forward selection's answer."
    else:
        txt += f" It confirms `{s.picked}`."
    if s.ties:
        txt += f" Tied with it (the held-out errors cannot tell them apart): {', '.join(s.ties)}."
    return txt


def _where(d: diagnose.Diagnosis, f: _Facts) -> List[str]:
    """Where the gap lies: the largest gaps, per axis, by region, the features that follow it, what is left."""
    out: List[str] = []
    names, rows, nu, size_b, g_base = f.names, f.rows, f.nu, f.size_b, f.g_base
    order = [i for i in np.argsort(-np.nan_to_num(size_b, nan=-1.0)) if np.isfinite(size_b[i])]
    sse = size_b[rows] ** 2
    tot = float(sse.sum())
    k50 = int(np.searchsorted(np.cumsum(np.sort(sse)[::-1]) / max(tot, 1e-300), 0.5) + 1) if tot > 0 else 0
    top = order[:min(3, len(order))]
    xy = _commanded_tip(d)[:, :2]
    out.append(
        "Largest gaps (nominal model): " + "; ".join(
            f"{names[i]} at X = {xy[i, 0] * 1e3:.1f} mm, Y = {xy[i, 1] * 1e3:.1f} mm: "
            f"{_um(size_b[i])} (dX {_um(g_base[i, 0])}, dY {_um(g_base[i, 1])})" for i in top)
        + f". {k50} of {nu} rows {'carry' if k50 > 1 else 'carries'} half of the squared gap"
        + (" — the gap is concentrated in a few rows." if k50 <= max(1, nu // 5) else "."))
    rx = float(np.sqrt(np.nanmean(g_base[rows, 0] ** 2)))
    ry = float(np.sqrt(np.nanmean(g_base[rows, 1] ** 2)))
    axis = ("mostly along Y" if ry > 1.5 * rx else "mostly along X" if rx > 1.5 * ry else "in both axes alike")
    mx, my = float(np.nanmean(g_base[rows, 0])), float(np.nanmean(g_base[rows, 1]))
    out.append(
        f"Per axis, the gap is {axis}: RMS dX {_um(rx)}, dY {_um(ry)} (means {_um(mx)}, {_um(my)}: "
        + ("a systematic offset in the mean" if math.hypot(mx, my) > 0.5 * math.hypot(rx, ry) else
           "mostly configuration-dependent, not a constant offset") + ").")
    regions = []
    for lab, axis_i in (("Y", 1), ("X", 0)):
        v = xy[rows, axis_i]
        cut = 0.0 if axis_i == 1 else float(np.median(v))
        lo, hi = size_b[rows][v < cut], size_b[rows][v >= cut]
        if len(lo) >= 2 and len(hi) >= 2:
            a, b = float(np.sqrt(np.mean(lo ** 2))), float(np.sqrt(np.mean(hi ** 2)))
            regions.append((max(a, b) / max(min(a, b), 1e-300), lab, cut, a, b, len(lo), len(hi)))
    if regions:
        r = max(regions)
        out.append(
            f"By region: rows with {r[1]} < {r[2] * 1e3:.1f} mm ({r[5]}) have RMS gap {_um(r[3])}, rows with "
            f"{r[1]} ≥ {r[2] * 1e3:.1f} mm ({r[6]}) {_um(r[4])}.")
    feats = _ranked_features(d, size_b)
    lines = []
    for k, rho in feats[:3]:
        if not np.isfinite(rho):
            continue
        meaning = _MEANING.get(k, (f"the gap grows with {k}", f"the gap shrinks with {k}"))[0 if rho > 0 else 1]
        lines.append(f"{k}: Spearman ρ = {rho:+.2f} ({_strength(rho, nu)}) — {meaning}")
    const = [k for k, rho in feats if not np.isfinite(rho)]
    if lines:
        out.append("Configuration features that explain the size of the gap (rank correlation with "
                   "|gap| of the nominal model): " + "; ".join(lines) + "."
                   + (f" Constant in these data (no information): {', '.join(const)}." if const else ""))
    if not d.explained and d.chosen is not None:
        size_f = f.size_f
        order_f = [i for i in np.argsort(-np.nan_to_num(size_f, nan=-1.0)) if np.isfinite(size_f[i])][:3]
        ff = [(k, rho) for k, rho in _ranked_features(d, size_f) if np.isfinite(rho)][:2]
        out.append(
            f"What `{d.best}` leaves unexplained ({_um(f.f_rms)} held-out, {f.f_rms / f.floor:.1f}× the noise "
            "floor) lies at " + "; ".join(f"{names[i]}: {_um(size_f[i])}" for i in order_f)
            + (("; its size follows " + ", ".join(f"{k} (ρ = {rho:+.2f})" for k, rho in ff)) if ff else "") + ".")
    return out


def _which(d: diagnose.Diagnosis, f: _Facts) -> List[str]:
    """Which effect: the chosen model's parameters and the selection steps (or the best single candidate)."""
    out: List[str] = []
    if d.chosen is not None:
        prs = param_rows(d, d.chosen)
        out.append(f"`{d.best}` fitted on all {f.nu} usable rows: " + "; ".join(
            f"{lab} = {txt}" + (f" ({abs(v) / s:.1f} σ from zero)" if np.isfinite(s) and s > 0 else "")
            for _, lab, txt, v, s in prs) + ".")
        out.extend(bound_notes(d, d.chosen))
        if len(d.steps) > 1:
            out.append("Forward selection: " + " → ".join(
                f"`{c.name}` {_um(c.heldout_rms)}" for c in d.steps) + " (each step kept only when it beats the "
                f"previous one by {_support_words(d)}: see [the tests](#tests)).")
    elif d.singles:
        t = d.singles[0]
        out.append(
            f"No effect is chosen. For reference, the best single candidate `{t.name}` would be: " + "; ".join(
                f"{lab} = {txt}" for _, lab, txt, _, _ in param_rows(d, t)) + ".")
        out.extend(bound_notes(d, t))
    return out


def _shrink(d: diagnose.Diagnosis, f: _Facts) -> List[str]:
    """How far the gap shrinks: every single candidate's held-out RMS, the chosen model row by row."""
    b_rms, nu, names, rows = f.b_rms, f.nu, f.names, f.rows
    out = [f"Held-out RMS position error ({f.cv}, {nu} rows): nominal {_um(b_rms)}; " + ", ".join(
        f"`{c.name}` {_um(c.heldout_rms)} (−{100 * (1 - c.heldout_rms / b_rms):.0f} %)"
        if c.heldout_rms <= b_rms else
        f"`{c.name}` {_um(c.heldout_rms)} (worse by {100 * (c.heldout_rms / b_rms - 1):.0f} %)"
        for c in d.singles) + f". Noise floor {_um(f.floor)}."]
    if d.chosen is not None:
        hb, hf = _heldout_full(d, d.baseline), _heldout_full(d, d.final())
        better_rows = int(np.sum(hf[rows] < hb[rows]))
        out.append(
            f"With `{d.best}` the held-out error shrinks at {better_rows} of {nu} rows; the largest remaining "
            f"held-out error is {_um(float(np.nanmax(hf)))} ({names[int(np.nanargmax(hf))]}), it was "
            f"{_um(float(np.nanmax(hb)))} ({names[int(np.nanargmax(hb))]}).")
    return out


def _identifiability(d: diagnose.Diagnosis) -> List[str]:
    """What the data cannot tell apart: ties, correlated and undetermined parameters."""
    out: List[str] = []
    if d.ties and d.singles:
        t0 = d.singles[0]
        sims = []
        for name in d.ties:
            c = next(c for c in d.singles if c.name == name)
            sims.append(f"`{name}` ({_um(c.heldout_rms)}, corrections cosine-similar {_similarity(d, t0, c):+.2f})")
        out.append(
            f"Ties: the held-out errors cannot tell `{t0.name}` ({_um(t0.heldout_rms)}) from " + ", ".join(sims)
            + ". A cosine similarity near ±1 means the two effects move the predictions alike over these rows: "
            "the data cannot separate them; measure rows where they differ.")
    else:
        out.append("No ties: the best candidate beats every other one on held-out rows beyond noise.")
    if d.correlated:
        out.append("Correlated parameters (|corr| > 0.95) of the final model: " + "; ".join(d.correlated) + ".")
    undetermined = [f"{e}: {lab}" for cand in ([d.chosen] if d.chosen else d.singles[:1])
                    for e, lab, txt, v, s in param_rows(d, cand) if "not determined" in txt]
    if undetermined:
        out.append("Not determined by these data (no effect on the measured quantity): "
                   + ", ".join(undetermined) + ".")
    if d.prep.reading == "displacement":
        out.append(
            "The data are displacements: a translation of the instrument frame cancels, and a constant cable "
            "offset or tip offset shows only through its small change of the configuration.")
    return out


def _flagged(d: diagnose.Diagnosis, f: _Facts) -> List[str]:
    """The rows left out of the fit, each with its reason."""
    prep = d.prep
    if not prep.flags:
        return [f"All {len(prep.meas)} rows were usable."]
    return ([f"{len(prep.flags)} of {len(prep.meas)} rows are flagged and left out of the fit "
             "(not dropped silently):"] + [f"{f.names[i]}: {why}" for i, why in sorted(prep.flags.items())])


def _support_words(d: diagnose.Diagnosis) -> str:
    """The support test of ``d`` in a few words."""
    src = d.noise_estimate.source
    if src == "assumed":
        return "the corrected paired held-out test (and BIC)"
    return ("the corrected likelihood-ratio test against the " + {"given": "given noise",
                                                                 "neighbours": "noise of neighbouring rows"}.get(
                                                                     src, "pure error of the repeats")
            + " (and a lower held-out RMS)")


def test_rows(d: diagnose.Diagnosis) -> List[List[str]]:
    """One row per test of ``d``, in the order asked: where, the model, the
    one it is tested against (nested: a support test; not nested: a tie
    test), the test, its statistic, degrees of freedom, p-value and level,
    the guard and the decision."""
    out = []
    for t in d.support:
        stat = f"{t.statistic:.3g}" if np.isfinite(t.statistic) else "—"
        out.append([t.step, f"`{t.big}`", f"`{t.small}`", {"chi2": "χ² (LR)", "F": "F (LR)"}.get(t.test, t.test),
                    stat, ", ".join(str(v) for v in t.dof), f"{t.p_value:.2g}", f"{t.alpha:.2g}",
                    f"{t.guard}: {'yes' if t.guard_passed else 'no'}" if t.nested else "— (not nested)",
                    ("**supported**" if t.supported else "no") if t.nested else ("differs" if t.supported else "tie")])
    return out


def tests_text(d: diagnose.Diagnosis) -> List[str]:
    """The paragraphs of the report's section on the tests behind the
    verdict: the support rule (and how an assumed noise limits it), the
    adequacy bounds used and how they were obtained, the lack-of-fit test."""
    v = d.verdict_detail
    out = [f"Support test: {d.support_rule}, at the family-corrected levels below (docs/model.md, \"The support "
           "test\"). Each row asks whether a model beats the nested smaller one (or, for two models not nested, "
           "whether the held-out errors tell them apart: a tie where they do not): the likelihood ratio's statistic "
           "is the drop in the position residuals' sum of squares over the noise variance (χ², degrees of "
           "freedom: the parameters added that are not at a bound), or that drop per parameter over the pure "
           "error's mean square (F); the signed-rank statistic is W+ over the rows' held-out gains."]
    if d.support_limits:
        out.append("**" + d.support_limits + "**")
    if v is not None and v.bound is not None:
        b, nb = v.bound, v.nominal_bound
        fin = d.final()
        out.append(
            f"Adequacy (docs/model.md, \"The adequacy bound\"): a model is adequate when its held-out RMS is within "
            f"its bound and the lack-of-fit test does not reject it at {diagnose.LACK_OF_FIT_ALPHA:g}. The bound is "
            f"the {b.quantile:g} quantile of the held-out RMS a correct model would reach on these rows and folds, "
            f"by a linearised parametric bootstrap around the model's fit ({b.draws} data sets simulated from the "
            f"fitted model's Jacobian plus the noise, refitted on the same folds). "
            + (f"`{d.best}`: held-out {_um(fin.heldout_rms)} against its bound {_um(b.bound)} "
               f"({b.factor:.2f}× the floor, median {_um(b.median)}, {b.parameters} parameters); the "
               if d.chosen is not None else "The ")
            + f"nominal model: held-out {_um(d.baseline.heldout_rms)} against {_um(nb.bound)} ({nb.factor:.2f}× the "
            f"floor, {nb.parameters} parameters). Lack of fit of the final model: "
            + (f"F = {v.statistic:.3g} ({v.dof[0]}, {v.dof[1]} dof)" if v.test == "F" and len(v.dof) > 1 else
               f"χ² = {v.statistic:.3g} ({v.dof[0]} dof)") + f", p = {v.p_value:.2g}.")
    return out


#: The outliers a summary names (the JSON lists every one).
OUTLIERS_SHOWN = 12


def outlier_note(d: diagnose.Diagnosis, names: List[str]) -> str:
    """The outliers, said against the noise they were judged by: a noise
    that was assumed, not estimated, is called so, and when every row is
    beyond it the assumption is what fails."""
    w = d.verdict_without_outliers
    ne = d.noise_estimate.source
    against = (f"beyond 5σ of the **assumed** noise ({_um(d.noise)} per axis; no repeats to estimate it)"
               if ne == "assumed" else f"beyond 5σ of the noise ({_um(d.noise)} per axis, {ne})")
    shown = [names[i] for i in d.outliers[:OUTLIERS_SHOWN]]
    more = len(d.outliers) - len(shown)
    listed = ", ".join(shown) + (f", ... ({len(d.outliers)} rows in all; the JSON lists every one)" if more > 0
                                 else "")
    text = f"Rows with a residual {against} after the fit: {listed}."
    many = diagnose.most_rows(len(d.outliers), int(d.prep.usable.sum()))
    if ne == "assumed" and many:
        text += (" So many rows cannot all be outliers: the assumed noise is too small for these data, or the "
                 "model misses an effect; give the noise (`--noise`) or repeat some commands to estimate it.")
    elif ne == "neighbours" and many:
        text += (" So many rows cannot all be outliers: the model misses an error larger than the noise of "
                 "neighbouring rows that neighbours share (a history, a drift, an effect outside the library), "
                 "or the robot repeats itself less well than neighbouring rows show.")
        if w is not None:
            text += f" Without them the verdict is **{w.verdict}**."
    elif w is not None:
        text += f" Without them the verdict is **{w.verdict}**."
    if d.without_outliers_skipped is not None:
        text += " The diagnosis is not rerun without them: they are most of the rows, the rest another data set."
    return text


def _plain(markdown: str) -> str:
    """A Markdown line for the terminal: no emphasis, code marks or links."""
    text = re.sub(r" — see \[[^\]]*\]\(#[^)]*\)", "", markdown)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
    return text.replace("**", "").replace("`", "")


def summary(d: diagnose.Diagnosis, suggestion=None) -> List[str]:
    """The headline for the command line: the verdict and why, the effect,
    how far the gap shrinks, the largest gaps, the next measurements; then
    the rows used and the flagged ones."""
    lines = [_plain(item) for item in headline_items(d, suggestion)]
    by = (f" over {d.prep.group_count} groups of {d.prep.group_column!r}"
          if d.prep.groups is not None else "")
    lines.append(f"rows: {int(d.prep.usable.sum())} of {len(d.prep.meas)} used ({d.prep.reading}), "
                 f"{d.folds}-fold cross-validation{by}")
    if d.prep.flags:
        lines.append(f"flagged rows: {', '.join(str(i + 1) for i in sorted(d.prep.flags))} (see the report)")
    if d.outliers:
        lines.append(_plain(outlier_note(d, _row_names(d))))
    return lines


# ---------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------
def _short_name(name: str, i: int) -> str:
    """A row's label on a figure: its point label, else its number."""
    return name.split(" ")[-1].strip("()") if "point" in name else str(i + 1)


def _clusters(xy: np.ndarray, link: float) -> List[np.ndarray]:
    """Groups (index arrays, 2 or more rows) of the finite points ``xy``
    (N, 2) chained by distances below ``link`` (single linkage: the
    connected components of ``scipy.sparse.csgraph`` over the pairs of
    ``scipy.spatial.KDTree``), largest first (ties: the lowest index first)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import KDTree

    fin = np.flatnonzero(np.isfinite(xy).all(1))
    if len(fin) < 2:
        return []
    pts = xy[fin]
    # a margin for the tree's own rounding, then the rule itself on each pair
    pairs = KDTree(pts).query_pairs(link * (1.0 + 1e-9), output_type="ndarray")
    pairs = pairs[np.hypot(*(pts[pairs[:, 0]] - pts[pairs[:, 1]]).T) < link]
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(fin), len(fin)))
    _, label = connected_components(graph, directed=False)
    groups: Dict[int, List[int]] = {}
    for i, lab in zip(fin, label):
        groups.setdefault(int(lab), []).append(int(i))
    out = [np.array(g) for g in groups.values() if len(g) >= 2]
    return sorted(out, key=lambda g: (-len(g), int(g[0])))


def _away_offsets(xy: np.ndarray, points: float = 7.0) -> np.ndarray:
    """(N, 2) label offsets in points: away from each point's nearest
    neighbour (``scipy.spatial.KDTree``; equally near ones: any one of them;
    up-right when it has none or sits on it), so close labels part."""
    out = np.tile([points * 0.7, points * 0.7], (len(xy), 1))
    from scipy.spatial import KDTree

    fin = np.flatnonzero(np.isfinite(xy).all(1))
    if len(fin) < 2:
        return out
    pts = xy[fin]
    dist, idx = KDTree(pts).query(pts, 2)
    # the nearest other point: the second hit, or the first where a copy came before the point itself
    other = np.where(idx[:, 0] == np.arange(len(fin)), idx[:, 1], idx[:, 0])
    v = pts - pts[other]
    nv = np.hypot(v[:, 0], v[:, 1])
    ok = nv > 0
    out[fin[ok]] = v[ok] / nv[ok, None] * points
    return out


def _arrow_panel(ax, xy, g, k, names, usable, labels=None, window=None, ref=None, title="",
                 xlabel="commanded tip X (mm)"):
    """Arrows of the gap ``g`` (N, 2) m at ``xy`` (N, 2) mm, ``k`` mm of plot
    per m; the rows ``labels`` (N,) bool labelled (parted from their nearest
    neighbour); square ``window`` (centre (2,), half width) in mm; a
    reference arrow of ``ref`` m."""
    ok = np.isfinite(g).all(1) & np.isfinite(xy).all(1)
    ax.scatter(xy[:, 0], xy[:, 1], s=12, c="#888888", zorder=2)
    q = ax.quiver(xy[ok, 0], xy[ok, 1], g[ok, 0] * k, g[ok, 1] * k, angles="xy", scale_units="xy", scale=1,
                  color=RED, width=0.006, zorder=3)
    bad = ~usable & np.isfinite(xy).all(1)
    if bad.any():
        ax.scatter(xy[bad, 0], xy[bad, 1], marker="x", s=50, c="k", zorder=4, label="flagged row")
        ax.legend(loc="lower right", fontsize=8)
    if labels is not None and labels.any():
        off = _away_offsets(xy)
        for i in np.flatnonzero(labels):
            ax.annotate(_short_name(names[i], i), xy[i], fontsize=8, xytext=tuple(off[i]), textcoords="offset points",
                        ha="center", va="center", color="#333333")
    if ref is not None and ref > 0:
        ax.quiverkey(q, 0.1, 0.05, ref * k, f"{ref * 1e6:g} µm", labelpos="E", coordinates="axes",
                     fontproperties={"size": 8})
    (cx, cy), half = window
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel(xlabel)
    ax.grid(True)
    ax.set_title(title, loc="left", fontsize=9.5)


def _window(pts: np.ndarray, pad: float):
    fin = pts[np.isfinite(pts).all(1)]
    if not len(fin):
        return (np.zeros(2), 1.0)
    lo, hi = fin.min(0), fin.max(0)
    return ((lo + hi) / 2, float(max(hi - lo)) / 2 + pad)


def _ref_arrow(gmax: float) -> float:
    """The largest 1, 2 or 5 times a power of ten not above ``gmax`` (m):
    the length of the reference arrow."""
    e = 10 ** math.floor(math.log10(max(gmax, 1e-12)))
    return max(m * e for m in (1, 2, 5) if m * e <= max(gmax, 1e-12) * (1 + 1e-9))


def residual_map_figure(d: diagnose.Diagnosis):
    """The gap (measured − model) as arrows at the commanded tips: the
    nominal model, the chosen model (only when one is chosen: the same arrow
    scale), and a zoom on the densest group of close rows with its own scale
    and each row's label beside it."""
    idx, axis_names = _map_axes(d)
    # an elastic arm's rows command tendons: its tips are the nominal model's equilibria
    where = "nominal" if d.prep.robot.is_elastic else "commanded"
    xlabel = f"{where} tip {axis_names[0]} (mm)"
    xy = _commanded_tip(d)[:, idx] * 1e3
    full_b, full_f = _gaps(d)
    # arrows at base-frame tips point in the base frame
    g_b, g_f = (_in_base_frame(d, g, c.fit)[:, idx] for g, c in ((full_b, d.baseline), (full_f, d.final())))
    names = _row_names(d)
    fin = np.isfinite(xy).all(1)
    span = float(np.nanmax(np.ptp(xy[fin], axis=0))) if fin.sum() > 1 else 1.0
    span = span if span > 0 else 1.0
    panels = [(g_b, "nominal model")] + ([(g_f, f"chosen model: {d.best}")] if d.chosen is not None else [])
    fulls = [full_b, full_f]  # each panel's gaps in every position component (the title's RMS)
    groups = _clusters(xy, 0.07 * span) if fin.sum() <= 60 else []
    zoom = groups[0] if groups and len(groups[0]) >= 2 else None
    cols = len(panels) + (zoom is not None)
    mag = np.linalg.norm(np.concatenate([g for g, _ in panels]), axis=1)
    gmax = float(np.nanmax(mag)) if np.isfinite(mag).any() else 1.0
    k = 0.15 * span / max(gmax, 1e-300)  # mm of plot per m of gap
    window = _window(xy, 0.12 * span + 1e-3)
    show = np.isfinite(xy).all(1) & (len(xy) <= 30)
    if zoom is not None:
        show[zoom] = False
    with report_style():
        fig = new_figure(min(3.45 * cols + 0.3, 10.4), 3.95)
        axes = np.atleast_1d(fig.subplots(1, cols))
        for ax, (g, title), full in zip(axes, panels, fulls):
            rms = float(np.sqrt(np.nanmean(np.sum(full[np.isfinite(full).all(1)] ** 2, 1)))) \
                if np.isfinite(full).any() else float("nan")
            _arrow_panel(ax, xy, g, k, names, d.prep.usable, labels=show, window=window, ref=_ref_arrow(gmax),
                         title=f"{title} (fit RMS {_um(rms)})", xlabel=xlabel)
        axes[0].set_ylabel(f"{where} tip {axis_names[1]} (mm)")
        if zoom is not None:
            from matplotlib.patches import Rectangle

            (cx, cy), half = _window(xy[zoom], 0.0)
            half = max(half * 1.35, 0.01 * span)
            for ax in axes[:len(panels)]:
                ax.add_patch(Rectangle((cx - half, cy - half), 2 * half, 2 * half, fill=False, ec="k", ls="--",
                                       lw=0.8, zorder=1))
                ax.annotate("zoom →", (cx + half, cy + half), fontsize=7.5, xytext=(2, 2), textcoords="offset points")
            g = panels[-1][0]
            zm = np.linalg.norm(g[zoom], axis=1)
            zmax = float(np.nanmax(zm)) if np.isfinite(zm).any() else 1.0
            kz = 0.3 * half / max(zmax, 1e-300)
            ax = axes[-1]
            _arrow_panel(ax, xy, g, kz, names, d.prep.usable, window=((cx, cy), half), xlabel=xlabel,
                         ref=_ref_arrow(zmax), title=f"zoom on rows {', '.join(_short_name(names[i], i) for i in zoom)}"
                         f"\n({panels[-1][1]}, own arrow scale)")
            # labels in a column right of the window, leader lines to their points
            order = sorted(zoom, key=lambda i: -xy[i, 1])
            for r, i in enumerate(order):
                yy = 0.92 - r * min(0.84 / max(len(order) - 1, 1), 0.14)
                ax.annotate(_short_name(names[i], i), xy[i], xytext=(1.04, yy), textcoords="axes fraction",
                            fontsize=8, va="center", color="#333333",
                            arrowprops=dict(arrowstyle="-", color="0.55", lw=0.6, shrinkA=0, shrinkB=3))
        place(fig, 1, cols, left=0.7, right=0.45 if zoom is not None else 0.15, bottom=0.5, top=0.5, wgap=0.55)
    return fig


def residual_bars_figure(d: diagnose.Diagnosis):
    N = len(d.prep.meas)
    g_b, g_f = _gaps(d)
    chosen = d.chosen is not None
    with report_style():
        fig = new_figure(max(7.0, min(10.4, 0.22 * N + 4)), 5.0)
        axes = fig.subplots(2, 1, sharex=True)
        x = np.arange(N)
        w = 0.4 if chosen else 0.6
        for ax, j, lab, col in ((axes[0], 0, "dX", RED), (axes[1], 1, "dY", BLUE)):
            ax.axhspan(-d.noise * 1e6, d.noise * 1e6, color=GREEN, alpha=0.15, label="± noise (1 σ)")
            ax.bar(x - (0.2 if chosen else 0.0), g_b[:, j] * 1e6, w, color=col, alpha=0.45 if chosen else 0.9,
                   label="nominal model")
            if chosen:
                ax.bar(x + 0.2, g_f[:, j] * 1e6, w, color=col, label=f"chosen: {d.best}")
            for i in np.flatnonzero(~d.prep.usable):
                ax.axvline(i, color="k", ls=":", lw=1)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_ylabel(f"gap {lab} (µm)")
            ax.grid(True, axis="y")
        axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
        axes[1].set_xlabel("row (dotted: flagged)")
        if N <= 40:
            axes[1].set_xticks(x)
            axes[1].set_xticklabels([str(i + 1) for i in x], fontsize=8)
        place(fig, 2, 1, left=0.8, right=1.9, bottom=0.55, top=0.2, hgap=0.25)
    return fig


def candidates_figure(d: diagnose.Diagnosis):
    cands = list(d.singles) + [c for c in d.steps if len(c.effects) > 1]
    cands.sort(key=lambda c: c.heldout_rms)
    chosen = d.chosen is not None
    with report_style():
        fig = new_figure(8.0, max(3.0, 0.3 * (len(cands) + 1) + 1.6))
        ax = fig.subplots()
        vals = [c.heldout_rms * 1e6 for c in cands] + [d.baseline.heldout_rms * 1e6]
        labels = [c.name for c in cands] + ["none (nominal)"]
        cols = [RED if chosen and c.name == d.best else BLUE for c in cands] + ["#888888"]
        y = np.arange(len(vals))[::-1]
        ax.barh(y, vals, color=cols)
        ax.set_yticks(y)
        ax.set_yticklabels(labels, fontsize=8)
        ax.axvline(d.noise_floor * 1e6, color=GREEN, ls="--", label=f"noise floor {d.noise_floor * 1e6:.1f} µm")
        ax.axvline(d.baseline.heldout_rms * 1e6, color="#555555", ls=":",
                   label=f"nominal {d.baseline.heldout_rms * 1e6:.1f} µm")
        fin = [v for v in vals if np.isfinite(v) and v > 0]
        if fin and max(fin) / min(fin + [d.noise_floor * 1e6]) > 20:
            ax.set_xscale("log")
        ax.set_xlabel("held-out RMS position error (µm)")
        what = f"red: chosen ({d.best})" if chosen else "no effect chosen"
        ax.set_title(f"candidates ({d.folds}-fold cross-validation; {what})", loc="left", fontsize=9.5)
        # the legend below the axes: inside it covered the nominal bar
        ax.grid(True, axis="x")
        place(fig, 1, 1, left=2.0, right=0.3, bottom=0.95, top=0.35)
        ah = fig.get_size_inches()[1] - 0.95 - 0.35  # axes height, in
        ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.55 / ah), ncol=2, fontsize=8, frameon=False)
    return fig


def features_figure(d: diagnose.Diagnosis, k: int = 4):
    g_b, g_f = _gaps(d)
    sb, sf = np.linalg.norm(g_b, axis=1), np.linalg.norm(g_f, axis=1)
    feats = [(n, r) for n, r in _ranked_features(d, sb) if np.isfinite(r)][:k]
    if not feats:
        return None
    with report_style():
        fig = new_figure(min(2.6 * len(feats) + 0.9, 10.4), 3.6)
        axes = np.atleast_1d(fig.subplots(1, len(feats), sharey=True))
        for ax, (name, rho) in zip(axes, feats):
            v = np.asarray(d.features[name], float)
            ax.scatter(v, sb * 1e6, facecolors="none", edgecolors=BLUE, label="nominal model")
            if d.chosen is not None:
                ax.scatter(v, sf * 1e6, c=RED, s=14, label=f"chosen: {d.best}")
            ax.axhline(d.noise_floor * 1e6, color=GREEN, ls="--", lw=1)
            ax.set_xlabel(name, fontsize=8.5)
            ax.set_title(f"ρ = {rho:+.2f}", loc="left", fontsize=9.5)
            ax.grid(True)
            ax.xaxis.set_major_locator(MaxNLocator(4))
        axes[0].set_ylabel("|gap| (µm)")
        axes[0].legend(loc="best", fontsize=8)
        place(fig, 1, len(feats), left=0.75, right=0.15, bottom=0.6, top=0.35, wgap=0.25)
    return fig


def figures(d: diagnose.Diagnosis) -> Dict[str, bytes]:
    """The report's figures as PNG bytes ({name: PNG}; those that apply)."""
    out = {}
    for name, make in (("residual_map", residual_map_figure), ("residual_bars", residual_bars_figure),
                       ("candidates", candidates_figure), ("features", features_figure)):
        fig = make(d)
        if fig is not None:
            out[name] = png_bytes(fig)
    return out


def _captions(d: diagnose.Diagnosis) -> Dict[str, str]:
    chosen = d.chosen is not None
    return {
        "residual_map": "Gap (measured − model) as arrows at the commanded tip positions: the nominal model"
                        + (f" and the chosen model `{d.best}` (fitted on all usable rows), same arrow scale"
                           if chosen else " (no model is chosen)")
                        + "; the dashed square is zoomed on the right with its own arrow scale. Crosses: flagged "
                          "rows.",
        "residual_bars": "Per-row gap in X and Y (µm): the nominal model" + (" (light) and the chosen model (dark)"
                                                                            if chosen else "")
                         + "; green band: ± measurement noise; dotted: flagged rows.",
        "candidates": "Held-out RMS position error of every candidate effect"
                      + (" and of the chosen combination (red)" if chosen else "")
                      + ", with the noise floor (green) and the nominal model (grey).",
        "features": "|gap| per row against the configuration features with the strongest rank correlation "
                    "(ρ with the nominal model's |gap|).",
    }


# ---------------------------------------------------------------------------
# the report
# ---------------------------------------------------------------------------
def next_steps(d: diagnose.Diagnosis, suggestion=None) -> List[str]:
    """The next measurements, in words, from the diagnosis (and the
    suggested configurations when given)."""
    out = []
    if d.noise_estimate.source == "assumed":
        out.append("Repeat some commands (approached from the same side) to measure the noise: it is assumed "
                   f"({_um(d.noise)}), and the verdict depends on it.")
    if d.ties and d.singles:
        out.append(f"Measure where `{d.singles[0].name}` and its ties ({', '.join(d.ties)}) predict differently"
                   + (": the suggested configurations below." if suggestion is not None else
                      " (`cdsm diagnose DATA --suggest K` proposes the configurations)."))
    elif d.verdict == "unexplained":
        out.append("Move other cables and in both directions: rows that differ from these are what tell the "
                   "candidate effects apart" + (" (the suggested configurations below)." if suggestion is not None
                                                else " (`--suggest K`)."))
    if d.verdict in ("explained", "partly explained") and d.chosen is not None:
        out.append(f"Check `{d.best}` on new rows, not used in the fit (`--save-model`, then `cdsm compensate`).")
    if d.verdict == "no gap":
        out.append("None needed to explain the data; more rows would tighten the noise estimate.")
    if suggestion is not None:
        out.append(f"{len(suggestion)} suggested configurations ({suggestion.criterion}) are in `suggested.csv`.")
    return out


def headline_items(d: diagnose.Diagnosis, suggestion=None) -> List[str]:
    """The answers of the diagnosis, in numbers: verdict, effect, how far
    the gap shrinks, where it lies, the next measurements."""
    b, f = d.baseline.heldout_rms, d.final().heldout_rms
    items = [f"**Verdict: {d.verdict}** — " + {
        "no gap": "the nominal model is within the measurement noise.",
        "explained": "one effect of the library explains the gap down to the noise.",
        "partly explained": "an effect explains part of the gap; the rest is more than noise.",
    }.get(d.verdict, "no effect of the library reduces the gap significantly.")]
    if d.chosen is not None:
        items.append(f"**Effect: `{d.best}`** — " + "; ".join(f"{lab} = {txt}" for _, lab, txt, _, _ in
                                                                param_rows(d, d.chosen)) + "."
                     + "".join(" " + note for note in bound_notes(d, d.chosen)))
    elif d.singles:
        t = d.singles[0]
        items.append(f"**Effect: none.** The best single candidate, `{t.name}`, reaches {_um(t.heldout_rms)} "
                     f"held-out, not significantly better than the nominal model"
                     + (f"; it ties with {', '.join(d.ties)}." if d.ties else "."))
    floor = (f"noise floor {_um(d.noise_floor)} "
             f"({'estimated from repeats' if d.noise_estimate.source == 'repeats' else d.noise_estimate.source})")
    if d.chosen is not None:
        shrink = 100.0 * (1.0 - f / b) if b > 0 else 0.0
        items.append(f"**How far the gap shrinks**: held-out RMS position error {_um(b)} (nominal) → {_um(f)} with "
                     f"`{d.best}` ({shrink:.0f} % smaller); {floor}.")
    else:
        t = d.singles[0] if d.singles else None
        items.append(f"**How far the gap shrinks**: it does not — held-out RMS position error {_um(b)} with the "
                     "nominal model" + (f"; the best candidate would give {_um(t.heldout_rms)} "
                                        f"({100.0 * (1.0 - t.heldout_rms / b):.0f} % smaller), not a significant "
                                        "difference on these rows" if t is not None and b > 0 else "")
                     + f"; {floor}.")
    g_b, _ = _gaps(d)
    size = np.linalg.norm(g_b, axis=1)
    names = _row_names(d)
    top = [i for i in np.argsort(-np.nan_to_num(size, nan=-1.0)) if np.isfinite(size[i])][:3]
    if top:
        items.append("**Largest gaps**: " + "; ".join(f"{names[i]} {_um(size[i])}" for i in top)
                     + " — see [where the gap lies](#where).")
    steps = next_steps(d, suggestion)
    if steps:
        items.append("**Next measurements**: " + " ".join(steps).rstrip(".") + " — see [next](#next).")
    return items


def _build(d: diagnose.Diagnosis, pngs: Dict[str, bytes], suggestion=None, validation=None) -> Document:
    prep = d.prep
    f = findings(d)
    names = _row_names(d)
    caps = _captions(d)
    doc = Document("Sim-to-real gap diagnosis")

    def fig(name):
        if name in pngs:
            doc.fig(name, caps.get(name, name))

    doc.section(HEADLINE, "Headline")
    src = os.path.basename(prep.meas.source) if prep.meas.source else "measurements"
    ne = d.noise_estimate.source
    doc.p(f"Data: {literal(src)} — {len(prep.meas)} rows of **{prep.reading}** measurements ({int(prep.usable.sum())} "
          f"usable); robot **{literal(prep.robot.name)}** ({prep.robot.n} joints); measurement noise "
          f"{'assumed ' if ne == 'assumed' else ''}{_um(d.noise)} per axis"
          f"{' (estimated from repeats)' if ne == 'repeats' else ''}; {d.folds}-fold cross-validation"
          f"{' by ' + literal(prep.group_column) if prep.groups is not None else ''}; "
          f"candidate library: {', '.join(c.name for c in d.singles) or 'empty'}. cdsm {__version__}. The "
          "diagnosis was not told which effect is in the data.")
    items = headline_items(d, suggestion)
    if validation is not None:
        v = validation
        items.append(f"**On a second file** ({literal(os.path.basename(v.source) or 'validation data')}, "
                     f"{v.rows} of {v.rows_in_file} rows, nothing refitted): tip error RMS {_um(v.nominal_rms)} "
                     f"nominal → {_um(v.model_rms)} with {literal(v.model)}; mean offset removed "
                     f"{_um(v.nominal_rms_mean_aligned)} → {_um(v.model_rms_mean_aligned)}.")
    doc.ul(items)
    if validation is not None:
        v = validation
        doc.section("validation", "On a second file")
        flagged = f" ({len(v.flagged)} flagged by the nominal model, as on the first file)" if v.flagged else ""
        lost = "; ".join(f"the {k} model cannot predict {len(r)} row(s) ({', '.join(str(i + 1) for i in r[:10])}"
                         f"{', ...' if len(r) > 10 else ''})" for k, r in v.unpredicted.items() if r)
        doc.p(f"The nominal model and {literal(v.model)}, every parameter and the frame as fitted on "
              f"{literal(src)}, predict {literal(os.path.basename(v.source) or 'the second file')}: nothing is "
              f"refitted there. {v.rows} of its {v.rows_in_file} rows are scored"
              f"{flagged}"
              f"{'; ' + lost if lost else ''}. Tip position error, RMS over those rows: {_um(v.nominal_rms)} "
              f"nominal, {_um(v.model_rms)} with {literal(v.model)}; after removing the error's mean over the "
              f"rows (three translations): {_um(v.nominal_rms_mean_aligned)} and "
              f"{_um(v.model_rms_mean_aligned)}.")
        if v.candidates:
            doc.p("Every other model the diagnosis fitted on the first file (each effect alone, each step of the "
                  "selection), judged the same way on the same rows — which effects carry over, best first:")
            ranked = sorted(v.candidates.items(), key=lambda kv: np.nan_to_num(kv[1][0], nan=np.inf))
            doc.table(["model (fitted on the first file)", "tip error RMS", "mean offset removed",
                       "rows not predicted"],
                      [[literal(name), _um(r), _um(ra), str(len(lost))] for name, (r, ra, lost) in ranked]
                      + [[f"{literal(v.model)} (chosen)", _um(v.model_rms), _um(v.model_rms_mean_aligned), "—"],
                         ["nominal", _um(v.nominal_rms), _um(v.nominal_rms_mean_aligned), "—"]])
    doc.section("answer", "Answer")
    for t in f["answer"]:
        doc.p(t)
    doc.section("where", "Where the gap lies")
    for t in f["where"]:
        doc.p(t)
    g_b, g_f = _gaps(d)
    hb, hf = _heldout_full(d, d.baseline), _heldout_full(d, d.final())
    xy = _commanded_tip(d)[:, :2]
    order = np.argsort(-np.nan_to_num(np.linalg.norm(g_b, axis=1), nan=np.inf))
    chosen = d.chosen is not None
    rows = []
    for i in order[:min(len(order), 12)]:
        row = [names[i], f"{xy[i, 0] * 1e3:.1f}, {xy[i, 1] * 1e3:.1f}" if np.isfinite(xy[i]).all() else "—",
               _pair_um(g_b[i]), _f1(hb[i] * 1e6)]
        if chosen:
            row += [_pair_um(g_f[i]), _f1(hf[i] * 1e6)]
        rows.append(row + [prep.flags.get(int(i), "")])
    doc.table(["row", "commanded X, Y (mm)", "gap nominal dX, dY (µm)", "held-out |e| nominal (µm)"]
              + ([f"gap with {d.best} dX, dY (µm)", f"held-out |e| with {d.best} (µm)"] if chosen else []) + ["flag"],
              rows)
    fig("residual_map")
    fig("residual_bars")
    fb = _ranked_features(d, np.linalg.norm(g_b, axis=1))
    ff = dict(_ranked_features(d, np.linalg.norm(g_f, axis=1)))
    doc.table(["feature", "Spearman ρ with |gap| (nominal)"] + (["with |gap| (chosen)"] if chosen else []),
              [[k, f"{rho:+.2f}" if np.isfinite(rho) else "constant"]
               + ([f"{ff.get(k, float('nan')):+.2f}" if np.isfinite(ff.get(k, float("nan"))) else "constant"]
                  if chosen else []) for k, rho in fb])
    fig("features")
    doc.section("which", "Which effect explains it")
    for t in f["which"]:
        doc.p(t)
    if d.chosen is not None:
        doc.table(["effect", "parameter", "value ± std"], [[e, lab, txt] for e, lab, txt, _, _ in
                                                           param_rows(d, d.chosen)])
    doc.section("shrink", "How far it shrinks")
    for t in f["shrink"]:
        doc.p(t)
    cands = list(d.singles) + [c for c in d.steps if len(c.effects) > 1]
    cands.sort(key=lambda c: c.heldout_rms)
    b = d.baseline
    doc.table(["candidate", "held-out RMS (µm)", "vs nominal", "× noise floor", "fit RMS (µm)", "ΔBIC",
               "parameters"],
              [["none (nominal)", f"{b.heldout_rms * 1e6:.1f}", "—", f"{b.heldout_rms / d.noise_floor:.2f}",
                f"{b.fit.rms * 1e6:.1f}", "0", "—"]] +
              [[("**" + c.name + "**") if chosen and c.name == d.best else c.name, f"{c.heldout_rms * 1e6:.1f}",
                f"{100 * (c.heldout_rms / b.heldout_rms - 1):+.0f} %", f"{c.heldout_rms / d.noise_floor:.2f}",
                f"{c.fit.rms * 1e6:.1f}", f"{c.fit.bic - b.fit.bic:+.1f}",
                "; ".join(f"{lab} {txt}" for _, lab, txt, _, _ in param_rows(d, c))] for c in cands])
    fig("candidates")
    doc.section("tests", "The tests behind the verdict")
    for t in tests_text(d):
        doc.p(t)
    if d.support:
        doc.table(["step", "model", "against", "test", "statistic", "dof", "p", "level", "guard", "decision"],
                  test_rows(d))
    doc.section("identifiability", "Identifiability")
    for t in f["identifiability"]:
        doc.p(t)
    doc.section("next", "Next measurements")
    doc.ul(next_steps(d, suggestion) or ["None proposed."])
    if suggestion is not None:
        lines = [ln.strip() for ln in suggestion.summary().splitlines() if ln.strip()]
        doc.ul(lines)
    doc.section("flagged", "Flagged rows")
    if prep.flags:
        doc.ul(f["flagged"][1:])
        doc.p(f["flagged"][0])
    else:
        doc.p(f["flagged"][0])
    doc.section("files", "Files")
    doc.ul(["`diagnosis.json` — the diagnosis (SI units; keys `best`, `baseline.heldout_rms_m`, `effects` best "
            "first with `name`, `params`, `heldout_rms_m`; `support.tests` each test's statistic, `dof`, "
            "`p_value`; `adequacy` the bounds used and how they were obtained)",
            "`residuals.csv` — per row: commanded tip, gap (measured − model) of the nominal and final "
            "model per position axis in the robot's base frame, held-out errors, features, flag (SI units)"]
           + (["`suggested.csv` — the suggested configurations"] if suggestion is not None else [])
           + ["`figures/*.png` — the figures of this report"])
    return doc


def _f1(v: float) -> str:
    return f"{v:.1f}" if np.isfinite(v) else "—"


def _pair_um(g) -> str:
    return f"{g[0] * 1e6:+.1f}, {g[1] * 1e6:+.1f}" if np.isfinite(g[:2]).all() else "—"


def _residual_rows(d: diagnose.Diagnosis) -> List[dict]:
    """``residuals.csv``: a row per measurement; the commanded tip and the
    gaps (measured − model) with one column per measured position axis, the
    gaps in the robot's base frame (registered data turned from the
    measuring frame by each model's own fitted frame, as the residual map
    draws them)."""
    full_b, full_f = _gaps(d)
    g_b, g_f = (_in_base_frame(d, g, c.fit) for g, c in ((full_b, d.baseline), (full_f, d.final())))
    hb, hf = _heldout_full(d, d.baseline), _heldout_full(d, d.final())
    tip = _commanded_tip(d)
    axes = "xyz"[:g_b.shape[1]]
    names = _row_names(d)
    out = []
    for i in range(len(d.prep.meas)):
        r: Dict[str, object] = dict(row=i + 1, name=names[i])
        r.update({f"{a}_cmd_m": tip[i, j] for j, a in enumerate(axes[:tip.shape[1]])})
        r.update({f"gap_nominal_d{a}_m": g_b[i, j] for j, a in enumerate(axes)})
        r.update({f"gap_final_d{a}_m": g_f[i, j] for j, a in enumerate(axes)})
        r.update(heldout_nominal_m=hb[i], heldout_final_m=hf[i])
        for k, v in d.features.items():
            r[k] = float(v[i])
        r["flag"] = d.prep.flags.get(i, "")
        out.append(r)
    return out


def write(d: diagnose.Diagnosis, out: "str | os.PathLike[str]", suggestion=None, overwrite: bool = False,
          validation=None) -> Dict[str, str]:
    """Write ``report.md``, ``report.html`` (self-contained), ``diagnosis.json``,
    ``residuals.csv``, ``figures/*.png`` and, given a ``suggestion``
    (:func:`cdsm.calibration.experiment.suggest`), ``suggested.csv`` into
    ``out`` (created), owned by this run while it writes
    (:func:`cdsm.files.run_directory`: refused while another run writes
    there, or when it holds files of these names (:data:`FILES`) that no
    cdsm run wrote, unless ``overwrite``). Returns {name: path}
    (``report_md``, ``report_html``, ``json``, ``csv``, ``figures``,
    ``suggested_csv``, ``manifest``: see :meth:`cdsm.files.Run.finish`).
    ``validation``: the models judged on a second file
    (:func:`cdsm.calibration.validation.validate`), a headline item, a
    section and the JSON's ``validation``."""
    with run_directory(out, "cdsm diagnose", FILES, overwrite=overwrite) as run:
        pngs = figures(d)
        paths = {"figures": os.path.join(run.out, "figures")}
        for name, data in pngs.items():
            run.write(f"figures/{name}.png", data, "figure")
        doc = _build(d, pngs, suggestion, validation)
        paths["report_md"] = run.write_text("report.md", doc.markdown("figures", pngs), "report")
        name = os.path.basename(d.prep.meas.source or "") or "measurements"
        paths["report_html"] = run.write_text("report.html", doc.html(pngs, f"cdsm diagnose — {name}"), "report")
        js = d.to_json()
        if validation is not None:
            js["validation"] = validation.to_json()
        paths["json"] = run.write_json("diagnosis.json", js, "diagnosis")
        paths["csv"] = run.write_csv("residuals.csv", _residual_rows(d), "residuals")
        if suggestion is not None:
            paths["suggested_csv"] = run.write_text("suggested.csv", suggestion.csv_text(), "suggestion")
        paths["manifest"] = run.finish()
    return paths
