"""``cdsm tolerance``: the largest tolerances that keep a tip-error percentile within a target."""

from __future__ import annotations

import argparse
import sys
import time

from .paths import add_path
from .registry import (UserError, add_robot_option, load_robot, options, positive_int, seed_int, subcommand)
from typing import List


# ---------------------------------------------------------------------------
def _tolerance_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--target-mm", metavar="T", type=float, required=True,
                   help="tip position error budget |d(x, y)|, mm")
    p.add_argument("--percentile", metavar="P", type=float, default=95.0,
                   help="percentile of |d(x, y)| pooled over the region (default: 95)")
    add_robot_option(p)
    add_path(p, "--region", role="input", path_of=_region_file, metavar="SPEC", default=None,
             help="configurations where the errors are applied: grid:LO_DEG:HI_DEG:STEP_DEG[:N] "
                  "(every joint; a grid of more than 20000 points, or N given, is "
                  "subsampled to N (default 2000) with --seed), joints:FILE.csv (joint "
                  "angles, rad, one configuration per row), poses:FILE.csv (x m, y m, "
                  "phi rad; pose IK with the paper seed; planar) or sobol:N (N configurations sampled "
                  "in the joint box with --seed). Default grid:-30:30:5 (spatial robots: sobol:1000); "
                  "elastic arms: sobol:N commands sampled in +-3 mm on every commanded cable (default "
                  "sobol:200)")
    p.add_argument("--weights", metavar="W", default=None,
                   help="relative tolerance weights: 'WC,WH' (cables, holes) or 2n numbers "
                        "(n cables then n disks; spatial robots: m position-controlled cables then every "
                        "cable's holes); default equal")
    p.add_argument("--base-mm", metavar="C,H", default="1,0.35",
                   help="reference tolerances of the equal-relative-cost shape, mm (default 1,0.35)")
    p.add_argument("--shape", choices=("ratio", "equal-effect"), default="ratio",
                   help="tolerance shape: weighted reference ratio (default) or equal linear effect (planar)")
    p.add_argument("--samples", metavar="N", type=positive_int, default=1000,
                   help="Monte-Carlo samples per configuration (default: 1000)")
    p.add_argument("--seed", metavar="S", type=seed_int, default=0, help="random seed (default: 0)")
    p.add_argument("--cells", metavar="K", type=positive_int, default=3,
                   help="per-region report: K x K cells over the nominal tip X, Y (default 3)")
    add_path(p, "--json", role="output", metavar="OUT", help="write the answer as JSON to OUT")
    p.add_argument("--quiet", action="store_true", help="no progress output")


def _region_file(spec: str):
    """The file a ``--region`` spec reads (``joints:FILE``, ``poses:FILE``), else None."""
    region, _, rest = spec.partition(":")
    return rest if region in ("joints", "poses") else None


def _float_list(name: str, text: str) -> List[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise UserError(f"{name} {text!r}: expected comma-separated numbers") from None


@subcommand("tolerance", help="largest cable-length and hole-height tolerances keeping a tip-error "
                              "percentile within a target")
@options(_tolerance_args)
def _tolerance_run(args) -> int:
    from ..accuracy import tolerance
    from ..accuracy.montecarlo import hole_error_sizes
    from ..calibration.measurements import commanded_cables
    from ..files import write_json

    t0 = time.perf_counter()
    if not (args.target_mm > 0 and args.target_mm < float("inf")):
        raise UserError(f"--target-mm: must be positive and finite, got {args.target_mm}")
    if not 0.0 < args.percentile < 100.0:
        raise UserError(f"--percentile: must be within (0, 100), got {args.percentile}")
    robot = load_robot(args.robot)
    kind = robot.kind
    words = kind.allocation
    commanded = commanded_cables(robot)
    m, groups = len(commanded), len(hole_error_sizes(robot))
    # an elastic arm's region is its commands (the plant's equilibria), a rigid arm's its joint angles
    default_region = f"sobol:{tolerance.ELASTIC_COMMANDS}" if robot.is_elastic else words["region"]
    region, configurations, desc, weights, base = _inputs(args, robot, default_region, m + groups,
                                                          words["weights"].format(count=m + groups, m=m,
                                                                                  groups=groups, finite=" finite"))
    where = dict(commands=configurations) if robot.is_elastic else dict(theta=configurations)
    show = not args.quiet
    if show:
        print(f"cdsm tolerance: {'elastic ' if robot.is_elastic else ''}{words['robot']} {robot.name!r} "
              f"({robot.n} joints), region {desc}, P{args.percentile:g} <= {args.target_mm:g} mm, "
              f"{args.samples} samples", file=sys.stderr)
    a = tolerance.allocate(robot, args.target_mm * 1e-3, percentile=args.percentile,
                           weights=weights, base=[b * 1e-3 for b in base], shape=args.shape,
                           samples=args.samples, seed=args.seed, progress=show, **where)
    holes = getattr(a, kind.hole_tolerance_key)
    dist = tolerance.distribution(robot, a.cable_length_tol_m, holes, percentiles=(50.0, args.percentile),
                                  samples=args.samples, seed=args.seed, cells=args.cells, **where)
    out = a.to_json()
    out.update(region=region, region_description=desc, regions=dist["regions"], region_axes=dist["axes"])
    cables = ", ".join(str(c + 1) for c in commanded)
    print(words["cables_line"].format(cables=cables) + ", ".join(f"±{v * 1e3:.4f}" for v in a.cable_length_tol_m))
    print(words["holes_line"].format(groups=groups, cables=cables) + ", ".join(f"±{v * 1e3:.4f}" for v in holes))
    print(f"achieved P{args.percentile:g} {kind.norm_label.lower()} = {a.achieved_m * 1e3:.4f} mm "
          f"(target {args.target_mm:g} mm; within ±{tolerance.HIST_RESOLUTION * 100:.1f} % of the sample quantile; "
          f"interpolated {out['achieved_interpolated_mm']:.4f} mm); "
          f"with every tolerance x1.25: {a.achieved_1p25_m * 1e3:.4f} mm")
    print(f"linear estimate {a.linear_m * 1e3:.4f} mm{words['evaluations'].format(evaluations=len(a.history))}; "
          f"failed solves {a.failed}; done in {time.perf_counter() - t0:.1f} s")
    if args.json:
        write_json(args.json, out, "--json", indent=2)
        print(f"json: {args.json}")
    return 0


def _inputs(args, robot, default_region: str, width: int, what: str):
    """The options both kinds check alike: the region (``default_region``
    when not given), ``--weights`` (2 or ``width`` numbers, ``what`` says
    which) and ``--base-mm``. Returns region, theta,
    its description, weights (or None) and base (mm)."""
    from ..accuracy import tolerance

    region = args.region or default_region
    theta, desc = tolerance.parse_region(region, robot, args.seed)
    weights = None if args.weights is None else _float_list("--weights", args.weights)
    if weights is not None and (len(weights) not in (2, width) or min(weights) <= 0
                                or not all(w < float("inf") for w in weights)):
        raise UserError(f"--weights {args.weights!r}: need 2 (cables, holes) or {what}")
    base = _float_list("--base-mm", args.base_mm)
    if len(base) != 2 or min(base) <= 0:
        raise UserError(f"--base-mm {args.base_mm!r}: expected two positive numbers C,H (mm)")
    return region, theta, desc, weights, base
