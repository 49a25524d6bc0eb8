"""Error rates of the sim-to-real diagnosis (``cdsm diagnose``) on virtual-prototype data.

Run: ``python benches/bench_error_rates.py [--datasets N] [--quick] [--out PATH]
[--noise-given FACTOR | --noise-assumed]``
(a benchmark, not a test: not run in CI). Prints a Markdown table and writes
it to ``--out`` (default ``benches/error_rates.md``).

What is measured
----------------
For every *case* below, ``N`` independent data sets (``--datasets``, default
30: about 8 min on 2 cores; ``--quick``: 3, about 1 min) of 60 and of 15 absolute rows are generated and diagnosed with
:func:`cdsm.calibration.diagnosis.diagnose` at its defaults (the whole
library, 10-fold cross-validation, the measuring frame registered) with the
true noise passed (``noise=10e-6``; ``--noise-given F`` passes F times the
truth instead, to measure the rules with the noise misstated;
``--noise-assumed`` passes none, so the diagnosis assumes its default
10 µm, the truth, and supports effects by the held-out signed-rank test).
Each data set is diagnosed twice: in
the robot's base frame and in a laser-tracker frame metres away (the same
readings rotated by 25-35° and translated by 1.3-1.5 m in a random
direction), so the two frames are a paired comparison.

Rows: random commands of the paper robot within ±30° per joint and ±1 mm of
upper-cable extra (``VirtualPrototype.random_commands``; an elastic arm's:
its tendons pulled or paid out by up to 1 mm from the rest angles), run in order,
Gaussian noise 10 µm per axis and reading (noise floor √2·σ = 14.1 µm).

Cases:

* **library effects**: each effect of ``plant.EFFECTS`` alone, and the
  mixtures hole_height+actuation_scale, backlash+cable_offset,
  link_length+tip_offset, hole_clearance+cable_elasticity. Magnitudes:
  ``plant.EXAMPLES_N3`` per effect, every value scaled by U(1, 2) and given a
  random sign per data set (non-negative parameters — cable_elasticity,
  hole_clearance, backlash — stay non-negative).
* **nominal**: no effect.
* **out of library** (``benches/out_of_library.py``): quadratic and cubic
  actuators, a periodic lead-screw error, a thermal drift of the cable
  lengths in time and a linear tracker drift in time. None can be
  represented by the library (friction in the holes left this set when
  ``cable_friction`` joined the library).

What counts as right
--------------------
* *right effect named*: ``best``, split at ``+``, equals the hidden effects as
  a set (order-insensitive); ``none`` for nominal data. In the tracker frame a
  leading ``frame_misalignment`` (the registered frame, named) is also
  accepted (``frame_misalignment+hole_height`` is right for hole_height; plain
  ``frame_misalignment`` is right for nominal data). Not defined for
  out-of-library data.
* *target verdict*: ``explained`` for library cases, ``no gap`` for nominal
  data. (A hidden ``frame_misalignment`` is absorbed by the default frame
  registration: it is named, but its verdict is ``no gap``; the table says
  so.) For out-of-library data the column is the rate of ``explained`` — a
  false claim that the library accounts for the gap; the goal is 0.

Every rate k/N is given with its Wilson score 95 % interval. A data set whose
diagnosis raises counts as neither right nor on target (column *errors*).
Also reported: the verdict counts (no gap / explained / partly explained /
unexplained), the most frequent ``best``, the median held-out RMS of the
nominal model (registered frame) and of the final model (µm; the effect is
"visible" when the first is well above the 14.1 µm floor), and the median
wall time of one diagnosis.

``--pairs``: every two-effect mixture of the kind's library as a cell (45
planar, 55 spatial, ``cable_friction`` included) instead of the four above;
``--robot two_universal`` (or any spatial robot file): the same cells on a
spatial arm (library effects at 1-2x their typical size; tracker frame
rotated 25-35° about a random axis, 1.3-1.5 m away; the out-of-library
effects act on the position-controlled cables and the tracker's three
axes). ``--robot ftdcr_v4`` (any elastic arm: OpenCR's FTDCR v4, 60 elastic joints
and 9 tendons): its own library (:func:`plant.effects_of`), every pair.
``--robot benches/two_universal_nylon.toml``: the
same arm strung with 0.3 mm nylon 6,6 (E A 177 N), where friction in the
holes moves the tip by more than the noise (with steel's 4.6 kN it moves it
by 2-6 µm at most: ``benches/identifiability.md``).

What the data cannot show is not asked for, and the report says so:

* a mixture the data cannot tell from one of its effects alone
  (``UNRESOLVABLE``, each with its measured reason; on ``two_universal``
  the hole positions contain an actuation scale and cable offsets) counts
  as right when the diagnosis names that effect (``ABSORBED_BY``) or its
  search lists the true pair among its ties;
* per data set, a hidden effect with at least as many parameters as the
  rows have position components (``hole_position``'s 48 against 15 rows'
  45), or whose signal — the sum over the rows of |position with it −
  without it|² / noise², every other hidden effect kept — is below the
  1-dof chi-square quantile at the selection's first step (friction with
  a steel cable) counts as right when the other true effects are named.

Everything is seeded (``--seed``, default 20240601): the hidden parameters,
commands, noise and tracker frame of data set i of a case come from
``SeedSequence([seed, crc32(case), rows, i])``, so results do not depend on
``--jobs`` or on the order the work runs in. Work is spread over ``--jobs``
processes (default 2) with ``robot.threads = --threads`` (default 1) each.
"""

