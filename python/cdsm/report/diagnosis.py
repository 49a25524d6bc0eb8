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
from typing import Dict, List, Tuple

import numpy as np

from .. import __version__
from ..calibration import diagnosis as diagnose
from ..calibration import stats
from ..files import begin_run, finish_run, write_csv, write_json, write_text
from .document import Document
from .figures import BLUE, GREEN, RED, new_figure, save

__all__ = ["write", "findings", "summary", "param_rows"]

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


def _pm(v: float, s: float, scale: float, unit: str, nd: int) -> str:
    if s is None or not np.isfinite(s) or s <= 0.0:
        # NaN: the fit found a direction the data do not see (diagnose.fit)
        return f"{v * scale:+.{nd}f} {unit} (not determined by these data)"
    return f"{v * scale:+.{nd}f} ± {s * scale:.{nd}f} {unit}"


def _param_labels(effect: str, n: int) -> List[Tuple[str, str]]:
    """(label, unit kind) of each parameter of ``effect`` for ``n`` joints.
    Unit kinds: len (m), ratio (1), rad, compliance (1/N)."""
    if effect == "actuation_scale":
        return [("actuation scale s", "ratio")]
    if effect == "cable_offset":
        return [(f"offset of upper cable {2 * i + 1} (pair {i + 1})", "len") for i in range(n)]
    if effect == "hole_height":
        return [(f"hole-height error, pair {i + 1}", "len") for i in range(n)]
    if effect == "link_length":
        return [("base → joint 1", "len")] + [(f"joint {i + 1} → disk {i + 1}", "len") for i in range(n)]
    if effect == "cable_elasticity":
        return [("compliance 1/(E A)", "compliance")]
    if effect == "hole_clearance":
        return [("hole clearance c", "len")]
    if effect == "frame_misalignment":
        return [("frame rotation", "rad"), ("frame x", "len"), ("frame y", "len")]
    if effect == "tip_offset":
        return [("tip offset x (end frame)", "len"), ("tip offset y (end frame)", "len")]
    return [(f"{effect}[{j}]", "len") for j in range(n)]  # pragma: no cover


def _fmt_param(kind: str, v: float, s: float) -> str:
    if kind == "ratio":
        return _pm(v, s, 100.0, "%", 2)
    if kind == "rad":
        return _pm(v, s, 1e3, "mrad", 2)
    if kind == "compliance":
        txt = _pm(v, s, 1.0, "1/N", 4)
        if v > 0:
            txt += f" (E·A ≈ {1.0 / v:.3g} N)"
        return txt
    big = max(abs(v), abs(s) if np.isfinite(s) else 0.0)
    return _pm(v, s, 1e3, "mm", 3) if big >= 1e-3 else _pm(v, s, 1e6, "µm", 1)


def param_rows(d: diagnose.Diagnosis, cand: diagnose.Candidate) -> List[Tuple[str, str, str, float, float]]:
    """(effect, parameter label, readable value ± std, value SI, std SI) of a
    candidate's fit on all usable rows."""
    robot = d.prep.robot
    vals = cand.fit.params_by_effect(robot)
    stds = cand.fit.std_by_effect(robot)
    out = []
    for e in cand.effects:
        for (lab, kind), v, s in zip(_param_labels(e, robot.n), vals[e], stds[e]):
            out.append((e, lab, _fmt_param(kind, float(v), float(s)), float(v), float(s)))
    return out


# ---------------------------------------------------------------------------
# per-row quantities
# ---------------------------------------------------------------------------
def _row_names(d: diagnose.Diagnosis) -> List[str]:
    labels = d.prep.meas.labels
    key = next((k for k in ("point", "label", "id", "name") if k in labels), None)
    return [f"row {i + 1}" + (f" (point {labels[key][i]})" if key else "") for i in range(len(d.prep.meas))]


