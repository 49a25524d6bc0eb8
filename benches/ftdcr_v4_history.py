"""FTDCR v4's recordings hold a history: at the rows where every servo is at
home (all within 0.25 mm of zero) the tip does not come back to one point;
it stays displaced towards where the arm was before. Printed, per file: the
home rows, the RMS distance of their tips from the mean home tip, and the
mean cosine between each home tip's offset and the direction of the
farthest tip of the excursion before it (same pattern; 0 would be no
memory, 1 a tip left exactly along the way it came back). Pure data, no
model: the reason a static model keeps millimetres at these rows
(README, "What the diagnosis of the real FTDCR v4 finds").

    python benches/ftdcr_v4_history.py
"""

from __future__ import annotations

import numpy as np

from cdsm.interop import opencr

HOME = 0.25e-3  # m


def main() -> None:
    for name in ("ftdcr_v4_train", "ftdcr_v4_val"):
        rec = opencr.read_sysid(opencr.packaged(name))
        home = np.flatnonzero(np.abs(rec.commands).max(axis=1) <= HOME)
        centre = rec.tip[home].mean(axis=0)
        spread = float(np.sqrt(np.mean(np.sum((rec.tip[home] - centre) ** 2, axis=1))))
        cosines = []
        for i in home:
            before = [j for j in range(i - 1, -1, -1) if rec.groups[j] == rec.groups[i]]
            if not before:
                continue
            far = max(before, key=lambda j: np.linalg.norm(rec.tip[j] - centre))
            a, b = rec.tip[i] - centre, rec.tip[far] - centre
            if np.linalg.norm(b) > 5e-3:  # an excursion of more than 5 mm
                cosines.append(float(a @ b / np.linalg.norm(a) / np.linalg.norm(b)))
        print(f"{name}: {len(home)} home rows, tips {spread * 1e3:.2f} mm RMS from their mean; offset towards the "
              f"excursion before: mean cosine {np.mean(cosines):+.2f} over {len(cosines)} rows")


if __name__ == "__main__":
    main()