from __future__ import annotations

import argparse
import collections
import itertools
import math
import multiprocessing as mp
import os
import subprocess
import sys
import time
import zlib
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import out_of_library as ool  # noqa: E402  (benches/ is not a package)

from cdsm import Robot  # noqa: E402
from cdsm.calibration import diagnosis, measurements, plant, stats  # noqa: E402

NOISE = 10e-6
ROWS = (60, 15)
FRAMES = ("base", "tracker")
SEED = 20240601
MIXTURES = (("hole_height", "actuation_scale"), ("backlash", "cable_offset"),
            ("link_length", "tip_offset"), ("hole_clearance", "cable_elasticity"))
#: Two-effect mixtures the data cannot tell from one of their effects alone,
#: and why (measured by ``benches/identifiability.py``, whose report
#: ``benches/identifiability.md`` gives the numbers): the right answer there
#: is the effect that explains the mixture alone (:data:`ABSORBED_BY`), or a
#: tie of the search that contains the true pair.
UNRESOLVABLE: Dict[frozenset, str] = {
    frozenset({"actuation_scale", "hole_position"}): (
        "`actuation_scale` lies in the column space of `hole_position`: every hole moved radially scales "
        "every moment arm as a scale of the commands does; of the scale's change (600 σ over 60 rows, median) "
        "less than 0.05 σ is left beside `hole_position` (relative residual 4e-14, linearised; σ = 10 µm)"),
    frozenset({"cable_offset", "hole_position"}): (
        "`cable_offset` lies in the column space of `hole_position`: the hole a cable is anchored in, moved "
        "along its disk, lengthens the cable by a constant; of the offsets' change (510 σ over 60 rows, "
        "median) less than 0.05 σ is left beside `hole_position` (relative residual 1e-15, linearised)"),
}
#: The effect of an :data:`UNRESOLVABLE` mixture that explains it alone.
ABSORBED_BY: Dict[frozenset, str] = {frozenset({"actuation_scale", "hole_position"}): "hole_position",
                                     frozenset({"cable_offset", "hole_position"}): "hole_position"}
VERDICTS = ("no gap", "explained", "partly explained", "unexplained")
Z95 = 1.959963984540054


@dataclass(frozen=True)
class Case:
    """One kind of data: ``kind`` "library", "nominal" or "ool"; ``truth``
    the hidden library effects (empty for nominal / out-of-library)."""

    name: str
    kind: str
    truth: Tuple[str, ...] = ()

    @property
    def target(self) -> str:
        return "no gap" if self.kind == "nominal" else "explained"