def _commanded_xy(d: diagnose.Diagnosis) -> np.ndarray:
    """(N, 2) commanded tip position (m) of the nominal model; the commanded
    pose for rows whose command was not solved (NaN if none was given)."""
    xy = np.stack([d.features["X (m)"], d.features["Y (m)"]], 1).astype(float)
    bad = ~d.prep.usable
    if bad.any():
        xy[bad] = d.prep.meas.pose_cmd[bad, :2] if d.prep.meas.pose_cmd is not None else np.nan
    return xy


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
    thr = 1.96 / math.sqrt(max(n - 1, 1))
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
    names = _row_names(d)
    prep, rows = d.prep, d.prep.rows
    nu = len(rows)
    base, final = d.baseline, d.final()
    b_rms, f_rms, floor = base.heldout_rms, final.heldout_rms, d.noise_floor
    g_base, g_final = _gaps(d)
    size_b = np.linalg.norm(g_base, axis=1)
    size_f = np.linalg.norm(g_final, axis=1)
    out: Dict[str, List[str]] = {k: [] for k in ("answer", "where", "which", "shrink", "identifiability",
                                                 "flagged")}
    cv = ("leave-one-out" if d.folds >= nu else f"{d.folds}-fold") + " cross-validation"
    shrink = 100.0 * (1.0 - f_rms / b_rms) if b_rms > 0 else 0.0

    # -- the answer ------------------------------------------------------
    v = d.verdict_detail
    ne = d.noise_estimate
    if ne.source == "repeats":
        ntxt = (f"{_um(d.noise)} per axis and reading, estimated from {ne.groups} groups of repeated commands "
                f"approached from the same direction (95 % interval {_um(ne.ci[0])}–{_um(ne.ci[1])})")
    elif ne.source == "given":
        ntxt = f"{_um(d.noise)} per axis and reading, as given"
    else:
        ntxt = (f"{_um(d.noise)} per axis and reading, **assumed** (no repeated commands in the data and "
                "none given)")
    lof = (f"lack-of-fit test ({'F against pure error' if v.test == 'F' else 'chi-square against the noise'}): "
           f"p = {v.p_value:.2g}")
    if d.verdict == "no gap":
        out["answer"].append(
            f"**No gap beyond measurement noise** (verdict: no gap). The nominal model's held-out RMS position "
            f"error is {_um(b_rms)}, within 1.5× the noise floor {_um(floor)}, and the {lof}; no effect of the "
            "library improves it significantly. Answer: **none**.")
    elif d.verdict == "unexplained":
        top = d.singles[0] if d.singles else None
        extra = (f" The best single candidate, `{top.name}`, reaches {_um(top.heldout_rms)}, which the "
                 "corrected paired held-out test (and BIC) cannot tell apart from the nominal model on these rows."
                 if top is not None else "")
        out["answer"].append(
            f"**The gap stays unexplained** (verdict: unexplained). The nominal model misses the measurements "
            f"by {_um(b_rms)} held-out RMS ({b_rms / floor:.1f}× the noise floor {_um(floor)}), and no "
            f"effect of the library ({len(d.singles)} tried) reduces it significantly.{extra} "
            "Answer: **none** — the cause lies outside the library (or the data are too few to tell).")
    else:
        what = ("explains the gap down to the noise level" if d.verdict == "explained" else
                "explains part of the gap; what is left is more than noise")
        out["answer"].append(
            f"**`{d.best}` {what}** (verdict: {d.verdict}). Held-out RMS position error ({cv}): nominal model "
            f"{_um(b_rms)} → with `{d.best}` {_um(f_rms)} ({shrink:.0f} % smaller; noise floor {_um(floor)}, "
            f"final/floor = {f_rms / floor:.2f}; {lof}).")
    out["answer"].append(f"Noise: {ntxt}; the floor is √2 × {'√2 × ' if prep.readings > 1 else ''}σ = "
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
        out["answer"].append(reg)
    if d.outliers:
        w = d.verdict_without_outliers
        out["answer"].append(
            f"Outliers (residual beyond 5σ after the fit): {', '.join(names[i] for i in d.outliers)}. "
            + (f"Without them the verdict is **{w.verdict}**." if w is not None else ""))

    # -- where the gap lies --------------------------------------------
    order = [i for i in np.argsort(-np.nan_to_num(size_b, nan=-1.0)) if np.isfinite(size_b[i])]
    sse = size_b[rows] ** 2
    tot = float(sse.sum())
    k50 = int(np.searchsorted(np.cumsum(np.sort(sse)[::-1]) / max(tot, 1e-300), 0.5) + 1) if tot > 0 else 0
    top = order[:min(3, len(order))]
    out["where"].append(
        "Largest gaps (nominal model): " + "; ".join(
            f"{names[i]} at X = {_commanded_xy(d)[i, 0] * 1e3:.1f} mm, Y = {_commanded_xy(d)[i, 1] * 1e3:.1f} mm: "
            f"{_um(size_b[i])} (dX {_um(g_base[i, 0])}, dY {_um(g_base[i, 1])})" for i in top)
        + f". {k50} of {nu} rows carry{'' if k50 > 1 else 'es'} half of the squared gap"
        + (" — the gap is concentrated in a few rows." if k50 <= max(1, nu // 5) else "."))
    rx = float(np.sqrt(np.nanmean(g_base[rows, 0] ** 2)))
    ry = float(np.sqrt(np.nanmean(g_base[rows, 1] ** 2)))
    axis = ("mostly along Y" if ry > 1.5 * rx else "mostly along X" if rx > 1.5 * ry else "in both axes alike")
    mx, my = float(np.nanmean(g_base[rows, 0])), float(np.nanmean(g_base[rows, 1]))
    out["where"].append(
        f"Per axis, the gap is {axis}: RMS dX {_um(rx)}, dY {_um(ry)} (means {_um(mx)}, {_um(my)}: "
        + ("a systematic offset in the mean" if math.hypot(mx, my) > 0.5 * math.hypot(rx, ry) else
           "mostly configuration-dependent, not a constant offset") + ").")
    xy = _commanded_xy(d)
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
        out["where"].append(
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
        out["where"].append("Configuration features that explain the size of the gap (rank correlation with "
                            "|gap| of the nominal model): " + "; ".join(lines) + "."
                            + (f" Constant in these data (no information): {', '.join(const)}." if const else ""))
    if not d.explained and d.chosen is not None:
        order_f = [i for i in np.argsort(-np.nan_to_num(size_f, nan=-1.0)) if np.isfinite(size_f[i])][:3]
        ff = [(k, rho) for k, rho in _ranked_features(d, size_f) if np.isfinite(rho)][:2]
        out["where"].append(
            f"What `{d.best}` leaves unexplained ({_um(f_rms)} held-out, {f_rms / floor:.1f}× the noise floor) "
            "lies at " + "; ".join(f"{names[i]}: {_um(size_f[i])}" for i in order_f)
            + (("; its size follows " + ", ".join(f"{k} (ρ = {rho:+.2f})" for k, rho in ff)) if ff else "") + ".")

    # -- which effect ----------------------------------------------------
    if d.chosen is not None:
        prs = param_rows(d, d.chosen)
        out["which"].append(f"`{d.best}` fitted on all {nu} usable rows: " + "; ".join(
            f"{lab} = {txt}" + (f" ({abs(v) / s:.1f} σ from zero)" if np.isfinite(s) and s > 0 else "")
            for _, lab, txt, v, s in prs) + ".")
        if len(d.steps) > 1:
            out["which"].append("Forward selection: " + " → ".join(
                f"`{c.name}` {_um(c.heldout_rms)}" for c in d.steps) + " (each step kept only when it beats the "
                "previous one on held-out rows beyond noise and lowers BIC).")
    elif d.singles:
        t = d.singles[0]
        out["which"].append(
            f"No effect is chosen. For reference, the best single candidate `{t.name}` would be: " + "; ".join(
                f"{lab} = {txt}" for _, lab, txt, _, _ in param_rows(d, t)) + ".")

    # -- how far it shrinks ----------------------------------------------
    out["shrink"].append(
        f"Held-out RMS position error ({cv}, {nu} rows): nominal {_um(b_rms)}; " + ", ".join(
            f"`{c.name}` {_um(c.heldout_rms)} (−{100 * (1 - c.heldout_rms / b_rms):.0f} %)"
            if c.heldout_rms <= b_rms else
            f"`{c.name}` {_um(c.heldout_rms)} (worse by {100 * (c.heldout_rms / b_rms - 1):.0f} %)"
            for c in d.singles) + f". Noise floor {_um(floor)}.")
    if d.chosen is not None:
        hb, hf = _heldout_full(d, base), _heldout_full(d, final)
        better_rows = int(np.sum(hf[rows] < hb[rows]))
        out["shrink"].append(
            f"With `{d.best}` the held-out error shrinks at {better_rows} of {nu} rows; the largest remaining "
            f"held-out error is {_um(float(np.nanmax(hf)))} ({names[int(np.nanargmax(hf))]}), it was "
            f"{_um(float(np.nanmax(hb)))} ({names[int(np.nanargmax(hb))]}).")

    # -- identifiability -------------------------------------------------
    if d.ties and d.singles:
        t0 = d.singles[0]
        sims = []
        for name in d.ties:
            c = next(c for c in d.singles if c.name == name)
            sims.append(f"`{name}` ({_um(c.heldout_rms)}, corrections cosine-similar {_similarity(d, t0, c):+.2f})")
        out["identifiability"].append(
            f"Ties: the held-out errors cannot tell `{t0.name}` ({_um(t0.heldout_rms)}) from " + ", ".join(sims)
            + ". A cosine similarity near ±1 means the two effects move the predictions alike over these rows: "
            "the data cannot separate them; measure rows where they differ.")
    else:
        out["identifiability"].append("No ties: the best candidate beats every other one on held-out rows "
                                      "beyond noise.")
    if d.correlated:
        out["identifiability"].append("Correlated parameters (|corr| > 0.95) of the final model: "
                                      + "; ".join(d.correlated) + ".")
    undetermined = [f"{e}: {lab}" for cand in ([d.chosen] if d.chosen else d.singles[:1])
                    for e, lab, txt, v, s in param_rows(d, cand) if "not determined" in txt]
    if undetermined:
        out["identifiability"].append("Not determined by these data (no effect on the measured quantity): "
                                      + ", ".join(undetermined) + ".")
    if prep.kind == "displacement":
        out["identifiability"].append(
            "The data are displacements: a translation of the instrument frame cancels, and a constant cable "
            "offset or tip offset shows only through its small change of the configuration.")

    # -- flagged rows ----------------------------------------------------
    if prep.flags:
        out["flagged"].append(f"{len(prep.flags)} of {len(prep.meas)} rows are flagged and left out of the fit "
                              "(not dropped silently):")
        out["flagged"].extend(f"{names[i]}: {why}" for i, why in sorted(prep.flags.items()))
    else:
        out["flagged"].append(f"All {len(prep.meas)} rows were usable.")
    return out


def summary(d: diagnose.Diagnosis) -> List[str]:
    """A few lines for the command line."""
    b, f = d.baseline.heldout_rms, d.final().heldout_rms
    lines = [f"best: {d.best}  (verdict: {d.verdict})",
             f"held-out RMS: nominal {b * 1e6:.1f} µm -> final {f * 1e6:.1f} µm "
             f"({100 * (1 - f / b):.0f} % smaller); noise floor {d.noise_floor * 1e6:.1f} µm "
             f"(noise {d.noise * 1e6:.3g} µm per axis, {d.noise_estimate.source})",
             f"rows: {int(d.prep.usable.sum())} of {len(d.prep.meas)} used ({d.prep.kind}), "
             f"{d.folds}-fold cross-validation"]
    if d.prep.flags:
        lines.append(f"flagged rows: {', '.join(str(i + 1) for i in sorted(d.prep.flags))} (see the report)")
    if d.ties:
        lines.append(f"ties with {d.singles[0].name}: {', '.join(d.ties)}")
    return lines


# ---------------------------------------------------------------------------
# figures
# ---------------------------------------------------------------------------
def _quiver_figure(d: diagnose.Diagnosis):
    fig = new_figure(11.0, 4.8)
    xy = _commanded_xy(d) * 1e3
    g_b, g_f = _gaps(d)
    names = _row_names(d)
    mag = np.linalg.norm(g_b, axis=1)
    gmax = float(np.nanmax(mag)) if np.isfinite(mag).any() else 1.0
    span = float(np.nanmax(np.ptp(xy[np.isfinite(xy).all(1)], axis=0))) if np.isfinite(xy).all(1).sum() > 1 else 1.0
    span = span if span > 0 else 1.0
    k = 0.15 * span / max(gmax, 1e-300)  # mm of plot per m of gap
    ref = 10 ** math.floor(math.log10(max(gmax, 1e-12)))
    axes = fig.subplots(1, 2)
    fin = xy[np.isfinite(xy).all(1)]
    lo, hi = (fin.min(0), fin.max(0)) if len(fin) else (np.zeros(2), np.ones(2))
    pad = 0.12 * span + 1e-3
    for ax, g, title in ((axes[0], g_b, "nominal model"), (axes[1], g_f, f"final model: {d.best}")):
        ok = np.isfinite(g).all(1)
        ax.scatter(xy[:, 0], xy[:, 1], s=12, c="#999999", zorder=1)
        q = ax.quiver(xy[ok, 0], xy[ok, 1], g[ok, 0] * k, g[ok, 1] * k, angles="xy", scale_units="xy", scale=1,
                      color=RED, width=0.006, zorder=3)
        bad = ~d.prep.usable & np.isfinite(xy).all(1)
        if bad.any():
            ax.scatter(xy[bad, 0], xy[bad, 1], marker="x", s=50, c="k", zorder=4, label="flagged row")
            ax.legend(loc="best")
        if len(xy) <= 30:
            for i in range(len(xy)):
                if np.isfinite(xy[i]).all():
                    ax.annotate(names[i].split(" ")[-1].strip("()") if "point" in names[i] else str(i + 1),
                                xy[i], fontsize=7, xytext=(3, 3), textcoords="offset points", color="#555555")
        ax.quiverkey(q, 0.08, 0.05, ref * k, f"{ref * 1e6:g} µm", labelpos="E", coordinates="axes")
        rms = float(np.sqrt(np.nanmean(np.sum(g[ok] ** 2, 1)))) if ok.any() else float("nan")
        ax.set_title(f"{title} (fit RMS {_um(rms)})", loc="left")
        ax.set_xlabel("commanded tip X (mm)")
        mid, half = (lo + hi) / 2, span / 2 + pad  # square window: arrows keep their direction
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_aspect("equal", adjustable="box")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("commanded tip Y (mm)")
    fig.tight_layout()
    return fig


def _bars_figure(d: diagnose.Diagnosis):
    N = len(d.prep.meas)
    fig = new_figure(max(7.0, min(16.0, 0.22 * N + 4)), 5.2)
    g_b, g_f = _gaps(d)
    axes = fig.subplots(2, 1, sharex=True)
    x = np.arange(N)
    for ax, j, lab, col in ((axes[0], 0, "dX", RED), (axes[1], 1, "dY", BLUE)):
        ax.axhspan(-d.noise * 1e6, d.noise * 1e6, color="#2ca02c", alpha=0.15, label="± noise (1 σ)")
        ax.bar(x - 0.2, g_b[:, j] * 1e6, 0.4, color=col, alpha=0.35, label="nominal model")
        ax.bar(x + 0.2, g_f[:, j] * 1e6, 0.4, color=col, label=f"final: {d.best}")
        for i in np.flatnonzero(~d.prep.usable):
            ax.axvline(i, color="k", ls=":", lw=1)
        ax.axhline(0, color="k", lw=0.6)
        ax.set_ylabel(f"gap {lab} (µm)")
        ax.grid(alpha=0.3, axis="y")
    axes[0].legend(loc="best", fontsize=8)
    axes[1].set_xlabel("row (dotted: flagged)")
    if N <= 40:
        axes[1].set_xticks(x)
        axes[1].set_xticklabels([str(i + 1) for i in x], fontsize=8)
    fig.tight_layout()
    return fig


def _candidates_figure(d: diagnose.Diagnosis):
    cands = list(d.singles) + [c for c in d.steps if len(c.effects) > 1]
    cands.sort(key=lambda c: c.heldout_rms)
    fig = new_figure(8.0, max(3.0, 0.35 * (len(cands) + 1) + 1.2))
    ax = fig.subplots()
    vals = [c.heldout_rms * 1e6 for c in cands] + [d.baseline.heldout_rms * 1e6]
    labels = [c.name for c in cands] + ["none (nominal)"]
    cols = [RED if c.name == d.best else BLUE for c in cands] + ["#888888"]
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
    ax.set_title(f"candidates ({d.folds}-fold cross-validation; red: chosen)", loc="left")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    return fig


def _features_figure(d: diagnose.Diagnosis, k: int = 4):
    g_b, g_f = _gaps(d)
    sb, sf = np.linalg.norm(g_b, axis=1), np.linalg.norm(g_f, axis=1)
    feats = [(n, r) for n, r in _ranked_features(d, sb) if np.isfinite(r)][:k]
    if not feats:
        return None
    fig = new_figure(4.0 * len(feats), 3.8)
    axes = np.atleast_1d(fig.subplots(1, len(feats), sharey=True))
    for ax, (name, rho) in zip(axes, feats):
        v = np.asarray(d.features[name], float)
        ax.scatter(v, sb * 1e6, facecolors="none", edgecolors=BLUE, label="nominal model")
        ax.scatter(v, sf * 1e6, c=RED, s=14, label=f"final: {d.best}")
        ax.axhline(d.noise_floor * 1e6, color=GREEN, ls="--", lw=1)
        ax.set_xlabel(name)
        ax.set_title(f"ρ = {rho:+.2f}", loc="left")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("|gap| (µm)")
    axes[0].legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


def figures(d: diagnose.Diagnosis, figdir: str) -> Dict[str, str]:
    """Write the figures as PNG into ``figdir``; returns {name: path}."""
    out = {}
    for name, make in (("residual_map", _quiver_figure), ("residual_bars", _bars_figure),
                       ("candidates", _candidates_figure), ("features", _features_figure)):
        fig = make(d)
        if fig is not None:
            out[name] = save(fig, os.path.join(figdir, f"{name}.png"))
    return out


_CAPTIONS = {
    "residual_map": "Gap (measured − model) as arrows at the commanded tip positions, nominal model (left) and "
                    "final model fitted on all usable rows (right), same arrow scale. Crosses: flagged rows.",
    "residual_bars": "Per-row gap in X and Y (µm): nominal model (light) and final model (dark); green band: "
                     "± measurement noise; dotted: flagged rows.",
    "candidates": "Held-out RMS position error of every candidate effect and of the chosen combination, with "
                  "the noise floor (green) and the nominal model (grey).",
    "features": "|gap| per row against the configuration features with the strongest rank correlation "
                "(ρ with the nominal model's |gap|).",
}


# ---------------------------------------------------------------------------
# the report
# ---------------------------------------------------------------------------
def _build(d: diagnose.Diagnosis, pngs: Dict[str, str]) -> Document:
    prep = d.prep
    f = findings(d)
    names = _row_names(d)
    doc = Document()
    doc.h(1, "Sim-to-real gap diagnosis")
    src = prep.meas.source or "measurements"
    doc.p(f"Data: `{src}` — {len(prep.meas)} rows of **{prep.kind}** measurements ({int(prep.usable.sum())} "
          f"usable); robot **{prep.robot.name}** ({prep.robot.n} joints); measurement noise assumed "
          f"{_um(d.noise)} per axis; {d.folds}-fold cross-validation; candidate library: "
          f"{', '.join(c.name for c in d.singles) or 'empty'}. cdsm {__version__}. The diagnosis was not told "
          "which effect is in the data.")
    doc.h(2, "Answer")
    for t in f["answer"]:
        doc.p(t)
    doc.h(2, "Where the gap lies")
    for t in f["where"]:
        doc.p(t)
    g_b, g_f = _gaps(d)
    hb, hf = _heldout_full(d, d.baseline), _heldout_full(d, d.final())
    xy = _commanded_xy(d)
    order = np.argsort(-np.nan_to_num(np.linalg.norm(g_b, axis=1), nan=np.inf))
    rows = []
    for i in order[:min(len(order), 12)]:
        rows.append([names[i], f"{xy[i, 0] * 1e3:.1f}, {xy[i, 1] * 1e3:.1f}",
                     f"{g_b[i, 0] * 1e6:+.1f}, {g_b[i, 1] * 1e6:+.1f}", f"{hb[i] * 1e6:.1f}",
                     f"{g_f[i, 0] * 1e6:+.1f}, {g_f[i, 1] * 1e6:+.1f}", f"{hf[i] * 1e6:.1f}",
                     prep.flags.get(int(i), "")])
    doc.table(["row", "commanded X, Y (mm)", "gap nominal dX, dY (µm)", "held-out |e| nominal (µm)",
               f"gap final ({d.best}) dX, dY (µm)", f"held-out |e| final ({d.best}) (µm)", "flag"], rows)
    doc.table(["feature", "Spearman ρ with |gap| (nominal)", "with |gap| (final)"],
              [[k, f"{rho:+.2f}" if np.isfinite(rho) else "constant",
                (lambda r: f"{r:+.2f}" if np.isfinite(r) else "constant")(
                    dict(_ranked_features(d, np.linalg.norm(g_f, axis=1))).get(k, float("nan")))]
               for k, rho in _ranked_features(d, np.linalg.norm(g_b, axis=1))])
    doc.h(2, "Which effect explains it")
    for t in f["which"]:
        doc.p(t)
    if d.chosen is not None:
        doc.table(["effect", "parameter", "value ± std"], [[e, lab, txt] for e, lab, txt, _, _ in
                                                           param_rows(d, d.chosen)])
    doc.h(2, "How far it shrinks")
    for t in f["shrink"]:
        doc.p(t)
    cands = list(d.singles) + [c for c in d.steps if len(c.effects) > 1]
    cands.sort(key=lambda c: c.heldout_rms)
    b = d.baseline
    doc.table(["candidate", "held-out RMS (µm)", "vs nominal", "× noise floor", "fit RMS (µm)", "ΔBIC",
               "parameters"],
              [["none (nominal)", f"{b.heldout_rms * 1e6:.1f}", "—", f"{b.heldout_rms / d.noise_floor:.2f}",
                f"{b.fit.rms * 1e6:.1f}", "0", "—"]] +
              [[("**" + c.name + "**") if c.name == d.best else c.name, f"{c.heldout_rms * 1e6:.1f}",
                f"{100 * (c.heldout_rms / b.heldout_rms - 1):+.0f} %", f"{c.heldout_rms / d.noise_floor:.2f}",
                f"{c.fit.rms * 1e6:.1f}", f"{c.fit.bic - b.fit.bic:+.1f}",
                "; ".join(f"{lab} {txt}" for _, lab, txt, _, _ in param_rows(d, c))] for c in cands])
    doc.h(2, "Identifiability")
    for t in f["identifiability"]:
        doc.p(t)
    doc.h(2, "Flagged rows")
    doc.ul(f["flagged"][1:]) if prep.flags else doc.p(f["flagged"][0])
    if prep.flags:
        doc.p(f["flagged"][0])
    doc.h(2, "Figures")
    for name in pngs:
        doc.fig(name, _CAPTIONS.get(name, name))
    doc.h(2, "Files")
    doc.ul(["`diagnosis.json` — the diagnosis (SI units; keys `best`, `baseline.heldout_rms_m`, `effects` best "
            "first with `name`, `params`, `heldout_rms_m`)",
            "`residuals.csv` — per row: commanded tip, gap of the nominal and final model, held-out errors, "
            "features, flag (SI units)",
            "`figures/*.png` — the figures of this report"])
    return doc


def _residual_rows(d: diagnose.Diagnosis) -> List[dict]:
    g_b, g_f = _gaps(d)
    hb, hf = _heldout_full(d, d.baseline), _heldout_full(d, d.final())
    xy = _commanded_xy(d)
    names = _row_names(d)
    out = []
    for i in range(len(d.prep.meas)):
        r = dict(row=i + 1, name=names[i], x_cmd_m=xy[i, 0], y_cmd_m=xy[i, 1],
                 gap_nominal_dx_m=g_b[i, 0], gap_nominal_dy_m=g_b[i, 1],
                 gap_final_dx_m=g_f[i, 0], gap_final_dy_m=g_f[i, 1],
                 heldout_nominal_m=hb[i], heldout_final_m=hf[i])
        for k, v in d.features.items():
            r[k] = float(v[i])
        r["flag"] = d.prep.flags.get(i, "")
        out.append(r)
    return out


def write(d: diagnose.Diagnosis, out: "str | os.PathLike[str]", suggestion=None) -> Dict[str, str]:
    """Write ``report.md``, ``report.html`` (self-contained), ``diagnosis.json``,
    ``residuals.csv``, ``figures/*.png`` and, given a ``suggestion``
    (:func:`cdsm.calibration.experiment.suggest`), ``suggested.csv`` into
    ``out`` (created). Returns {name: path} (``report_md``, ``report_html``,
    ``json``, ``csv``, ``figures``, ``suggested_csv``, ``manifest``: see
    :func:`cdsm.files.finish_run`)."""
    out = os.fspath(out)
    figdir = os.path.join(out, "figures")
    os.makedirs(figdir, exist_ok=True)
    begin_run(out, "cdsm diagnose")
    pngs = figures(d, figdir)
    doc = _build(d, pngs)
    paths = {"figures": figdir}
    paths["report_md"] = write_text(os.path.join(out, "report.md"), doc.markdown("figures"), "report")
    paths["report_html"] = write_text(os.path.join(out, "report.html"),
                                      doc.html(pngs, f"cdsm diagnose — {d.prep.meas.source or 'measurements'}"),
                                      "report")
    paths["json"] = write_json(os.path.join(out, "diagnosis.json"), d.to_json(), "diagnosis")
    paths["csv"] = write_csv(os.path.join(out, "residuals.csv"), _residual_rows(d), "residuals")
    if suggestion is not None:
        paths["suggested_csv"] = suggestion.to_csv(os.path.join(out, "suggested.csv"))
    paths["manifest"] = finish_run(out, "cdsm diagnose", [*pngs.values(), *(v for k, v in paths.items()
                                                                           if k != "figures")])
    return paths
