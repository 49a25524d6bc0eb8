"""Which two-effect mixtures of the diagnosis library the data can tell apart
(``python benches/identifiability.py [--robot two_universal] [--datasets 3]``;
a benchmark, not a test). Writes ``benches/identifiability.md``.

For the data sets of ``benches/bench_error_rates.py --pairs`` (same seeds,
commands and hidden effects; base frame), the plant is linearised at the
nominal model (exact Jacobians, :func:`cdsm.calibration.plant.linearise`)
and each effect ``A`` of a pair ``(A, B)`` is measured by

* its *signal*: ``|J_A x_A| / sigma``, the 2-norm over every position
  component of the rows of the change its hidden values ``x_A`` make, over
  the noise per axis ``sigma`` = 10 µm;
* its *signal beside B*: ``|(I - P_B) J_A x_A| / sigma``, ``P_B`` the
  orthogonal projector on the column space of ``B``'s Jacobian: what is
  left of ``A``'s change once ``B`` has taken all it can.

A signal beside ``B`` far below 1 means the data cannot tell ``A + B`` from
``B`` alone, whatever the sample: ``A`` lies in ``B``'s column space (a true
confounding, not a weakness of the search). The smallest singular value of
the joint Jacobian is not used: a many-parameter effect such as
``hole_position`` has near-null directions of its own that say nothing
about whether a second effect can be told from it.

``cable_friction`` is not linear at ``mu = 0`` (its sliding state), so it is
measured directly: the tip change ``|p(mu) - p(0)|`` over the rows at the
benchmark's friction (0.15-0.3) for the robot file's cable and for the
other cables given with ``--cable E,d`` (Pa, m).
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_error_rates as ber  # noqa: E402  (benches/ is not a package)

from cdsm.calibration import plant  # noqa: E402


def pair_jacobian(robot, a: str, b: str, rows: int, i: int, seed: int):
    """The position Jacobian of data set ``i`` of the benchmark's ``a+b``
    cell (base frame), linearised at the nominal model: columns ``a``'s
    parameters, one row per position component (m per SI unit), as
    {effect: columns}; with the hidden effects ({effect: values}, SI)."""
    case = ber.Case(a + "+" + b, "library", (a, b))
    base, _, _, hidden = ber.datasets(robot, case, rows, i, seed)
    i_a, i_b = plant.effect_indices(robot, a), plant.effect_indices(robot, b)
    free = np.concatenate([i_a, i_b])
    _, _, jac = plant.linearise(robot, np.zeros(plant.size(robot)), free, base.theta, base.dL)
    J = jac[:, :plant.dims(robot), :].reshape(-1, len(free))
    return {a: J[:, :len(i_a)], b: J[:, len(i_a):]}, hidden


def pair_signals(robot, a: str, b: str, rows: int, i: int, seed: int):
    """(signal, signal beside the other) / sigma of ``a`` and of ``b`` in data set ``i``."""
    cols, hidden = pair_jacobian(robot, a, b, rows, i, seed)
    out = {}
    for x, y in ((a, b), (b, a)):
        v = plant.params(robot, {x: hidden[x]})[plant.effect_indices(robot, x)]
        sig = cols[x] @ v
        u, s, _ = np.linalg.svd(cols[y], full_matrices=False)
        u = u[:, s > s[0] * 1e-10]
        left = sig - u @ (u.T @ sig)
        out[x] = (float(np.linalg.norm(sig) / ber.NOISE), float(np.linalg.norm(left) / ber.NOISE))
    return out


def absorbing(robot, small: str, big: str, rows: int, seed: int):
    """The parameters of ``big`` that reproduce each parameter of ``small``
    (least squares on the linearised plant, data set 0): the three largest
    coefficients per column, in ``big``'s typical units."""
    cols, _ = pair_jacobian(robot, small, big, rows, 0, seed)
    names = plant.parameter_names(robot, plant.effect_indices(robot, big))
    reach = cols[big] * plant.TYPICAL[big]
    out = []
    for j, name in enumerate(plant.parameter_names(robot, plant.effect_indices(robot, small))):
        target = cols[small][:, j] * plant.TYPICAL[small]
        coef, *_ = np.linalg.lstsq(reach, target, rcond=None)
        left = np.linalg.norm(target - reach @ coef) / np.linalg.norm(target)
        top = np.argsort(-np.abs(coef))[:3]
        out.append(f"{name} (typical size) = " + " + ".join(f"{coef[k]:+.2f} {names[k]}" for k in top)
                   + f" + … (relative residual {left:.1e})")
    return out