def cases(robot: Robot, pairs: bool = False) -> List[Case]:
    """The cells for ``robot``: its diagnosis library (:func:`plant.effects_of`:
    the kind's, an elastic arm's own) each alone, mixtures (every pair with
    ``pairs`` or beyond the paper's planar library, else :data:`MIXTURES`),
    nominal data and the out-of-library effects."""
    library = plant.effects_of(robot)
    out = [] if pairs else [Case(e, "library", (e,)) for e in library]
    mixtures = list(itertools.combinations(library, 2)) if pairs or library != plant.EFFECTS else MIXTURES
    out += [Case("+".join(m), "library", tuple(m)) for m in mixtures]
    out.append(Case("nominal (no effect)", "nominal"))
    out += [Case(name, "ool") for name in ool.EFFECTS]
    return out


# ---------------------------------------------------------------------------
# data
# ---------------------------------------------------------------------------
def library_effects(robot: Robot, truth: Sequence[str], rng: np.random.Generator) -> Dict[str, np.ndarray]:
    """Hidden parameters: EXAMPLES_N3 magnitudes x U(1, 2), random signs
    (non-negative blocks stay non-negative)."""
    lower, _ = plant.bounds(robot)
    lay = plant.layout(robot)
    hidden = {}
    for e in truth:
        if robot.kind == "planar" and robot.n == 3 and e in plant.EXAMPLES_N3:
            v = np.asarray(plant.EXAMPLES_N3[e][e], float)
        else:  # 1-2x the typical size of every parameter of the effect's block
            v = np.full(lay[e].stop - lay[e].start, plant.TYPICAL[e])
        nonneg = bool(np.all(lower[lay[e]][: v.size] >= 0.0))
        sign = np.ones(v.size) if nonneg else rng.choice([-1.0, 1.0], v.size)
        hidden[e] = np.abs(v) * rng.uniform(1.0, 2.0, v.size) * sign
    return hidden


def tracker_frame(rng: np.random.Generator) -> Tuple[float, float, float]:
    """A laser-tracker frame: rotation 25-35°, translation 1.3-1.5 m in a random direction."""
    alpha = np.radians(rng.uniform(25.0, 35.0)) * rng.choice([-1.0, 1.0])
    dist, direction = rng.uniform(1.3, 1.5), rng.uniform(0.0, 2.0 * np.pi)
    return float(alpha), float(dist * np.cos(direction)), float(dist * np.sin(direction))


def tracker_frame_3d(rng: np.random.Generator) -> Tuple[np.ndarray, np.ndarray]:
    """A tracker frame in 3-D: rotation 25-35° about a random axis, translation
    1.3-1.5 m in a random direction; (R (3, 3), t (3,))."""
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = np.radians(rng.uniform(25.0, 35.0))
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rot = np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k
    t = rng.normal(size=3)
    return rot, t / np.linalg.norm(t) * rng.uniform(1.3, 1.5)


def datasets(robot: Robot, case: Case, rows: int, i: int, seed: int):
    """The base-frame and tracker-frame Measurements of data set ``i`` (same
    readings, the tracker's rotated and translated), how many generation
    attempts failed to settle (regenerated with the next seed), and the
    hidden library effects ({effect: values}, SI; empty for nominal and
    out-of-library data)."""
    retries = 0
    while True:
        ss = np.random.SeedSequence([seed, zlib.crc32(case.name.encode()), rows, i, retries])
        r_par, r_cmd, r_noise, r_frame = (np.random.default_rng(s) for s in ss.spawn(4))
        frame = tracker_frame(r_frame)
        cmd_seed, noise_seed = int(r_cmd.integers(2 ** 31)), int(r_noise.integers(2 ** 31))
        hidden: Dict[str, np.ndarray] = {}
        try:
            if case.kind == "ool":
                effect = ool.EFFECTS[case.name].sample(r_par, robot)
                th, dl = plant.VirtualPrototype(robot, {}).random_commands(rows, seed=cmd_seed)
                if robot.kind == "spatial":
                    frame = tracker_frame_3d(r_frame)
                base = ool.measure(robot, effect, th, dl, NOISE, noise_seed)
                tracker = ool.measure(robot, effect, th, dl, NOISE, noise_seed, frame=frame)
            else:
                hidden = library_effects(robot, case.truth, r_par)
                vp = plant.VirtualPrototype(robot, hidden, noise=NOISE, seed=noise_seed)
                th, dl = vp.random_commands(rows, seed=cmd_seed)
                base = vp.measure(th, dl)
                if robot.kind == "spatial":
                    rot, t = tracker_frame_3d(r_frame)
                    seen = base.measured @ rot.T + t
                else:
                    seen = ool.to_frame(base.measured, frame)
                tracker = measurements.Measurements(base.reading, base.n, base.dL, seen,
                                                    theta=base.theta, source=base.source + " (tracker frame)")
            return base, tracker, retries, hidden
        except Exception as exc:  # a command that does not settle: regenerate, counted
            if "settle" not in str(exc) or retries >= 10:
                raise
            retries += 1


