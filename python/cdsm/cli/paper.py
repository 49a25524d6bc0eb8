"""``cdsm paper``: the seed paper's accuracy study on a robot, with its report."""

from __future__ import annotations

import argparse
import math
import sys
import time

from .registry import (DeprecatedOption, UserError, add_robot_option, load_robot, options, positive_int, prepare_dir,
                       seed_int, subcommand)


def _paper_args(p: argparse.ArgumentParser) -> None:
    add_robot_option(p)
    p.add_argument("--out-dir", metavar="DIR", default="cdsm-paper", dest="out_dir",
                   help="output directory (default: ./cdsm-paper)")
    p.add_argument("--out", metavar="DIR", dest="out_dir", action=DeprecatedOption, replacement="--out-dir",
                   help="deprecated spelling of --out-dir")
    p.add_argument("--samples", metavar="N", type=positive_int, default=None,
                   help="Monte-Carlo samples (default: 1000, as the paper; spatial robots 200 per configuration)")
    p.add_argument("--seed", metavar="S", type=seed_int, default=0, help="Monte-Carlo seed (default: 0)")
    p.add_argument("--configurations", metavar="N", type=positive_int, default=None,
                   help="spatial robots: joint-angle sets sampled in the joint box (scrambled Sobol, seeded "
                        "by --seed; default 1000)")
    p.add_argument("--no-scenario-figures", action="store_true", dest="no_scenario_figures",
                   help="spatial robots: leave out the one-figure-per-scenario maps (three projections each); "
                        "the overview figures still map every scenario")
    p.add_argument("--quiet", action="store_true", help="no progress output")


@subcommand("paper", help="reproduce the seed paper's accuracy study: figures, CSV tables and a report "
                          "(spatial robots: the same methods over sampled configurations)")
@options(_paper_args)
def _paper_run(args) -> int:
    from .. import paper, report

    t0 = time.perf_counter()
    robot = load_robot(args.robot)
    if robot.kind == "spatial":
        return _spatial_run(args, robot, t0)
    for opt, given in (("--configurations", args.configurations is not None),
                       ("--no-scenario-figures", args.no_scenario_figures)):
        if given:
            raise UserError(f"{opt}: for spatial robots only (a planar study uses its joint grid and draws "
                            "every scenario)")
    samples = 1000 if args.samples is None else args.samples
    out = prepare_dir(args.out_dir, "--out-dir")
    show = not args.quiet

    def say(msg: str) -> None:
        if show:
            print(msg, file=sys.stderr, flush=True)

    say(f"cdsm paper: robot {robot.name!r} ({robot.n} joints), {samples} Monte-Carlo samples, "
        f"seed {args.seed} -> {out}")
    study = paper.run(robot, samples=samples, seed=args.seed, progress=show)
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


def _spatial_run(args, robot, t0: float) -> int:
    """``cdsm paper`` on a spatial robot: :func:`cdsm.spatial_study.run` and
    :func:`cdsm.report.spatial.write`."""
    from .. import spatial_study
    from ..report import spatial as spatial_report

    out = prepare_dir(args.out_dir, "--out-dir")
    show = not args.quiet
    configurations = spatial_study.DEFAULT_CONFIGURATIONS if args.configurations is None else args.configurations
    samples = spatial_study.DEFAULT_SAMPLES if args.samples is None else args.samples
    if show:
        print(f"cdsm paper: spatial robot {robot.name!r} ({robot.n} joints), {configurations} configurations, "
              f"{samples} Monte-Carlo samples, seed {args.seed} -> {out}", file=sys.stderr, flush=True)
    study = spatial_study.run(robot, configurations=configurations, samples=samples, seed=args.seed,
                              progress=show)
    paths = spatial_report.write(study, out, progress=show, detail=not args.no_scenario_figures)
    h = spatial_report.headline(study)
    print(f"report: {paths['report_html']}")
    print(f"        {paths['report_md']}")
    print(f"single errors: worst |dXYZ| {h['worst_single_dxyz_m'] * 1e3:.3f} mm, worst rotation "
          f"{math.degrees(h['worst_single_rotation_rad']):.3f} deg, jump points {h['jump_points']}")
    print(f"Monte Carlo: max |dXYZ| {h['mc_max_dxyz_m'] * 1e3:.3f} mm, worst 95th pct "
          f"{h['mc_max_p95_dxyz_m'] * 1e3:.3f} mm, failed solves {h['mc_failed']}")
    print(f"taut at {100 * h['feasible_share']:.1f} % of the configurations; smallest singular measure "
          f"{h['singular_min']:.3g}; done in {time.perf_counter() - t0:.1f} s")
    return 0


# ---------------------------------------------------------------------------
# cdsm diagnose
