"""Command line of cdsm: ``cdsm <command> [options]``.

Subcommands live in a registry (:data:`COMMANDS`): each is one function that
adds its options and one that runs it. To add one (diagnose, tolerance,
montecarlo, ...)::

    def _name_args(p: argparse.ArgumentParser) -> None:   # add options
        p.add_argument(...)

    @subcommand("name", help="one line")
    @options(_name_args)
    def _name_run(args) -> int:                            # exit status
        ...

User errors (bad options, bad robot or data files: :class:`CdsmInputError`)
exit with status 2 and one line ``cdsm: error: ...`` on stderr, no traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Callable, Dict, List, Optional

__all__ = ["main", "subcommand", "COMMANDS"]

PROG = "cdsm"


class _Command:
    def __init__(self, name: str, help: str, add_args: Callable, run: Callable):
        self.name, self.help, self.add_args, self.run = name, help, add_args, run


#: name -> command; filled by :func:`subcommand`.
COMMANDS: Dict[str, _Command] = {}


def subcommand(name: str, help: str):
    """Register a subcommand: decorates ``run(args) -> int``; the options are
    added by ``run.add_args(parser)`` (set with :func:`options`)."""
    def deco(run: Callable) -> Callable:
        COMMANDS[name] = _Command(name, help, getattr(run, "add_args", lambda p: None), run)
        return run
    return deco


def options(add_args: Callable):
    """Attach the option builder ``add_args(parser)`` to a run function
    (use below :func:`subcommand`)."""
    def deco(run: Callable) -> Callable:
        run.add_args = add_args
        return run
    return deco


class UserError(Exception):
    """A user mistake reported as ``cdsm: error: <message>`` with exit status 2."""


# ---------------------------------------------------------------------------
# option types
# ---------------------------------------------------------------------------
def _int_at_least(text: str, lo: int, what: str) -> int:
    try:
        v = int(text)
    except ValueError:
        v = lo - 1
    if v < lo:
        raise argparse.ArgumentTypeError(f"expected a {what} integer, got {text!r}")
    return v


def _positive_int(text: str) -> int:
    return _int_at_least(text, 1, "positive")


def _seed(text: str) -> int:
    return _int_at_least(text, 0, "non-negative")


def load_robot(path: Optional[str]):
    """The robot of ``--robot`` (TOML file), or the paper's prototype."""
    from .robot import CdsmInputError, Robot

    if path is None:
        return Robot.paper()
    if os.path.isdir(path):
        raise UserError(f"robot file {path!r}: is a directory")
    try:
        return Robot.from_toml(path)
    except CdsmInputError as exc:
        msg = str(exc)
        if path in msg:
            raise
        raise UserError(f"robot file {path!r}: {msg}") from None


def _prepare_out(path: str) -> str:
    out = os.path.abspath(path)
    if os.path.exists(out) and not os.path.isdir(out):
        raise UserError(f"--out {path!r}: exists and is not a directory")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out {path!r}: cannot create the directory ({exc.strerror})") from None
    if not os.access(out, os.W_OK):
        raise UserError(f"--out {path!r}: directory is not writable")
    return out