# ---------------------------------------------------------------------------
# scoring
# ---------------------------------------------------------------------------
def named_right(best: str, truth: Sequence[str], frame: str) -> bool:
    names = [] if best == "none" else best.split("+")
    if sorted(names) == sorted(truth):
        return True
    # a hidden frame error merges with the tracker's frame: named once, first
    rest = [e for e in truth if e != "frame_misalignment"]
    return frame == "tracker" and names[:1] == ["frame_misalignment"] and sorted(names[1:]) == sorted(rest)


def detection_level(robot: Robot) -> float:
    """The signal an effect needs to be seen at all: the 1-dof chi-square
    quantile at the selection's first-step level (``diagnosis.ALPHA`` over
    the library's size), in units of sum((change / noise)^2)."""
    return stats.chi2_ppf(1.0 - diagnosis.ALPHA / len(plant.effects_of(robot)), 1)


def signals(robot: Robot, hidden: Dict[str, np.ndarray], meas: measurements.Measurements) -> Dict[str, float]:
    """Each hidden effect's signal in a data set: the sum over its rows of
    |position with every hidden effect - position without this one|^2 over
    the noise^2 (the noncentrality a test of the effect has at best)."""
    k = plant.dims(robot)
    full, _ = plant.predict(robot, plant.params(robot, hidden), meas.theta, meas.dL)
    out = {}
    for e in hidden:
        rest, _ = plant.predict(robot, plant.params(robot, {x: v for x, v in hidden.items() if x != e}),
                                meas.theta, meas.dL)
        out[e] = float(np.nansum((full[:, :k] - rest[:, :k]) ** 2) / NOISE ** 2)
    return out


def unseen(robot: Robot, hidden: Dict[str, np.ndarray], meas: measurements.Measurements) -> Dict[str, str]:
    """The hidden effects these data cannot show, each with the measured
    reason: more parameters than the rows have position components, or a
    signal below :func:`detection_level`."""
    rows = len(meas) * plant.dims(robot)
    level = detection_level(robot)
    out = {}
    for e, lam in signals(robot, hidden, meas).items():
        p = len(plant.effect_indices(robot, e))
        if p >= rows:
            out[e] = f"{p} parameters, {rows} position components"
        elif lam < level:
            out[e] = f"signal sum((change/noise)^2) = {lam:.2g} < {level:.1f}"
    return out


def named_within(best: str, truth: Sequence[str], frame: str, hidden_from: Sequence[str]) -> bool:
    """Whether ``best`` names what the data can show of ``truth``: the
    true effects less those the data cannot show (``hidden_from``), at
    least one of them named."""
    seen = [e for e in truth if e not in hidden_from]
    return bool(hidden_from) and bool(seen) and named_right(best, seen, frame)


def tied_right(ties: Sequence[str], truth: Sequence[str]) -> bool:
    """Whether the true mixture is among the search's ties (any order)."""
    return any(sorted(t.split("+")) == sorted(truth) for t in ties)


def wilson(k: int, n: int, z: float = Z95) -> Tuple[float, float]:
    """Wilson score interval of a binomial proportion k/n."""
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