def friction_signal(robot, rows: int, mu: float, seed: int = 3):
    """Tip change of ``mu`` against none over benchmark rows: RMS, max (µm)
    and sum((change / noise)^2)."""
    vp = plant.VirtualPrototype(robot, {})
    th, dl = vp.random_commands(rows, seed=seed)
    p0, _ = plant.predict(robot, plant.params(robot, {}), th, dl)
    p1, _ = plant.predict(robot, plant.params(robot, {"cable_friction": [mu]}), th, dl)
    k = plant.dims(robot)
    d = np.linalg.norm(p1[:, :k] - p0[:, :k], axis=1)
    return float(np.sqrt(np.mean(d ** 2)) * 1e6), float(d.max() * 1e6), float(np.sum(d ** 2) / ber.NOISE ** 2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--robot", default="two_universal")
    ap.add_argument("--datasets", type=int, default=3)
    ap.add_argument("--rows", default="60,15")
    ap.add_argument("--seed", type=int, default=ber.SEED)
    ap.add_argument("--cable", action="append", default=["2.5e9,0.3e-3"],
                    help="another cable E,d (Pa, m) for the friction table (default nylon 6,6, 0.3 mm)")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "identifiability.md"))
    args = ap.parse_args()
    t0 = time.perf_counter()
    robot = ber.load_robot(args.robot)
    robot.threads = 1
    rows_list = [int(r) for r in args.rows.split(",")]
    library = [e for e in plant.effects_of(robot) if e != "cable_friction"]
    size = {e: len(plant.effect_indices(robot, e)) for e in plant.effects_of(robot)}
    lines = ["## Which mixtures the data can tell apart", "",
             f"`python benches/identifiability.py --robot {args.robot} --datasets {args.datasets}` (seed "
             f"{args.seed}; the data sets of `bench_error_rates.py --pairs`, base frame; noise σ = "
             f"{ber.NOISE * 1e6:.0f} µm per axis). Signal: |J_A x_A| / σ over every position component of the "
             "rows (linearised at the nominal model); beside B: what is left once B's column space has taken "
             "all it can. Median (min) over the data sets. A signal beside B below 1 σ: the data cannot tell "
             "A + B from B alone.", "",
             "Parameters per effect: " + ", ".join(f"`{e}` {p}" for e, p in size.items()) + ".", ""]
    for rows in rows_list:
        lines += [f"### {rows} rows ({rows * plant.dims(robot)} position components)", "",
                  "| A | B | signal A | A beside B | signal B | B beside A |", "|---|---|---:|---:|---:|---:|"]
        for a, b in itertools.combinations(library, 2):
            if size[a] + size[b] >= rows * plant.dims(robot):
                lines.append(f"| {a} | {b} | — | — | — | — ({size[a] + size[b]} parameters) |")
                continue
            got = [pair_signals(robot, a, b, rows, i, args.seed) for i in range(args.datasets)]

            def cell(e, w):
                v = np.array([g[e][w] for g in got])
                return f"{np.median(v):.1f} ({v.min():.1f})"
            lines.append(f"| {a} | {b} | {cell(a, 0)} | {cell(a, 1)} | {cell(b, 0)} | {cell(b, 1)} |")
            print(lines[-1], file=sys.stderr, flush=True)
        lines.append("")
    if "hole_position" in library:
        lines += ["### What reproduces the absorbed effects (60 rows, data set 0)", "",
                  "`hole_position[3h + a]`: hole `h` in the order of docs/model.md (cable by cable, each "
                  "cable's base face b, then faces a and b of each disk it passes), `a` = 0, 1, 2 for dx, dy, dz "
                  "in the face's frame (x along the arm, y radial for the cables at 0°).", ""]
        for small in ("actuation_scale", "cable_offset"):
            lines += [f"- {s}" for s in absorbing(robot, small, "hole_position", 60, args.seed)]
        lines.append("")
    lines += ["### Friction's tip effect", "",
              "| cable | E·A (N) | rows | mu | RMS (µm) | max (µm) | sum((change/σ)²) |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    cables = [(robot.youngs_modulus, robot.cable_diameter)]
    cables += [tuple(float(x) for x in c.split(",")) for c in args.cable]
    for e_mod, dia in cables:
        r = robot.with_cable(youngs_modulus=e_mod, diameter=dia)
        ea = e_mod * np.pi * dia ** 2 / 4
        for rows in rows_list:
            for mu in (0.15, 0.3):
                rms, mx, lam = friction_signal(r, rows, mu)
                lines.append(f"| E = {e_mod:.3g} Pa, d = {dia * 1e3:.2f} mm | {ea:.0f} | {rows} | {mu} | {rms:.1f} | "
                             f"{mx:.1f} | {lam:.3g} |")
    lines += ["", f"Detection level (1-dof chi-square at the first selection step): "
              f"{ber.detection_level(robot):.1f}. Total {(time.perf_counter() - t0) / 60:.1f} min.", ""]
    text = "\n".join(lines)
    print(text)
    with open(args.out, "w", encoding="utf-8") as fh:
        fh.write(text)


if __name__ == "__main__":
    main()
