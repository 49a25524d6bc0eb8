"""``cdsm diagnose``: the sim-to-real gap of measurements against a robot."""

from __future__ import annotations

import argparse
import sys
import time

from .paths import add_path
from .registry import (add_robot_option, load_robot, options, positive_int, subcommand)
from typing import List


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
    v = positive_int(text)
    if v < 2:
        raise argparse.ArgumentTypeError(f"expected at least 2 folds, got {text!r}")
    return v


def _effect_list(text: str) -> List[str]:
    """argparse type: a comma list of effect names (checked against the
    robot's library once the robot is read, before the data)."""
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise argparse.ArgumentTypeError(f"expected a comma-separated list of effects, got {text!r}")
    dup = sorted({t for t in names if names.count(t) > 1})
    if dup:
        raise argparse.ArgumentTypeError(f"effect(s) listed twice: {', '.join(dup)}")
    return names


def _report_files():
    from ..report.diagnosis import FILES

    return FILES


def _diagnose_args(p: argparse.ArgumentParser) -> None:
    from ..calibration.diagnosis import DEFAULT_NOISE, FRAMES, NEAR_FRACTION

    add_path(p, "data", role="input", metavar="DATA.csv|NAME",
             help="measurement table (CSV, SI units; see cdsm.calibration.measurements), or the name of a "
                  "packaged table (`cdsm list data`: e.g. table3)")
    add_robot_option(p)
    p.add_argument("--effects", metavar="a,b,...", type=_effect_list, default=None,
                   help="candidate effects (comma list; default: the whole library)")
    add_path(p, "--validate", role="input", metavar="VAL.csv|NAME",
             help="judge the nominal and the diagnosed model on a second measurement table, nothing refitted "
                  "(the frame and every parameter as fitted on DATA): tip error RMS, as is and with the mean "
                  "offset removed, in the summary and the JSON's `validation`")
    add_path(p, "--json", role="output", metavar="OUT", help="write the diagnosis as JSON (SI units)")
    add_path(p, "--report", role="directory", command="cdsm diagnose", files=_report_files, metavar="DIR",
             help="write report.md, report.html, figures and CSV into DIR")
    p.add_argument("--noise", metavar="SIGMA_M", type=_noise_m, default=None,
                   help="measurement noise per axis and reading, m (default: estimated from repeated "
                        f"commands in the data, else assumed {DEFAULT_NOISE:g})")
    p.add_argument("--frame", choices=FRAMES, default="auto",
                   help="absolute data: 'auto' (default) takes data within "
                        f"{NEAR_FRACTION * 100:.0f} %% of the arm's length of the nominal predictions in the "
                        "base frame (the frame a candidate effect) and registers farther ones; 'register' fits the "
                        "measuring frame with every candidate (a tracker's own frame); 'base' says the data "
                        "are in the robot's base frame")
    p.add_argument("--folds", metavar="K", type=_folds, default=10,
                   help="cross-validation folds (default: 10; leave-one-out when fewer rows)")
    p.add_argument("--folds-by", metavar="COLUMN", default=None,
                   help="hold out the rows of one value of this label column together (e.g. a motion pattern: "
                        "neighbouring keypoints of one pattern are not independent readings); default: row by row")
    add_path(p, "--save-model", role="output", metavar="MODEL.json",
             help="save the diagnosed model (cdsm.calibration.model)")
    p.add_argument("--suggest", metavar="K", type=positive_int,
                   help="suggest K new measurement configurations (cdsm.calibration.experiment)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


@subcommand("diagnose", help="sim-to-real gap diagnosis: which unmodelled effect explains the measurements")
@options(_diagnose_args)
def _diagnose_run(args) -> int:
    from ..calibration import diagnosis as diagnose
    from ..calibration.measurements import read_for
    from ..files import write_json
    from ..report import diagnosis as diagnose_report

    t0 = time.perf_counter()
    show = not args.quiet
    robot = load_robot(args.robot)
    if args.effects is not None:
        from ..calibration.plant import check_effects

        check_effects(robot, args.effects, "--effects")
    meas = read_for(robot, args.data, progress=show)
    report_dir = args.report  # absolute, owned by this run (cdsm.cli.paths)
    d = diagnose.diagnose(robot, meas, effects=args.effects, folds=args.folds, noise=args.noise,
                          frame=args.frame, progress=show, folds_by=args.folds_by)
    suggestion = None
    if args.suggest is not None:
        from ..calibration.experiment import suggest

        suggestion = suggest(d, args.suggest)
    validation = None
    if args.validate is not None:
        from ..calibration.validation import validate

        validation = validate(d, read_for(robot, args.validate, progress=show))
    for line in diagnose_report.summary(d, suggestion):
        print(line)
    if validation is not None:
        print(validation.summary())
    if suggestion is not None:
        print(suggestion.summary())
    if args.json is not None:
        out = d.to_json()
        if validation is not None:
            out["validation"] = validation.to_json()
        write_json(args.json, out, "--json")
        print(f"json: {args.json}")
    if report_dir is not None:
        paths = diagnose_report.write(d, report_dir, suggestion=suggestion, overwrite=args.overwrite,
                                      validation=validation)
        print(f"report: {paths['report_html']}")
        print(f"        {paths['report_md']}")
        if "suggested_csv" in paths:
            print(f"suggested configurations: {paths['suggested_csv']}")
    if args.save_model is not None:
        from ..calibration.model import FittedPlant

        FittedPlant.from_diagnosis(d).save(args.save_model)
        print(f"model: {args.save_model}")
    if show:
        print(f"done in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


# ---------------------------------------------------------------------------
# cdsm montecarlo
# ---------------------------------------------------------------------------