def rate(k: int, n: int) -> str:
    if n == 0:
        return "—"
    lo, hi = wilson(k, n)
    return f"{k}/{n} = {100 * k / n:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}]"


# ---------------------------------------------------------------------------
# workers
# ---------------------------------------------------------------------------
_ROBOT: Optional[Robot] = None
_CASES: List[Case] = []


def _init(threads: int, robot: str, pairs: bool) -> None:
    global _ROBOT, _CASES
    _ROBOT = load_robot(robot)
    _ROBOT.threads = threads
    _CASES = cases(_ROBOT, pairs)


def given_noise(factor: Optional[float]) -> Optional[float]:
    """The noise passed to ``diagnose`` (m): ``factor`` times the truth,
    None (the diagnosis' assumed default) without a factor."""
    return None if factor is None else factor * NOISE


def _task(args) -> List[dict]:
    ci, rows, i, seed, factor = args
    case = _CASES[ci]
    robot = _ROBOT
    base, tracker, retries, hidden = datasets(robot, case, rows, i, seed)
    missing = unseen(robot, hidden, base) if hidden else {}
    absorber = ABSORBED_BY.get(frozenset(case.truth))
    out = []
    for frame, meas in zip(FRAMES, (base, tracker)):
        rec = dict(case=ci, rows=rows, frame=frame, i=i, retries=retries, error=None, unseen=missing,
                   within=False)
        t0 = time.perf_counter()
        try:
            d = diagnosis.diagnose(robot, meas, noise=given_noise(factor))
        except Exception as exc:  # reported, counted as wrong
            rec.update(time=time.perf_counter() - t0, error=f"{type(exc).__name__}: {exc}", best="(error)",
                       verdict="(error)", right=False, tied=False, searched=False, usable=0, nominal_rms=np.nan,
                       final_rms=np.nan)
            out.append(rec)
            continue
        right = named_right(d.best, case.truth, frame)
        tied = (not right and frozenset(case.truth) in UNRESOLVABLE and d.search is not None
                and tied_right(d.search.ties, case.truth))
        # what the data can show: the effect that absorbs an unresolvable
        # mixture, or the true effects less those the data cannot show
        within = not (right or tied) and (
            (absorber is not None and named_right(d.best, [absorber], frame))
            or named_within(d.best, case.truth, frame, list(missing)))
        rec.update(time=time.perf_counter() - t0, best=d.best, verdict=d.verdict, right=right or tied or within,
                   tied=tied, within=within,
                   searched=d.search is not None, usable=int(d.prep.usable.sum()),
                   nominal_rms=d.baseline.heldout_rms, final_rms=d.final().heldout_rms)
        out.append(rec)
    return out


# ---------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------
def _cell_rows(recs: List[dict], case: Case) -> List[str]:
    n = len(recs)
    ok = [r for r in recs if r["error"] is None]
    right = sum(r["right"] for r in recs)
    hit = sum(r["verdict"] == case.target for r in recs)
    counts = collections.Counter(r["verdict"] for r in ok)
    verdicts = " / ".join(str(counts.get(v, 0)) for v in VERDICTS)
    best, kbest = collections.Counter(r["best"] for r in recs).most_common(1)[0]
    med = lambda key: float(np.nanmedian([r[key] for r in ok])) * 1e6 if ok else float("nan")  # noqa: E731
    t = float(np.median([r["time"] for r in recs]))
    errors = n - len(ok)
    flagged = sum(r["rows"] - r["usable"] for r in ok)
    tied = sum(r["tied"] for r in recs)
    within = sum(r["within"] for r in recs)
    searched = sum(r["searched"] for r in recs)
    how = [f"{tied} by a tie"] * bool(tied) + [f"{within} by what the data show"] * bool(within)
    return [(rate(right, n) + (f" ({'; '.join(how)})" if how else "")) if case.kind != "ool" else "n/a",
            rate(hit, n), verdicts, f"`{best}` ({kbest})",
            f"{med('nominal_rms'):.0f} → {med('final_rms'):.0f}", str(searched), f"{t:.2f}",
            str(errors) + (f" ({flagged} rows flagged)" if flagged else "")]