# ---------------------------------------------------------------------------
# cdsm paper
# ---------------------------------------------------------------------------
def _paper_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", metavar="R.toml", help="robot description (TOML, SI units); "
                   "default: the paper's 3-joint prototype")
    p.add_argument("--out", metavar="DIR", default="cdsm-paper",
                   help="output directory (default: ./cdsm-paper)")
    p.add_argument("--samples", metavar="N", type=_positive_int, default=1000,
                   help="Monte-Carlo samples (default: 1000, as the paper)")
    p.add_argument("--seed", metavar="S", type=_seed, default=0, help="Monte-Carlo seed (default: 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


@subcommand("paper", help="reproduce the seed paper's accuracy study: figures, CSV tables and a report")
@options(_paper_args)
def _paper_run(args) -> int:
    from . import paper, report

    t0 = time.perf_counter()
    robot = load_robot(args.robot)
    out = _prepare_out(args.out)
    show = not args.quiet

    def say(msg: str) -> None:
        if show:
            print(msg, file=sys.stderr, flush=True)

    say(f"cdsm paper: robot {robot.name!r} ({robot.n} joints), {args.samples} Monte-Carlo samples, "
        f"seed {args.seed} -> {out}")
    study = paper.run(robot, samples=args.samples, seed=args.seed, progress=show)
    paths = report.write(study, out, progress=show)
    h = report.headline(study)
    print(f"report: {paths['report_html']}")
    print(f"        {paths['report_md']}")
    for p in study.workspaces:
        line = (f"{p}: worst single-error |dXY| {h[f'worst_single_dxy_m_{p}'] * 1e3:.2f} mm, "
                f"jump points {h[f'jump_points_{p}']}, unreachable {h[f'unreachable_{p}']}")
        if f"mc_max_dxy_m_{p}" in h:
            line += (f", Monte Carlo max |dXY| {h[f'mc_max_dxy_m_{p}'] * 1e3:.2f} mm "
                     f"(95th pct up to {h[f'mc_max_p95_dxy_m_{p}'] * 1e3:.2f} mm)")
        print(line)
    if "table3_max_ours_minus_paper_m" in h:
        print(f"Table 3: max |ours - paper| {h['table3_max_ours_minus_paper_m'] * 1e3:.1e} mm, "
              f"RMS measured - ours {h['table3_rms_measured_minus_ours_m'] * 1e3:.3f} mm")
    print(f"claims holding: {h['claims_holding']} of {h['claims_total']}; "
          f"done in {time.perf_counter() - t0:.1f} s")
    return 0


# ---------------------------------------------------------------------------
# cdsm diagnose
# ---------------------------------------------------------------------------
def _noise_m(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a noise level in m, got {text!r}") from None
    if not (v > 0 and v < 1e-2):  # also rejects nan and inf
        raise argparse.ArgumentTypeError(f"expected a positive noise level in m below 0.01 m (SI units: "
                                         f"10 µm is 1e-5), got {text!r}")
    return v


def _folds(text: str) -> int:
    v = _positive_int(text)
    if v < 2:
        raise argparse.ArgumentTypeError(f"expected at least 2 folds, got {text!r}")
    return v


def _effect_list(text: str) -> List[str]:
    from .plant import EFFECTS

    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of effects, got {text!r}")
    bad = [t for t in names if t not in EFFECTS]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown effect(s) {', '.join(map(repr, bad))}; "
                                         f"known: {', '.join(EFFECTS)}")
    dup = sorted({t for t in names if names.count(t) > 1})
    if dup:
        raise argparse.ArgumentTypeError(f"effect(s) listed twice: {', '.join(dup)}")
    return names


def _diagnose_args(p: argparse.ArgumentParser) -> None:
    from .diagnose import DEFAULT_NOISE

    p.add_argument("data", metavar="DATA.csv", help="measurement table (CSV, SI units; see cdsm.measurements)")
    p.add_argument("--robot", metavar="R.toml", help="robot description (TOML, SI units); "
                   "default: the paper's 3-joint prototype")
    p.add_argument("--effects", metavar="a,b,...", type=_effect_list, default=None,
                   help="candidate effects (comma list; default: the whole library)")
    p.add_argument("--json", metavar="OUT", help="write the diagnosis as JSON (SI units)")
    p.add_argument("--report", metavar="DIR", help="write report.md, report.html, figures and CSV into DIR")
    p.add_argument("--noise", metavar="SIGMA_M", type=_noise_m, default=DEFAULT_NOISE,
                   help=f"measurement noise per axis, m (default: {DEFAULT_NOISE:g})")
    p.add_argument("--folds", metavar="K", type=_folds, default=10,
                   help="cross-validation folds (default: 10; leave-one-out when fewer rows)")
    p.add_argument("--save-model", metavar="MODEL.json", help="save the diagnosed model (cdsm.model)")
    p.add_argument("--suggest", metavar="K", type=_positive_int,
                   help="suggest K new measurement configurations (cdsm.design)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def _optional_module(name: str, what: str):
    import importlib

    try:
        return importlib.import_module(f"cdsm.{name}")
    except ModuleNotFoundError as exc:
        if exc.name not in (f"cdsm.{name}",):
            raise
        raise UserError(f"{what} needs the module cdsm.{name}, which is not installed in this build") from None


@subcommand("diagnose", help="sim-to-real gap diagnosis: which unmodelled effect explains the measurements")
@options(_diagnose_args)
def _diagnose_run(args) -> int:
    import json

    from . import diagnose, diagnose_report
    from .measurements import read_csv

    t0 = time.perf_counter()
    show = not args.quiet
    robot = load_robot(args.robot)
    if os.path.isdir(args.data):
        raise UserError(f"measurement file {args.data!r}: is a directory")
    meas = read_csv(args.data, robot.n)
    report_dir = None
    if args.report is not None:
        try:
            report_dir = _prepare_out(args.report)
        except UserError as exc:
            raise UserError(str(exc).replace("--out", "--report", 1)) from None
    for opt, path in (("--json", args.json), ("--save-model", args.save_model)):
        if path is not None and os.path.isdir(path):
            raise UserError(f"{opt} {path!r}: is a directory")
    d = diagnose.diagnose(robot, meas, effects=args.effects, folds=args.folds, noise=args.noise,
                          progress=show)
    for line in diagnose_report.summary(d):
        print(line)
    if args.json is not None:
        try:
            with open(args.json, "w", encoding="utf-8") as fh:
                json.dump(diagnose_report.json_safe(d.to_json()), fh, indent=1, allow_nan=False)
        except OSError as exc:
            raise UserError(f"--json {args.json!r}: {exc.strerror}") from None
        print(f"json: {args.json}")
    if report_dir is not None:
        paths = diagnose_report.write(d, report_dir)
        print(f"report: {paths['report_html']}")
        print(f"        {paths['report_md']}")
    if args.save_model is not None:
        model = _optional_module("model", "--save-model")
        model.Model.from_diagnosis(d).save(args.save_model)
        print(f"model: {args.save_model}")
    if args.suggest is not None:
        design = _optional_module("design", "--suggest")
        s = design.suggest(d, args.suggest)
        print(s.summary())
        if report_dir is not None:
            path = os.path.join(report_dir, "suggested.csv")
            s.to_csv(path)
            print(f"suggested configurations: {path}")
    if show:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


# ---------------------------------------------------------------------------
# cdsm montecarlo
# ---------------------------------------------------------------------------
def _percentile_list(text: str) -> List[float]:
    try:
        vals = [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated percentiles, got {text!r}") from None
    if not vals or not all(0.0 <= v <= 100.0 for v in vals):
        raise argparse.ArgumentTypeError(f"expected percentiles within [0, 100], got {text!r}")
    return vals


def _angle_deg(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an angle in degrees, got {text!r}") from None
    if not (v > 0 and v <= 180):
        raise argparse.ArgumentTypeError(f"expected an angle in (0, 180] degrees, got {text!r}")
    return v


def _montecarlo_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", metavar="R.toml", help="robot description (TOML, SI units); "
                   "default: the paper's 3-joint prototype")
    p.add_argument("--out", metavar="FILE.npz", required=True,
                   help="output: per-configuration statistics as arrays, with the run's parameters")
    p.add_argument("--samples", metavar="N", type=_positive_int, default=1000,
                   help="Monte-Carlo samples (default: 1000, as the paper)")
    p.add_argument("--seed", metavar="S", type=_seed, default=0,
                   help="seed; chunk c draws from the stream (S, c) (default: 0)")
    p.add_argument("--chunk", metavar="C", type=_positive_int, default=100,
                   help="samples per chunk = per task (default: 100); results depend on S and C "
                        "only, not on where they run. On a cluster pick C so a chunk runs >= 1 s")
    p.add_argument("--tolerances", metavar="TOL.json",
                   help="error bounds from JSON (cable_length_tol_m per upper cable, "
                        "hole_height_tol_m per disk; as `cdsm tolerance --json` writes); "
                        "default: the paper's +-1 mm and +-0.35 mm")
    p.add_argument("--protocol", choices=("attitude0", "joint"), default="attitude0",
                   help="initial configurations: the grid's tip positions at attitude 0 "
                        "(default, the paper) or the grid angles themselves")
    p.add_argument("--step", metavar="DEG", type=_angle_deg, default=5.0,
                   help="joint grid step, degrees (default: 5)")
    p.add_argument("--range", metavar="DEG", type=_angle_deg, default=30.0, dest="grid_range",
                   help="joint grid from -DEG to +DEG (default: 30)")
    p.add_argument("--percentiles", metavar="P,...", type=_percentile_list, default=[50.0, 95.0, 99.0],
                   help="percentiles of |d(X, Y)| to store (default: 50,95,99)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the chunks on this dask.distributed scheduler (e.g. tcp://host:8786; "
                        "needs pip install 'cdsm[dask]'); default: locally, threads in the Rust core")
    p.add_argument("--timeout", metavar="SECONDS", type=float, default=10.0,
                   help="seconds to reach the scheduler and find workers (default: 10)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


@subcommand("montecarlo", help="Monte-Carlo accuracy study reduced to per-configuration statistics "
                               "(.npz), locally or on a Dask cluster")
@options(_montecarlo_args)
def _montecarlo_run(args) -> int:
    import math

    import numpy as np

    from . import __version__, montecarlo, workspace

    t0 = time.perf_counter()
    show = not args.quiet
    out = args.out
    if os.path.isdir(out):
        raise UserError(f"--out {out!r}: is a directory")
    parent = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(parent):
        raise UserError(f"--out {out!r}: directory {parent!r} does not exist")
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise UserError(f"--timeout: expected a positive number of seconds, got {args.timeout}")
    robot = load_robot(args.robot)
    if args.tolerances is not None:
        if os.path.isdir(args.tolerances):
            raise UserError(f"tolerance file {args.tolerances!r}: is a directory")
        dl_tol, dh_tol = montecarlo.load_tolerances(args.tolerances, robot.n)
    else:
        dl_tol, dh_tol = montecarlo.PAPER_DL_TOL, montecarlo.PAPER_DH_TOL
    r = math.radians(args.grid_range)
    grid = workspace.joint_grid(robot.n, -r, r, math.radians(args.step))
    ws = workspace.sweep(robot, args.protocol, grid=grid)
    ok = ws.reachable
    if not ok.any():
        raise UserError("no configuration of the grid is reachable")
    if show:
        where = args.scheduler or "local threads"
        print(f"cdsm montecarlo: robot {robot.name!r}, {int(ok.sum())} configurations "
              f"({args.protocol}, {ws.n_unreachable} unreachable), {args.samples} samples in chunks of "
              f"{args.chunk}, seed {args.seed}, on {where}", file=sys.stderr, flush=True)
    try:
        mc = montecarlo.run(robot, ws.theta0[ok], samples=args.samples, seed=args.seed,
                            chunk=args.chunk, dl_tol=dl_tol, dh_tol=dh_tol,
                            scheduler=args.scheduler, progress=show, timeout=args.timeout)
    except montecarlo.ClusterError as exc:
        raise UserError(str(exc)) from None
    params = dict(robot=robot.name, robot_file=args.robot, robot_toml=montecarlo.robot_spec(robot)["toml"],
                  tolerances=args.tolerances or "paper", protocol=args.protocol, grid_step_deg=args.step,
                  grid_range_deg=args.grid_range, configurations=int(ok.sum()),
                  unreachable=ws.n_unreachable, cdsm_version=__version__)
    try:
        arrays = montecarlo.save_npz(out, mc, poses=ws.poses[ok], params=params,
                                     percentiles=args.percentiles)
    except OSError as exc:
        raise UserError(f"--out {out!r}: {exc.strerror}") from None
    written = out if out.endswith(".npz") else out + ".npz"
    worst = np.nanmax(arrays["max_abs"][:, 3]) if (mc.count > 0).any() else float("nan")
    pmax = np.nanmax(arrays["dxy_percentiles"], axis=0) if (mc.count > 0).any() else []
    print(f"{written}: {len(mc.count)} configurations x {args.samples} samples, "
          f"{int(mc.failed.sum())} failed solves; max |dXY| {worst * 1e3:.3f} mm; "
          + ", ".join(f"worst p{p:g} {v * 1e3:.3f} mm" for p, v in zip(args.percentiles, pmax))
          + f"; done in {time.perf_counter() - t0:.1f} s")
    return 0


# ---------------------------------------------------------------------------
# cdsm tolerance (issue 7)
# ---------------------------------------------------------------------------
def _tolerance_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--target-mm", metavar="T", type=float, required=True,
                   help="tip position error budget |d(x, y)|, mm")
    p.add_argument("--percentile", metavar="P", type=float, default=95.0,
                   help="percentile of |d(x, y)| pooled over the region (default: 95)")
    p.add_argument("--robot", metavar="R.toml", help="robot description (TOML, SI units); "
                   "default: the paper's 3-joint prototype")
    p.add_argument("--region", metavar="SPEC", default="grid:-30:30:5",
                   help="configurations where the errors are applied: grid:LO_DEG:HI_DEG:STEP_DEG[:N] "
                        "(every joint; a grid of more than 20000 points, or N given, is "
                        "subsampled to N (default 2000) with --seed), joints:FILE.csv (joint "
                        "angles, rad, one configuration per row) or poses:FILE.csv (x m, y m, "
                        "phi rad; pose IK with the paper seed). Default grid:-30:30:5")
    p.add_argument("--weights", metavar="W", default=None,
                   help="relative tolerance weights: 'WC,WH' (cables, holes) or 2n numbers "
                        "(n cables then n disks); default equal")
    p.add_argument("--base-mm", metavar="C,H", default="1,0.35",
                   help="reference tolerances of the equal-relative-cost shape, mm (default 1,0.35)")
    p.add_argument("--shape", choices=("ratio", "equal-effect"), default="ratio",
                   help="tolerance shape: weighted reference ratio (default) or equal linear effect")
    p.add_argument("--samples", metavar="N", type=_positive_int, default=1000,
                   help="Monte-Carlo samples per configuration (default: 1000)")
    p.add_argument("--seed", metavar="S", type=_seed, default=0, help="random seed (default: 0)")
    p.add_argument("--cells", metavar="K", type=_positive_int, default=3,
                   help="per-region report: K x K cells over the nominal tip X, Y (default 3)")
    p.add_argument("--json", metavar="OUT", help="write the answer as JSON to OUT")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def _float_list(name: str, text: str) -> List[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UserError(f"{name} {text!r}: expected comma-separated numbers") from None


def _csv_rows(path: str, width: int, what: str):
    import numpy as np

    if not os.path.isfile(path):
        raise UserError(f"--region: {what} file {path!r} does not exist")
    rows = []
    with open(path, encoding="utf-8") as fh:
        for ln, line in enumerate(fh, 1):
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            parts = [v.strip() for v in line.split(",")]
            try:
                vals = [float(v) for v in parts]
            except ValueError:
                if not rows:
                    continue  # header
                raise UserError(f"--region: {path!r} line {ln}: not numeric") from None
            if len(vals) != width:
                raise UserError(f"--region: {path!r} line {ln}: expected {width} values ({what}), got {len(vals)}")
            rows.append(vals)
    if not rows:
        raise UserError(f"--region: {path!r} holds no {what}")
    arr = np.asarray(rows, dtype=float)
    if not np.isfinite(arr).all():
        raise UserError(f"--region: {path!r} holds non-finite values")
    return arr


def parse_region(spec: str, robot, seed: int = 0):
    """Joint angles (N, n) rad of a ``--region`` spec, and a description."""
    import numpy as np

    from .workspace import joint_grid, paper_ik_seed

    kind, _, rest = spec.partition(":")
    if kind == "grid":
        try:
            vals = [float(v) for v in rest.split(":")]
        except ValueError:
            vals = []
        if len(vals) not in (3, 4):
            raise UserError(f"--region {spec!r}: expected grid:LO_DEG:HI_DEG:STEP_DEG[:N]")
        lo, hi, step = vals[:3]
        if not (np.isfinite(vals).all() and step > 0 and hi >= lo):
            raise UserError(f"--region {spec!r}: need LO <= HI and STEP > 0 (degrees)")
        k = int(np.floor((hi - lo) / step + 1e-9)) + 1
        want = int(vals[3]) if len(vals) == 4 else None
        if want is not None and want < 1:
            raise UserError(f"--region {spec!r}: N must be >= 1")
        total = k ** robot.n
        if total <= 20000 and want is None:
            return joint_grid(robot.n, np.radians(lo), np.radians(hi), np.radians(step)), \
                f"grid {lo:g}..{hi:g} deg step {step:g} ({total} configurations)"
        want = 2000 if want is None else want
        rng = np.random.default_rng([int(seed), 11])
        axis = np.radians(lo + step * np.arange(k))
        theta = axis[rng.integers(0, k, (min(want, total), robot.n))]
        return theta, f"grid {lo:g}..{hi:g} deg step {step:g}, {len(theta)} random points of {total}"
    if kind == "joints":
        t = _csv_rows(rest, robot.n, f"{robot.n} joint angles (rad)")
        return t, f"{len(t)} configurations from {rest}"
    if kind == "poses":
        p = _csv_rows(rest, 3, "poses x, y, phi (m, m, rad)")
        sol = robot.ik(p, seed=paper_ik_seed(robot.n))
        bad = np.flatnonzero(~np.asarray(sol.converged, bool))
        if len(bad):
            raise UserError(f"--region {spec!r}: pose IK failed for row(s) {bad[:5].tolist()} (unreachable?)")
        return np.atleast_2d(sol.theta), f"{len(p)} poses from {rest} (pose IK, paper seed)"
    raise UserError(f"--region {spec!r}: expected grid:LO:HI:STEP[:N], joints:FILE.csv or poses:FILE.csv")


@subcommand("tolerance", help="largest cable-length and hole-height tolerances keeping a tip-error percentile within a target")
@options(_tolerance_args)
def _tolerance_run(args) -> int:
    import json

    from . import tolerance

    t0 = time.perf_counter()
    if not (args.target_mm > 0 and args.target_mm < float("inf")):
        raise UserError(f"--target-mm: must be positive and finite, got {args.target_mm}")
    if not 0.0 < args.percentile < 100.0:
        raise UserError(f"--percentile: must be within (0, 100), got {args.percentile}")
    robot = load_robot(args.robot)
    theta, desc = parse_region(args.region, robot, args.seed)
    weights = None if args.weights is None else _float_list("--weights", args.weights)
    if weights is not None and (len(weights) not in (2, 2 * robot.n) or min(weights) <= 0
                                or not all(w < float("inf") for w in weights)):
        raise UserError(f"--weights {args.weights!r}: need 2 (cables, holes) or 2n = {2 * robot.n} "
                        "positive finite numbers (n cables then n disks)")
    base = _float_list("--base-mm", args.base_mm)
    if len(base) != 2 or min(base) <= 0:
        raise UserError(f"--base-mm {args.base_mm!r}: expected two positive numbers C,H (mm)")
    if args.json:
        d = os.path.dirname(os.path.abspath(args.json))
        if not os.path.isdir(d) or not os.access(d, os.W_OK):
            raise UserError(f"--json {args.json!r}: directory does not exist or is not writable")
    show = not args.quiet
    if show:
        print(f"cdsm tolerance: robot {robot.name!r} ({robot.n} joints), region {desc}, "
              f"P{args.percentile:g} <= {args.target_mm:g} mm, {args.samples} samples", file=sys.stderr)
    a = tolerance.allocate(robot, args.target_mm * 1e-3, theta, percentile=args.percentile,
                           weights=weights, base=[b * 1e-3 for b in base], shape=args.shape,
                           samples=args.samples, seed=args.seed, progress=show)
    dist = tolerance.distribution(robot, a.cable_length_tol_m, a.hole_height_tol_m, theta,
                                  percentiles=(50.0, args.percentile), samples=args.samples,
                                  seed=args.seed, cells=args.cells)
    out = a.to_json()
    out["region"] = args.region
    out["region_description"] = desc
    out["regions"] = dist["regions"]
    print("cable length tolerance (mm, per upper cable): "
          + ", ".join(f"±{v * 1e3:.4f}" for v in a.cable_length_tol_m))
    print("hole height tolerance (mm, per disk):         "
          + ", ".join(f"±{v * 1e3:.4f}" for v in a.hole_height_tol_m))
    print(f"achieved P{args.percentile:g} |d(x, y)| = {a.achieved_m * 1e3:.4f} mm "
          f"(target {args.target_mm:g} mm; bin-edge bound, +{tolerance.HIST_RESOLUTION * 100:.1f} % "
          f"resolution; interpolated {out['achieved_interpolated_mm']:.4f} mm); "
          f"with every tolerance x1.25: {a.achieved_1p25_m * 1e3:.4f} mm")
    print(f"linear estimate {a.linear_m * 1e3:.4f} mm; failed solves {a.failed}; "
          f"done in {time.perf_counter() - t0:.1f} s")
    if args.json:
        from .diagnose_report import json_safe

        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(json_safe(out), fh, indent=2, allow_nan=False)
        print(f"json: {args.json}")
    return 0


# ---------------------------------------------------------------------------
# cdsm compensate (issue 6; implementation in cdsm.model)
# ---------------------------------------------------------------------------
def _compensate_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("targets", metavar="TARGETS.csv", help="target poses: columns x, y (m) and optional "
                   "phi (rad); '#' comment lines")
    p.add_argument("--model", metavar="MODEL.json", required=True,
                   help="fitted model (cdsm diagnose --save-model; format cdsm-model/1)")
    p.add_argument("--out", metavar="COMMANDS.csv", required=True,
                   help="output: upper-cable length commands L_1..L_n (m) per target, converged, "
                        "predicted tip error (m), flags")
    p.add_argument("--tol", metavar="M", type=float, default=1e-9,
                   help="tip residual tolerance of the compensation solve, m (default 1e-9)")
    p.add_argument("--enforce-limits", action="store_true",
                   help="leave out targets whose nominal IK answer is outside the joint limits "
                        "(default: compensate them and flag the row)")


@subcommand("compensate", help="upper-cable commands that put the tip on target poses under a fitted model")
@options(_compensate_args)
def _compensate_run(args) -> int:
    from .model import Model, read_targets

    if not (args.tol > 0 and args.tol < 1):
        raise UserError(f"--tol: expected a positive length in m, got {args.tol}")
    model = Model.load(args.model)
    poses = read_targets(args.targets)
    res = model.compensate(poses, tol=args.tol, enforce_limits=args.enforce_limits)
    res.to_csv(args.out)
    print(f"model {model.name!r} ({model.robot.name}, {model.robot.n} joints)")
    print(res.summary())
    for i, f in enumerate(res.flags):
        if f:
            print(f"  row {i + 1}: {f}")
    print(f"commands: {os.path.abspath(args.out)}")
    return 0


# ---------------------------------------------------------------------------
# main
# ---------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one subparser per registered command."""
    from . import __version__

    parser = argparse.ArgumentParser(
        prog=PROG, description="Kinematics and tip-positioning accuracy of cable-driven serpentine "
                               "manipulators (SI units).")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for cmd in COMMANDS.values():
        p = sub.add_parser(cmd.name, help=cmd.help, description=cmd.help)
        cmd.add_args(p)
        p.set_defaults(_run=cmd.run)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``cdsm``; returns the exit status (0 ok, 2 user error)."""
    parser = build_parser()
    args = parser.parse_args(argv)  # exits 2 with a usage line on bad options
    if getattr(args, "_run", None) is None:
        parser.print_help(sys.stderr)
        return 2
    from .robot import CdsmInputError

    try:
        return int(args._run(args) or 0)
    except (CdsmInputError, UserError) as exc:
        msg = " ".join(str(exc).split())
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\n{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which closed early
        sys.stdout = open(os.devnull, "w")
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
