"""The diagnosis' adequacy bound against a full parametric bootstrap, and
what keeps the ``hole_position`` pairs of issue 25 from it (docs/model.md,
"The adequacy bound").

Run: ``python benches/adequacy_bound.py [--draws B] [--steps S] [--cells ...]``
(a benchmark, not a test: not run in CI; about 5 min of CPU with the
defaults). Prints two Markdown tables.

For each cell (a hidden pair and a data set of ``bench_error_rates.py
--pairs``; default: the ``hole_position`` pairs issue 25 measured, 60 rows,
base frame, ``two_universal``):

1. the hidden pair is fitted on all rows from zero for up to 400
   Levenberg–Marquardt steps (the fitted model);
2. the **linearised** bound: :func:`cdsm.calibration.diagnosis.adequacy_bound`
   (400 draws about the fitted model's Jacobian, its median and its 0.99
   quantile);
3. the **full** parametric bootstrap: ``B`` data sets measured on a virtual
   prototype with the fitted parameters and the noise (10 µm) at the same
   commands, each refitted in full on the diagnosis' folds for ``S`` steps
   from the fitted parameters (the statistical part: where the folds' fits
   reach their minima), their held-out RMS;
4. the fit of the real data from zero (400 steps) and from the hidden
   parameters (100 steps), against the hidden parameters' own residual
   (per-row RMS over all rows): a fit from zero that ends above the
   truth's residual is in a false minimum.

Held-out RMS is given over the noise floor (sqrt(3) x 10 µm spatial).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_error_rates as ber  # noqa: E402  (benches/ is not a package)

from cdsm.calibration import diagnosis, plant  # noqa: E402
from cdsm.calibration.fit import fit_folds  # noqa: E402

CELLS = ("hole_position+tip_offset:1", "hole_position+cable_elasticity:0", "hole_position+cable_elasticity:2",
         "hole_position+link_length:1", "actuation_scale+hole_position:0")


def heldout_rms(prep, fits, folds) -> float:
    """Held-out RMS |e| (m) of the fold fits ``fits`` (one per fold) on ``prep``."""
    k = plant.dims(prep.robot)
    err = np.concatenate([np.linalg.norm(fits[f].prediction[t, :k] - prep.measured[t, :k], axis=1)
                          for f, t in enumerate(folds)])
    return float(np.sqrt(np.mean(err ** 2)))


def per_row_rms(prep, p) -> float:
    """Per-row RMS |e| (m) over the usable rows of the plant ``p`` (P,)."""
    o, k = prep.order, plant.dims(prep.robot)
    obs, _ = plant.predict(prep.robot, p, prep.theta_cmd[o], prep.dL[o], prep.reading_codes[o])
    pred = np.empty_like(obs)
    pred[o] = obs
    return float(np.sqrt(np.mean(np.sum((pred[prep.rows, :k] - prep.measured[prep.rows, :k]) ** 2, axis=1))))


def cell(robot, name: str, i: int, rows: int, draws: int, steps: int):
    case = {c.name: c for c in ber.cases(robot.kind, True)}[name]
    meas, _, _, hidden = ber.datasets(robot, case, rows, i, ber.SEED)
    prep = diagnosis.prepare(robot, meas, "base")
    effects = list(case.truth)
    folds = [prep.rows[t] for t in diagnosis.fold_split(len(prep.rows), min(10, len(prep.rows)))]
    scored = np.zeros((len(folds), len(prep.theta_cmd)), bool)
    for f, t in enumerate(folds):
        scored[f, prep.rows] = True
        scored[f, t] = False
    usable = np.zeros((1, len(prep.theta_cmd)), bool)
    usable[0, prep.rows] = True
    full = fit_folds(prep, effects, usable, np.zeros(plant.size(robot)), max_iter=400)[0]
    cand = diagnosis.Candidate(name, effects, full, np.zeros(len(prep.rows)), fitted=effects, folds=folds)
    bound = diagnosis.adequacy_bound(prep, diagnosis.NoiseEstimate(ber.NOISE, "given"), cand)
    boot = []
    for b in range(draws):
        vp = plant.VirtualPrototype(robot, full.params_by_effect(robot), noise=ber.NOISE, seed=7000 + b)
        pb = diagnosis.prepare(robot, vp.measure(prep.theta_cmd, prep.dL), "base")
        boot.append(heldout_rms(pb, fit_folds(pb, effects, scored, full.p, max_iter=steps), folds))
    truth = plant.params(robot, hidden)
    from_truth = fit_folds(prep, effects, usable, truth, max_iter=100)[0]
    return dict(name=name, i=i, bound=bound, boot=np.array(boot), zero=per_row_rms(prep, full.p),
                zero_steps=full.iterations, zero_converged=full.converged, truth=per_row_rms(prep, truth),
                from_truth=per_row_rms(prep, from_truth.p), truth_steps=from_truth.iterations)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--robot", default="two_universal")
    ap.add_argument("--rows", type=int, default=60)
    ap.add_argument("--draws", type=int, default=6, help="data sets of the full bootstrap (default 6)")
    ap.add_argument("--steps", type=int, default=100, help="fit steps of each fold of the full bootstrap")
    ap.add_argument("--cells", default=",".join(CELLS), help="comma list of PAIR:DATASET")
    args = ap.parse_args()
    robot = ber.load_robot(args.robot)
    t0 = time.perf_counter()
    out = []
    for c in args.cells.split(","):
        name, i = c.split(":")
        out.append(cell(robot, name, int(i), args.rows, args.draws, args.steps))
        print(f"  {c} done, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    print(f"`python benches/adequacy_bound.py --robot {args.robot} --rows {args.rows} --draws {args.draws} "
          f"--steps {args.steps}` ({time.perf_counter() - t0:.0f} s)\n")
    print("| Cell, base frame | Data set | Full bootstrap, median [range] | Linearised median | "
          "Linearised 0.99 quantile (the bound) |")
    print("|---|---:|---|---:|---:|")
    for r in out:
        f, b = r["boot"] / r["bound"].floor, r["bound"]
        print(f"| `{r['name']}` | {r['i']} | {np.median(f):.2f} [{f.min():.2f}, {f.max():.2f}] | "
              f"{b.median / b.floor:.2f} | {b.factor:.2f} |")
    print("\n| Cell, base frame | Data set | At the hidden parameters | Fit from them (steps) | "
          "Fit from zero (steps) |")
    print("|---|---:|---:|---:|---:|")
    for r in out:
        print(f"| `{r['name']}` | {r['i']} | {r['truth'] * 1e6:.1f} | {r['from_truth'] * 1e6:.1f} "
              f"({r['truth_steps']}) | {r['zero'] * 1e6:.1f} ({r['zero_steps']}"
              f"{'' if r['zero_converged'] else ', not converged'}) |")


if __name__ == "__main__":
    main()
