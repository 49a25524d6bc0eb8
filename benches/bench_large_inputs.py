"""Time and peak memory on large inputs: a measurement file of a million rows
and a 200-joint arm (issue 32, item 11).

    python benches/bench_large_inputs.py [--rows 1000000] [--dir DIR] [--diagnose] [--joints 200]

Steps, each in a fresh process (peak resident memory, ``ru_maxrss``, is the
process's own; the import of cdsm is in it, about 40 MB):

* ``read``: writes (once, into ``--dir``) a measurement file of ``--rows``
  absolute rows of the paper's prototype with a hidden hole-height error
  (a virtual prototype, seed 1, commands within ±30°, 10 µm noise; a
  ``point`` label column: 9 columns, 177 MB for a million rows) and reads
  it (:func:`cdsm.calibration.measurements.read_csv`);
* ``diagnose`` (with ``--diagnose``; hours for a million rows on two
  cores): ``cdsm diagnose FILE --quiet`` on it;
* ``friction``: the hysteresis part of ``cdsm paper`` on a generated planar
  arm of ``--joints`` joints (``benches/bench_scale.py``'s generator):
  :func:`cdsm.accuracy.statics.friction_map` at one configuration (what the
  study cycles for such an arm: :data:`~cdsm.accuracy.statics.CYCLE_WORK`).

Prints a Markdown table (wall time depends on what else the machine runs;
CPU time less). Run it with another ``PYTHONPATH`` to measure another
version of cdsm (the API used is the same since 0.2).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))

_READ = """
import resource, sys, time
from cdsm.calibration.measurements import read_csv
t = time.perf_counter()
m = read_csv(sys.argv[1], 3)
ru = resource.getrusage(resource.RUSAGE_SELF)
print(len(m), time.perf_counter() - t, ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024)
"""

_FRICTION = """
import resource, sys, time
import numpy as np
import cdsm
from cdsm.accuracy import statics
sys.path.insert(0, sys.argv[2])
from bench_scale import planar_toml
r = cdsm.Robot.from_toml_str(planar_toml(int(sys.argv[1])))
th = np.full((1, r.n), 0.01)
t = time.perf_counter()
fm = statics.friction_map(r, th)
ru = resource.getrusage(resource.RUSAGE_SELF)
print(int(fm.cycled.sum()) * len(r.position_cables), time.perf_counter() - t, ru.ru_utime + ru.ru_stime,
      ru.ru_maxrss / 1024)
"""


def write_file(path: str, rows: int) -> None:
    import numpy as np

    import cdsm
    from cdsm.calibration.plant import VirtualPrototype

    vp = VirtualPrototype(cdsm.Robot.paper(), {"hole_height": [3e-4, -2e-4, 2e-4]}, noise=10e-6, seed=1)
    th, dl = vp.random_commands(rows, reading="absolute")
    xy = vp.measure(th, dl, "absolute").measured
    vals = np.hstack([th, dl, xy])
    with open(path, "w") as fh:
        fh.write("point,theta_1,theta_2,theta_3,dL_1,dL_2,dL_3,x,y\n")
        for i, r in enumerate(vals):
            fh.write(f"p{i}," + ",".join(repr(float(v)) for v in r) + "\n")


def child(code: str, *args: str):
    out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, check=True)
    return [float(v) for v in out.stdout.split()]


def timed(argv):
    out = subprocess.run(["/usr/bin/time", "-f", "%e %U %S %M", *argv], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(out.stderr)
    wall, user, system, rss = (float(v) for v in out.stderr.strip().splitlines()[-1].split())
    return wall, user + system, rss / 1024


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--dir", default=tempfile.gettempdir())
    ap.add_argument("--diagnose", action="store_true")
    ap.add_argument("--joints", type=int, default=200)
    a = ap.parse_args()
    path = os.path.join(a.dir, f"measurements_{a.rows}.csv")
    if not os.path.exists(path):
        write_file(path, a.rows)
    table = ["| step | size | wall time | CPU time (with the import) | peak RSS |", "|---|---|---|---|---|"]
    n, t, cpu, rss = child(_READ, path)
    table.append(f"| read {os.path.basename(path)} | {int(n)} rows, {os.path.getsize(path) / 1e6:.0f} MB | "
                 f"{t:.1f} s | {cpu:.1f} s | {rss:.0f} MB |")
    if a.diagnose:
        t, cpu, rss = timed([sys.executable, "-m", "cdsm", "diagnose", path, "--quiet"])
        table.append(f"| cdsm diagnose | {a.rows} rows | {t:.0f} s | {cpu:.0f} s | {rss:.0f} MB |")
    n, t, cpu, rss = child(_FRICTION, str(a.joints), HERE)
    table.append(f"| friction map, {a.joints}-joint arm | {int(n)} cycles | {t:.0f} s | {cpu:.0f} s | {rss:.0f} MB |")
    print("\n".join(table))


if __name__ == "__main__":
    main()
