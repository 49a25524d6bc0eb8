"""``cdsm paper``: the seed paper's accuracy study on a robot, with its report."""

from __future__ import annotations

import argparse
import sys
import time

from .registry import (DeprecatedOption, load_robot, options, positive_int, prepare_dir, seed_int,
                       subcommand)


def _paper_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", metavar="R.toml", help="robot description (TOML, SI units); "
                   "default: the paper's 3-joint prototype")
    p.add_argument("--out-dir", metavar="DIR", default="cdsm-paper", dest="out_dir",
                   help="output directory (default: ./cdsm-paper)")
    p.add_argument("--out", metavar="DIR", dest="out_dir", action=DeprecatedOption, replacement="--out-dir",
                   help="deprecated spelling of --out-dir")
    p.add_argument("--samples", metavar="N", type=positive_int, default=1000,
                   help="Monte-Carlo samples (default: 1000, as the paper)")
    p.add_argument("--seed", metavar="S", type=seed_int, default=0, help="Monte-Carlo seed (default: 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


@subcommand("paper", help="reproduce the seed paper's accuracy study: figures, CSV tables and a report")
@options(_paper_args)
def _paper_run(args) -> int:
    from .. import paper, report

    t0 = time.perf_counter()
    robot = load_robot(args.robot)
    out = prepare_dir(args.out_dir, "--out-dir")
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