def _limits(records: List[dict], all_cases: List[Case], args) -> List[str]:
    """The Markdown on what the data cannot show: the unresolvable mixtures
    measured, with their reasons, and the hidden effects the data sets
    could not show, counted per effect and row count with a reason."""
    out = []
    run = {frozenset(all_cases[r["case"]].truth) for r in records}
    listed = [(m, why) for m, why in UNRESOLVABLE.items() if m in run]
    if listed:
        out += ["### Mixtures the data cannot resolve (`UNRESOLVABLE`)", "",
                "Counted right when the diagnosis names the effect that explains the mixture alone, or when "
                "the search's ties contain the true pair.", ""]
        out += [f"- `{'+'.join(sorted(m))}` (explained alone by `{ABSORBED_BY[m]}`): {why}." for m, why in listed]
        out.append("")
    miss: Dict[Tuple[str, int], List[str]] = collections.defaultdict(list)
    total: Dict[Tuple[str, int], int] = collections.Counter()
    for r in records:
        if r["frame"] != "base":
            continue
        for e in all_cases[r["case"]].truth:
            total[(e, r["rows"])] += 1
        for e, why in r["unseen"].items():
            miss[(e, r["rows"])].append(why)
    if miss:
        out += ["### Hidden effects the data cannot show", "",
                "Per data set, a hidden effect with at least as many parameters as the rows have position "
                "components, or whose signal (the sum over the rows of |position with it − without it|² / "
                f"noise², every other hidden effect kept) is below {detection_level(load_robot(args.robot)):.1f} "
                "(the 1-dof chi-square quantile at the selection's first-step level), is not asked for: the "
                "diagnosis is right there when it names the other true effects.", "",
                "| effect | rows | data sets | reason (first) |", "|---|---:|---|---|"]
        for (e, ro), whys in sorted(miss.items(), key=lambda t: (t[0][0], -t[0][1])):
            out.append(f"| {e} | {ro} | {len(whys)} of {total[(e, ro)]} | {whys[0]} |")
        out.append("")
    return out


def load_robot(name: str) -> Robot:
    """The paper robot, a packaged robot's name (OpenCR's ``ftdcr_v4``
    included) or a robot file (TOML or an OpenCR config): :meth:`Robot.load`."""
    return Robot.load(name)


