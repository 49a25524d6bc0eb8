"""``cdsm paper``: the seed paper's accuracy study on a robot, with its report."""

from __future__ import annotations

import argparse
import sys
import time

from .paths import add_path
from .registry import (DeprecatedOption, UserError, add_robot_option, load_robot, options, positive_int, seed_int,
                       subcommand)


def _report_files():
    from ..report.paper import PaperReport

    return PaperReport.FILES  # the paper's report writes the most files


def _paper_args(p: argparse.ArgumentParser) -> None:
    add_robot_option(p)
    add_path(p, "--out-dir", role="directory", command="cdsm paper", files=_report_files, metavar="DIR",
             default="cdsm-paper", dest="out_dir", help="output directory (default: ./cdsm-paper)")
    p.add_argument("--out", metavar="DIR", dest="out_dir", action=DeprecatedOption, replacement="--out-dir",
                   help="deprecated spelling of --out-dir")
    p.add_argument("--samples", metavar="N", type=positive_int, default=None,
                   help="Monte-Carlo samples per configuration (default: 1000, as the paper; fewer where the study "
                        "has more than 5000 configurations; spatial robots 200)")
    p.add_argument("--seed", metavar="S", type=seed_int, default=0, help="Monte-Carlo seed (default: 0)")
    p.add_argument("--configurations", metavar="N", type=positive_int, default=None,
                   help="robots studied over sampled configurations (spatial arms, planar arms of many joints): "
                        "how many joint-angle sets to sample in the joint box (scrambled Sobol, seeded by --seed; "
                        "default 1000)")
    p.add_argument("--no-scenario-figures", action="store_true", dest="no_scenario_figures",
                   help="leave out the one-figure-per-scenario maps; the overview figures still map every scenario")
    p.add_argument("--quiet", action="store_true", help="no progress output")


@subcommand("paper", help="the seed paper's accuracy study on a robot of either kind: figures, CSV tables and a "
                          "report (the paper's tables and claims for its prototype's geometry)")
@options(_paper_args)
def _paper_run(args) -> int:
    from .. import paper, report, study
    from ..report.study import jump_words

    t0 = time.perf_counter()
    robot = load_robot(args.robot)
    protocols, reason = study.choose_protocols(robot)
    sampled = any(p in ("sampled", "commanded") for p in protocols)
    if args.configurations is not None and not sampled:
        raise UserError(f"--configurations: this robot's study uses its joint grid ({reason}); configurations are "
                        "sampled for spatial robots and planar arms of many joints only")
    configurations = study.DEFAULT_CONFIGURATIONS if args.configurations is None else args.configurations
    count = study.configuration_count(robot, protocols, configurations)
    samples = study.default_samples(robot, count) if args.samples is None else args.samples
    out = args.out_dir  # absolute, owned by this run (cdsm.cli.paths)
    show = not args.quiet
    layer = paper.is_prototype(robot)
    if show:
        what = (f"{configurations} sampled configurations" if sampled else
                " and ".join(study.PROTOCOL_NAMES[p] for p in protocols))
        print(f"cdsm paper: {robot.kind} robot {robot.name!r} ({robot.n} joints), {what}, {samples} Monte-Carlo "
              f"samples, seed {args.seed}" + ("; the paper's geometry: its tables and claims too" if layer else "")
              + f" -> {out}", file=sys.stderr, flush=True)
    st = study.run(robot, samples=args.samples, seed=args.seed, progress=show, configurations=configurations)
    if layer and "attitude0" in st.workspaces:
        st = paper.extend(st)
    paths = report.write(st, out, progress=show, detail=not args.no_scenario_figures, overwrite=args.overwrite)
    h = report.headline(st)
    print(f"report: {paths['report_html']}")
    print(f"        {paths['report_md']}")
    q = robot.kind.norm_short
    for p in st.workspaces:
        line = (f"{p}: worst single-error {q} {h[f'worst_single_m_{p}'] * 1e3:.2f} mm, {jump_words(h, p)}, "
                f"unreachable {h[f'unreachable_{p}']}, Monte Carlo max {q} "
                f"{h[f'mc_max_m_{p}'] * 1e3:.2f} mm (95th pct up to {h[f'mc_max_p95_m_{p}'] * 1e3:.2f} mm)")
        fail = h[f"mc_failed_{p}"]
        line += (f", FAILED SOLVES {fail} of {h[f'mc_attempted_{p}']} at {h[f'mc_failed_configurations_{p}']} "
                 "configurations (flagged in the report)" if fail else ", failed solves 0")
        print(line)
    if "table3_max_ours_minus_paper_m" in h:
        print(f"Table 3: max |ours - paper| {h['table3_max_ours_minus_paper_m'] * 1e3:.1e} mm, "
              f"RMS measured - ours {h['table3_rms_measured_minus_ours_m'] * 1e3:.3f} mm")
    if "claims_total" in h:
        print(f"claims holding: {h['claims_holding']} of {h['claims_total']}")
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


# ---------------------------------------------------------------------------
# cdsm diagnose
