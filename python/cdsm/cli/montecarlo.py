"""``cdsm montecarlo``: a Monte-Carlo study to ``.npz``, locally or on a Dask cluster."""

from __future__ import annotations

import argparse
import sys
import time

from .paths import add_path
from .registry import (UserError, add_robot_option, load_robot, options, positive_int, seed_int, subcommand)
from typing import List


def _percentile_list(text: str) -> List[float]:
    try:
        vals = [float(t) for t in text.split(",") if t.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated percentiles, got {text!r}") from None
    if not vals or not all(0.0 <= v <= 100.0 for v in vals):
        raise argparse.ArgumentTypeError(f"expected percentiles within [0, 100], got {text!r}")
    twice = [v for i, v in enumerate(vals) if v in vals[:i]]
    if twice:
        from ..accuracy.montecarlo import percentile_text

        raise argparse.ArgumentTypeError(f"percentile {percentile_text(twice[0])} is given more than once in {text!r}")
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
    add_robot_option(p)
    add_path(p, "--out", role="output", suffix=".npz", metavar="FILE.npz", required=True,
             help="output: per-configuration statistics as arrays, with the run's parameters")
    p.add_argument("--samples", metavar="N", type=positive_int, default=1000,
                   help="Monte-Carlo samples (default: 1000, as the paper)")
    p.add_argument("--seed", metavar="S", type=seed_int, default=0,
                   help="seed; chunk c draws from the stream (S, c) (default: 0)")
    p.add_argument("--chunk", metavar="C", type=positive_int, default=100,
                   help="samples per chunk = per task (default: 100); results depend on S and C "
                        "only, not on where they run. On a cluster pick C so a chunk runs >= 1 s")
    add_path(p, "--tolerances", role="input", metavar="TOL.json",
             help="error bounds from JSON (cable_length_tol_m per upper cable, "
                  "hole_height_tol_m per disk; spatial robots: cable_length_tol_m per position-controlled "
                  "cable and hole_tol_m per cable's holes or per hole coordinate; as `cdsm tolerance "
                  "--json` writes); default: the paper's +-1 mm and +-0.35 mm (spatial: on every hole "
                  "coordinate)")
    p.add_argument("--protocol", choices=("attitude0", "joint"), default=None,
                   help="initial configurations: the grid's tip positions at attitude 0 "
                        "(default, the paper) or the grid angles themselves (spatial robots: joint only)")
    p.add_argument("--step", metavar="DEG", type=_angle_deg, default=None,
                   help="joint grid step, degrees (default: 5; planar robots)")
    p.add_argument("--range", metavar="DEG", type=_angle_deg, default=None, dest="grid_range",
                   help="joint grid from -DEG to +DEG (default: 30; spatial robots: samples within the joint "
                        "limits and, if given, within +-DEG)")
    p.add_argument("--configurations", metavar="N", type=positive_int, default=None,
                   help="spatial robots: configurations sampled in the joint box (scrambled Sobol, seed 0 "
                        "whatever --seed, so runs with other seeds can be merged; default 2197 = 13^3); "
                        "elastic arms: commands sampled in the --reach-mm box (default 500)")
    p.add_argument("--reach-mm", metavar="MM", type=float, default=None, dest="reach_mm",
                   help="elastic arms: half-width of the box of commands sampled on every commanded cable, mm "
                        "(default: 3)")
    p.add_argument("--percentiles", metavar="P,...", type=_percentile_list, default=[50.0, 95.0, 99.0],
                   help="percentiles of |d(X, Y)| (spatial: |d(X, Y, Z)|) to store (default: 50,95,99)")
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

    from .. import __version__
    from ..accuracy import distributed, montecarlo
    from ..accuracy.scenarios import PAPER_DH_TOL, PAPER_DL_TOL
    from ..accuracy.tolerance import read_tolerances

    t0 = time.perf_counter()
    show = not args.quiet
    out = args.out
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise UserError(f"--timeout: expected a positive number of seconds, got {args.timeout}")
    robot = load_robot(args.robot)
    if robot.is_elastic:  # its configurations are the equilibria of commands: the plant's Monte Carlo
        mc, poses, params = _commanded_study(args, robot, show)
    else:
        # the paper's joint grid where its protocols apply (planar), else configurations sampled in the joint box
        if args.reach_mm is not None:
            raise UserError("--reach-mm: for elastic arms only (their commands are sampled; a rigid arm's "
                            "configurations are its joint angles: --range)")
        configurations = _grid_configurations if robot.kind.grid_protocols else _sampled_configurations
        theta0, poses, params, desc = configurations(args, robot)
        dl_tol, dh_tol = ((PAPER_DL_TOL, PAPER_DH_TOL) if args.tolerances is None
                          else read_tolerances(args.tolerances, robot))
        if show:
            where = args.scheduler or "local threads"
            print(f"cdsm montecarlo: robot {robot.name!r}, {desc}, {args.samples} samples in chunks of "
                  f"{args.chunk}, seed {args.seed}, on {where}", file=sys.stderr, flush=True)
        try:
            mc = distributed.run(robot, theta0, samples=args.samples, seed=args.seed,
                                chunk=args.chunk, dl_tol=dl_tol, dh_tol=dh_tol,
                                scheduler=args.scheduler, progress=show, timeout=args.timeout)
        except distributed.ClusterError as exc:
            raise UserError(str(exc)) from None
    params = dict(robot=robot.name, robot_file=args.robot, robot_toml=robot.to_toml(),
                  tolerances=args.tolerances or "paper", **params, cdsm_version=__version__)
    arrays = montecarlo.save_npz(out, mc, poses=poses, params=params, percentiles=args.percentiles)
    written = out if out.endswith(".npz") else out + ".npz"
    worst = np.nanmax(arrays["max_abs"][:, 3]) if (mc.count > 0).any() else float("nan")
    pmax = np.nanmax(arrays["dxy_percentiles"], axis=0) if (mc.count > 0).any() else []
    norm = robot.kind.norm_short
    print(f"{written}: {len(mc.count)} configurations x {args.samples} samples, "
          f"{int(mc.failed.sum())} failed solves; max {norm} {worst * 1e3:.3f} mm; "
          + ", ".join(f"worst p{montecarlo.percentile_text(p)} {v * 1e3:.3f} mm"
                      for p, v in zip(args.percentiles, pmax))
          + f"; done in {time.perf_counter() - t0:.1f} s")
    return 0


#: Commands of ``cdsm montecarlo`` on an elastic arm by default (each sample settles them all in sequence).
ELASTIC_CONFIGURATIONS = 500


def _commanded_study(args, robot, show: bool):
    """The Monte Carlo of an elastic arm (:mod:`cdsm.accuracy.plant_errors`):
    ``--configurations`` commands sampled in the box ±``--reach-mm`` on
    every commanded cable (scrambled Sobol, seed 0), the nominal plant
    settled at them in order; every sample's plant (manufacturing errors as
    plant parameters within the tolerances) settled at the same commands.
    Returns the statistics, the nominal tips and the run parameters."""
    import math

    from ..accuracy import plant_errors
    from ..accuracy.tolerance import read_tolerances

    for given, option, why in ((args.scheduler, "--scheduler", "the plant's Monte Carlo runs locally"),
                               (args.step, "--step", "its commands are sampled, not gridded"),
                               (args.grid_range, "--range", "its commands are sampled in a box of cable "
                                                            "displacements: --reach-mm"),
                               (args.protocol, "--protocol", "its protocol is the sampled commands")):
        if given is not None:
            raise UserError(f"{option}: not for an elastic arm ({why})")
    reach = 1e3 * plant_errors.COMMAND_RANGE if args.reach_mm is None else args.reach_mm
    if not (math.isfinite(reach) and reach > 0):
        raise UserError(f"--reach-mm: expected a positive number of mm, got {args.reach_mm}")
    count = ELASTIC_CONFIGURATIONS if args.configurations is None else args.configurations
    tol = None
    if args.tolerances is not None:  # per commanded cable and per hole error, as for a rigid arm
        dl, dh = read_tolerances(args.tolerances, robot)
        tol = {"cable_offset": dl, plant_errors.hole_block(robot): dh}
    if show:
        print(f"cdsm montecarlo: elastic robot {robot.name!r}, {count} commands within ±{reach:g} mm on every "
              f"commanded cable (scrambled Sobol, seed 0), {args.samples} samples in chunks of {args.chunk}, "
              f"seed {args.seed}, the plant's equilibria on local threads", file=sys.stderr, flush=True)
    ws = plant_errors.sample_commands(robot, count, seed=0, reach=reach * 1e-3)
    ok = ws.reachable
    if not ok.any():
        raise UserError("the nominal plant settles at none of the sampled commands")
    mc = plant_errors.monte_carlo_commands(robot, ws.commands[ok], samples=args.samples, seed=args.seed,
                                           tolerances=tol, chunk=args.chunk, progress=show)
    # by plant block (one number where the block's are equal); "tolerances" names their source, as for rigid arms
    by_block = mc.params.pop("tolerances")
    mc.params["plant_tolerances_m"] = {b: v[0] if len(set(v)) == 1 else v for b, v in by_block.items()}
    params = dict(protocol="commanded", sampling="scrambled Sobol, seed 0", reach_m=reach * 1e-3,
                  configurations=int(count), unreachable=int((~ok).sum()),
                  path_dependent=int(ws.path_dependent[ok].sum()))
    return mc, ws.poses[ok], params


# ---------------------------------------------------------------------------
# cdsm tolerance (issue 7)


#: Configurations of ``cdsm montecarlo`` on a spatial robot by default (13^3, the planar grid's size).
SPATIAL_CONFIGURATIONS = 2197


def _grid_configurations(args, robot):
    """Joint angles (N, n) rad, end poses (N, 3), run parameters and their
    description of a planar robot's study: the reachable configurations of
    the joint grid (``--range``, ``--step``) under ``--protocol``."""
    import math

    from ..accuracy import workspace

    if args.configurations is not None:
        raise UserError("--configurations: for spatial robots only (planar robots: --range and --step)")
    protocol = args.protocol or "attitude0"
    step = 5.0 if args.step is None else args.step
    grid_range = 30.0 if args.grid_range is None else args.grid_range
    r = math.radians(grid_range)
    grid = workspace.joint_grid(robot.n, -r, r, math.radians(step))
    ws = workspace.sweep(robot, protocol, grid=grid)
    ok = ws.reachable
    if not ok.any():
        raise UserError("no configuration of the grid is reachable")
    params = dict(protocol=protocol, grid_step_deg=step, grid_range_deg=grid_range,
                  configurations=int(ok.sum()), unreachable=ws.n_unreachable)
    return (ws.theta0[ok], ws.poses[ok], params,
            f"{int(ok.sum())} configurations ({protocol}, {ws.n_unreachable} unreachable)")


def _sampled_configurations(args, robot):
    """Joint angles (N, n) rad, end poses (N, 6), run parameters and their
    description of a spatial robot's study: a scrambled Sobol sample (seed
    0) of the joint box, within +-``--range`` degrees when given."""
    import math

    import numpy as np

    from ..accuracy.sampling import sample_configurations

    if args.step is not None:
        raise UserError("--step: spatial robots are sampled, not gridded; use --configurations (and --range)")
    if args.protocol == "attitude0":
        raise UserError("--protocol attitude0: planar robots only; a spatial study applies the errors at the "
                        "sampled joint angles (--protocol joint)")
    count = SPATIAL_CONFIGURATIONS if args.configurations is None else args.configurations
    limits = robot.joint_limits
    if args.grid_range is not None:
        r = math.radians(args.grid_range)
        limits = np.stack([np.maximum(limits[:, 0], -r), np.minimum(limits[:, 1], r)], axis=1)
        if (limits[:, 1] < limits[:, 0]).any():
            raise UserError(f"--range {args.grid_range:g}: outside the joint limits of some joint")
    theta = sample_configurations(robot, count, method="sobol", seed=0, limits=limits)
    params = dict(protocol="joint", sampling="scrambled Sobol, seed 0", grid_range_deg=args.grid_range,
                  configurations=int(count), unreachable=0)
    return theta, robot.fk(theta), params, f"{len(theta)} configurations (sampled, {params['sampling']})"