def report(records: List[dict], args, elapsed: float, robot: Robot) -> str:
    all_cases = cases(robot, args.pairs)
    by = collections.defaultdict(list)
    for r in records:
        by[(r["case"], r["rows"], r["frame"])].append(r)
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=os.path.dirname(os.path.abspath(__file__))).stdout.strip() or "?"
    except OSError:
        commit = "?"
    opts = f"--datasets {args.datasets}" + (" --quick" if args.quick else "")
    opts += "" if args.seed == SEED else f" --seed {args.seed}"
    opts += "" if tuple(args.rows) == ROWS else f" --rows {','.join(map(str, args.rows))}"
    opts += "" if args.only is None else f" --only {args.only}"
    opts += " --pairs" if args.pairs else ""
    opts += " --singles" if args.singles else ""
    opts += " --noise-assumed" if args.noise_assumed else ("" if args.noise_given == 1.0
                                                           else f" --noise-given {args.noise_given:g}")
    opts += "" if args.robot == "paper" else f" --robot {args.robot}"
    lines = [
        "## Error rates of the diagnosis" + (" (quick smoke run — not for the README)" if args.quick else ""),
        "",
        f"`python benches/bench_error_rates.py {opts}` "
        f"(commit {commit}, seed {args.seed}): {args.datasets} data sets per cell; rows "
        + ("the tendons' pulls ±1 mm from the rest angles" if robot.is_elastic else
           "±30° per joint, ±1 mm cable extra") + f"; noise {NOISE * 1e6:.0f} µm per axis ("
        + ("not passed to `diagnose`: it assumes its default "
           f"{diagnosis.DEFAULT_NOISE * 1e6:.0f} µm" if args.noise_assumed else
           f"passed to `diagnose` as {args.noise_given * NOISE * 1e6:g} µm"
           + (f", {args.noise_given:g} × the truth" if args.noise_given != 1.0 else ""))
        + f"; floor {math.sqrt(plant.dims(robot)) * NOISE * 1e6:.1f} µm); robot `{args.robot}`; whole "
        "library, 10-fold CV, frame rule `auto` (the default: base-frame data are taken in the base frame with "
        "the frame a candidate, tracker data registered). "
        "Tracker frame: the same readings rotated 25-35° and moved 1.3-1.5 m. Rates: k/N = % "
        "[Wilson 95 % interval]. Verdicts: no gap / explained / partly explained / unexplained. "
        "RMS: median held-out RMS of the nominal → the final model (µm). Search: data sets where the search "
        "beyond forward selection ran. Time: median s per diagnosis "
        f"({args.jobs} process(es), robot.threads = {args.threads}). Errors: diagnoses that raised; rows "
        "flagged: rows the diagnosis left out (e.g. a slack cable), summed over the data sets. "
        f"Total {elapsed / 60:.1f} min.",
        "",
    ]
    head = ("| case | rows | frame | right effect named | {target} | verdicts NG / E / P / U | most frequent `best` | "
            "RMS (µm) | search | time (s) | errors |")
    sep = "|---|---:|---|---|---|---|---|---|---:|---:|---|"
    sections = (("library", "Library effects (goal: right effect named, verdict explained)", "explained"),
                ("nominal", "Nominal data (goal: best none, verdict no gap)", "no gap"),
                ("ool", "Effects outside the library (goal: never explained)", "explained (goal 0)"))
    pooled = []
    for group, title, target in sections:
        if not any(all_cases[ci].kind == group for ci, _, _ in by):
            continue
        lines += [f"### {title}", "", head.format(target=target), sep]
        for ci, case in enumerate(all_cases):
            if case.kind != group:
                continue
            for rows in args.rows:
                for frame in FRAMES:
                    recs = by.get((ci, rows, frame), [])
                    if not recs:
                        continue
                    lines.append(f"| {case.name} | {rows} | {frame} | " + " | ".join(_cell_rows(recs, case)) + " |")
        if group == "library" and any(all_cases[ci].name == "frame_misalignment" for ci, _, _ in by):
            lines += ["", "In a tracker frame (registered), a hidden `frame_misalignment` is absorbed by the "
                      "registration: the diagnosis names it but, no effect being chosen, its verdict is "
                      "`no gap`, never `explained`."]
        lines.append("")
        for rows in args.rows:
            for frame in FRAMES:
                recs = [r for (ci, ro, fr), v in by.items() if all_cases[ci].kind == group and ro == rows
                        and fr == frame for r in v]
                if not recs:
                    continue
                hit = sum(r["verdict"] == all_cases[r["case"]].target for r in recs)
                right = sum(r["right"] for r in recs)
                what = "explained" if group == "ool" else f"right effect {rate(right, len(recs))}; {target}"
                pooled.append(f"| {group} | {rows} | {frame} | {what} {rate(hit, len(recs))} |")
    lines += ["### Pooled over cases", "", "| cases | rows | frame | rates |", "|---|---:|---|---|", *pooled, ""]
    lines += _limits(records, all_cases, args)
    retried = collections.Counter()
    for r in records:
        if r["frame"] == "base" and r["retries"]:
            retried[f"{all_cases[r['case']].name} ({r['rows']} rows)"] += r["retries"]
    errs = [r for r in records if r["error"]]
    if retried:
        lines.append("Generated data sets with a command the prototype could not settle, regenerated with the "
                     "next seed: " + ", ".join(f"{k}: {v}" for k, v in sorted(retried.items())) + ".")
    for r in errs[:10]:
        lines.append(f"- error: {all_cases[r['case']].name}, {r['rows']} rows, {r['frame']}, data set {r['i']}: "
                     f"{r['error']}")
    return "\n".join(lines).rstrip() + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--datasets", type=int, default=None, help="data sets per case, row count and frame "
                    "(default 30, ~8 min on 2 cores; --quick: 3)")
    ap.add_argument("--quick", action="store_true", help="smoke run (~1 min): 3 data sets per cell")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "error_rates.md"),
                    help="Markdown output (default benches/error_rates.md)")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--threads", type=int, default=1, help="robot.threads in each worker (default 1)")
    ap.add_argument("--seed", type=int, default=SEED)
    ap.add_argument("--rows", default=",".join(map(str, ROWS)), help="row counts (default 60,15)")
    ap.add_argument("--only", default=None, help="only cases whose name contains this text (a comma-separated "
                    "list: any of them)")
    ap.add_argument("--pairs", action="store_true", help="every two-effect mixture of the library as a cell")
    ap.add_argument("--singles", action="store_true",
                    help="only the cells of one library effect, nominal data and the out-of-library effects (no "
                         "mixtures: a first look at a robot whose diagnosis is slow, e.g. an elastic arm)")
    ap.add_argument("--robot", default="paper", help="'paper' (default), a packaged robot name or a robot file")
    noise = ap.add_mutually_exclusive_group()
    noise.add_argument("--noise-given", type=float, default=1.0, metavar="FACTOR",
                       help="pass FACTOR times the true noise to the diagnosis (default 1: the truth; 0.5 and 2 "
                            "measure the rules with the noise misstated)")
    noise.add_argument("--noise-assumed", action="store_true",
                       help="pass no noise: the diagnosis assumes its default (10 µm, the truth) and supports "
                            "effects by the held-out signed-rank test")
    args = ap.parse_args()
    if not (args.noise_given > 0 and math.isfinite(args.noise_given)):
        ap.error("--noise-given must be a positive number")
    if args.datasets is None:
        args.datasets = 3 if args.quick else 30
    if args.datasets < 1 or args.jobs < 1:
        ap.error("--datasets and --jobs must be positive")
    args.rows = [int(r) for r in args.rows.split(",") if r.strip()]
    robot = load_robot(args.robot)
    all_cases = cases(robot, args.pairs)
    wanted = None if args.only is None else [w.strip() for w in args.only.split(",") if w.strip()]
    chosen = [ci for ci, c in enumerate(all_cases) if (wanted is None or any(w in c.name for w in wanted))
              and not (args.singles and len(c.truth) > 1)]
    # the longest work first (60 rows, library mixtures), for load balance
    factor = None if args.noise_assumed else args.noise_given
    tasks = [(ci, rows, i, args.seed, factor) for rows in sorted(args.rows, reverse=True) for ci in chosen
             for i in range(args.datasets)]
    print(f"{len(tasks) * len(FRAMES)} diagnoses ({len(chosen)} cases x {args.rows} rows x {len(FRAMES)} frames x "
          f"{args.datasets} data sets) on {args.jobs} process(es), cores visible: {os.cpu_count()}",
          file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    records: List[dict] = []
    if args.jobs == 1:
        _init(args.threads, args.robot, args.pairs)
        results = map(_task, tasks)
        pool = None
    else:
        pool = mp.get_context("spawn").Pool(args.jobs, initializer=_init,
                                            initargs=(args.threads, args.robot, args.pairs))
        results = pool.imap_unordered(_task, tasks, chunksize=1)
    step = max(1, len(tasks) // 20)
    for k, res in enumerate(results, 1):
        records.extend(res)
        if k % step == 0 or k == len(tasks):
            el = time.perf_counter() - t0
            print(f"  {k}/{len(tasks)} data sets, {el:.0f} s, ~{el / k * (len(tasks) - k):.0f} s left",
                  file=sys.stderr, flush=True)
    if pool is not None:
        pool.close()
        pool.join()
    records.sort(key=lambda r: (r["case"], -r["rows"], r["frame"], r["i"]))
    text = report(records, args, time.perf_counter() - t0, robot)
    print(text)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)) or ".", exist_ok=True)
    with open(args.out, "w", encoding="utf-8") as fh:
        fh.write(text)
    print(f"written: {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
