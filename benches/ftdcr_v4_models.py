"""How far any model of the elastic library gets on FTDCR v4's held-out val
file, chosen with the val file in view: an optimistic bound, not a
diagnosis. Every combination of up to ``--most`` effects of
``cdsm.plant.effects_of`` (the tracker frame always fitted) is fitted on the
whole train file (1620 rows) and judged on val (443 rows) with nothing
refitted, in OpenCR's metric (tip position error, RMS over the rows, after
removing the mean offset) beside the plain RMS. Printed best first, the
answer on the first line. `cdsm diagnose` chooses on train alone (grouped
folds) and reaches less; this says what the library could give at best
(README, "What the diagnosis of the real FTDCR v4 finds").

    python benches/ftdcr_v4_models.py [--most 3]

About 2 min of CPU at ``--most 3`` (42 fits); one thread per fit.
"""

from __future__ import annotations

import argparse
import itertools
import time

import numpy as np

import cdsm
from cdsm import plant
from cdsm.calibration.diagnosis import prepare
from cdsm.calibration.fit import fit
from cdsm.calibration.measurements import read_for

FRAME = "frame_misalignment"


def rms(e: np.ndarray) -> float:
    """RMS of the rows' Euclidean norms (m)."""
    return float(np.sqrt((e ** 2).sum(axis=1).mean()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--most", type=int, default=3, help="effects per combination at most (default 3)")
    args = ap.parse_args()
    robot = cdsm.Robot.load("ftdcr_v4")
    train = prepare(robot, read_for(robot, "ftdcr_v4_train"))
    val = prepare(robot, read_for(robot, "ftdcr_v4_val"), frame="base")  # the frame comes with each fit
    k = plant.dims(robot)
    library = [e for e in plant.effects_of(robot) if e != FRAME]
    combos = [()] + [c for r in range(1, args.most + 1) for c in itertools.combinations(library, r)]
    o = val.order
    rows = []
    t0 = time.process_time()
    for c in combos:
        f = fit(train, list(c) + [FRAME])
        pred, ok = plant.predict(robot, f.p[None], val.theta_cmd[o], val.dL[o], val.reading_codes[o])
        obs = np.empty_like(pred[0])
        obs[o] = pred[0]
        good = np.zeros(len(obs), bool)
        good[o] = ok[0]
        use = np.flatnonzero(val.usable & good & np.isfinite(obs[:, :k]).all(axis=1))
        e = obs[use, :k] - val.measured[use, :k]
        et = f.prediction[train.rows, :k] - train.measured[train.rows, :k]
        rows.append((rms(e - e.mean(axis=0)), rms(e), rms(et), "+".join(c) or "design", len(use)))
    rows.sort()
    best = rows[0]
    print(f"Best on val, chosen on val: {best[3]}, {best[0] * 1e3:.2f} mm (mean offset removed; "
          f"{best[1] * 1e3:.2f} mm plain) over {best[4]} of {len(val.usable)} rows; {len(combos)} models, "
          f"{time.process_time() - t0:.0f} s CPU")
    print(f"{'model (tracker frame fitted)':50s} {'val, mean removed':>18s} {'val':>8s} {'train':>8s}  (mm)")
    for ma, plain, tr, name, _ in rows:
        print(f"{name:50s} {ma * 1e3:18.3f} {plain * 1e3:8.3f} {tr * 1e3:8.3f}")


if __name__ == "__main__":
    main()
