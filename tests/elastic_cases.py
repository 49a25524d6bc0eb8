"""Elastic arms shared by the tests of the NumPy reference (``test_reference_elastic.py``)
and of the core (``test_elastic.py``): a backbone rod of any number of stations, a mixed
arm with every term of the potential, a sprung planar arm, recorded FTDCR v4 commands and bad robot-file
edits.  SI units."""

from __future__ import annotations

import math
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

OPENCR = ROOT / "tests" / "data" / "opencr"
E_ROD, R_ROD = 50e9, 0.0005            # Pa, m: the FTDCR's backbone (a solid rod)
EI = E_ROD * math.pi * R_ROD**4 / 4.0  # N m^2


def rod_toml(links: int, length: float = 0.1, cables: str | None = None, joints: str = "z",
             gravity: str = "[0.0, 0.0, 0.0]", mass: float = 0.0, extra: str = "") -> str:
    """A straight rod along ``x``, ``links`` stations at ``(i - 1/2) l`` (``l = length /
    links``; OpenCR's layout: half links at both ends) each ending at a via plate at ``i l``,
    stiffness from ``[backbone]``; ``joints`` "z" (one bending joint per station) or "yz"
    (two).  ``cables`` the ``[[cables]]`` tables (default one central displacement cable:
    it only shortens as the rod bends, so it stays slack)."""
    half = length / links / 2.0
    axes = {"z": "{ axis = [0.0, 0.0, 1.0], offset = [%r, 0.0, 0.0] }" % half,
            "yz": "{ axis = [0.0, 1.0, 0.0], offset = [%r, 0.0, 0.0] }, { axis = [0.0, 0.0, 1.0] }" % half}
    out = [f'kind = "spatial"\nname = "rod"\ngravity = {gravity}\n{extra}',
           "[cable]\nyoungs_modulus = 1e30\ndiameter = 0.0002\n",
           "[base]\nradius = 0.006\n",
           f"[backbone]\nyoungs_modulus = {E_ROD!r}\nshear_modulus = 19e9\nradius = {R_ROD!r}\n"
           f"[[backbone.segments]]\nlength = {length!r}\nlinks = {links}\n"]
    for _ in range(links):
        out.append(f"[[linkage]]\njoints = [ {axes[joints]} ]\nlink_after = [{half!r}, 0.0, 0.0]\n"
                   f"thickness = 0.0\nradius = 0.006\nmass = {mass!r}\n")
    if cables is None:
        cables = f'[[cables]]\nend = {links}\nmode = "displacement"\nradius = 0.0\nangle = 0.0\n'
    out.append(cables)
    return "\n".join(out)


def mixed_text() -> str:
    """A 6-station rod with two bending joints per station, gravity on its disks, a
    position cable, a force cable and three displacement cables (one with pretension and
    a cap) at 120 degrees: every term of the potential."""
    cables = "".join(
        f'[[cables]]\nend = {end}\nmode = "displacement"\nradius = 0.004\nangle = {a!r}\nstiffness = 3000.0\n'
        f"pretension = {p!r}\n" + ("max_tension = 4.0\n" if p else "")
        for end, a, p in ((6, 0.0, 0.5), (6, 2.0944, 0.0), (3, 4.18879, 0.0)))
    cables += ('[[cables]]\nend = 6\nmode = "force"\ntension = 0.4\nradius = 0.003\nangle = 1.0\n'
               '[[cables]]\nend = 4\nmode = "position"\nradius = 0.005\nangle = 3.0\n')
    text = rod_toml(6, 0.09, cables, joints="yz", gravity="[0.0, -9.80665, -2.0]", mass=0.004)
    return text.replace("youngs_modulus = 1e30", "youngs_modulus = 2e9")


#: Train rows of the FTDCR v4 recordings (``../shared/opencr``; servo mm / 1000, tendons
#: k0..k8): a pulled tendon with eight paid out to -10 mm (rows 41, 112), one segment
#: bent (381), two segments bent far (732: the tip 160 mm off the axis; 1436).
FTDCR_ROWS = {
    41: [-0.009986216, -0.009955537, 0.002669127, -0.009986216, -0.009986216, -0.009986216, -0.009986216,
         -0.009986216, -0.009986216],
    112: [-0.009986216, -0.009955537, -0.009986216, -0.009986216, -0.009986216, -0.009986216, -0.009986216,
          0.002546408, -0.009986216],
    381: [0.0, 0.0, -6.1359e-05, 0.003942331, -0.000107379, -0.00401903, 0.004555924, -0.00242369, -0.002377671],
    732: [0.004801361, -0.002485049, -0.002500389, 0.007823303, -0.008145439, -1.534e-05, 0.004801361,
          -0.008344857, 0.004770681],
    1436: [-1.534e-05, -1.534e-05, 0.0, -0.003926991, 0.0, 0.003957671, -0.009341944, 0.004540584, 0.004525244],
}


def edit_text(old, new):
    def apply(text):
        assert old in text, old
        return text.replace(old, new, 1)
    return apply


def chain_edits(*edits):
    def apply(text):
        for e in edits:
            text = e(text)
        return text
    return apply


TENDON = ('[[cables]]\nend = 3\nmode = "displacement"\nradius = 0.004\nangle = 0.0\nstiffness = 5000.0\n'
          "pretension = 1.0\nmax_tension = 50.0\n")
JOINT = "{ axis = [0.0, 0.0, 1.0], offset = [0.005, 0.0, 0.0] }"
SPRUNG = "{ axis = [0.0, 0.0, 1.0], offset = [0.005, 0.0, 0.0], stiffness = 0.3, rest = 0.01, limits = [-1.0, 1.0] }"
NO_BACKBONE = edit_text("[backbone]\nyoungs_modulus = 50000000000.0\nshear_modulus = 19e9\nradius = 0.0005\n"
                        "[[backbone.segments]]\nlength = 0.03\nlinks = 3\n", "")


def sprung(joint):
    """Every joint sprung (no backbone), the first one ``joint``."""
    def apply(text):
        text = NO_BACKBONE(text).replace(JOINT, SPRUNG)
        return text.replace(SPRUNG, joint, 1)
    return apply


#: Bad values of the elastic fields and the field each error names (as the reference
#: names it: array elements from 1).
BAD_FIELDS = [
    (edit_text("links = 3", "links = 4"), "backbone.segments"),
    (edit_text("links = 3", "links = 0"), "backbone.segments[1].links"),
    (edit_text("links = 3", "links = 2.5"), "backbone.segments[1].links"),
    (edit_text("length = 0.03", "length = -0.03"), "backbone.segments[1].length"),
    (edit_text("radius = 0.0005", "radius = 0.0"), "backbone.radius"),
    (edit_text("youngs_modulus = 50000000000.0", "youngs_modulus = nan"), "backbone.youngs_modulus"),
    (edit_text("shear_modulus = 19e9\n", "shear_modulus = 19e9\nstiff = 1\n"), "backbone"),
    (edit_text("axis = [0.0, 0.0, 1.0]", "axis = [0.3, 0.0, 1.0]"), "linkage[1].joints[1].axis"),
    (chain_edits(edit_text("shear_modulus = 19e9\n", ""),
                 edit_text("axis = [0.0, 0.0, 1.0]", "axis = [1.0, 0.0, 0.0]")),
     "backbone.shear_modulus"),  # a torsion joint needs the rod's G
    (edit_text(JOINT, SPRUNG), "linkage[1].joints[1].stiffness"),  # a joint's stiffness beside a [backbone]
    (sprung(SPRUNG.replace("stiffness = 0.3", "stiffness = -0.3")), "linkage[1].joints[1].stiffness"),
    (sprung(SPRUNG.replace("rest = 0.01", "rest = 1.5")), "linkage[1].joints[1].rest"),
    (sprung(SPRUNG.replace("rest = 0.01", "rest = inf")), "linkage[1].joints[1].rest"),
    (NO_BACKBONE, "cables: 1 position or displacement cables for 3 joints"),
    (edit_text("stiffness = 5000.0", "stiffness = 0.0"), "cables[1].stiffness"),
    (edit_text("stiffness = 5000.0", "stiffness = -5000.0"), "cables[1].stiffness"),
    (edit_text("pretension = 1.0", "pretension = -1.0"), "cables[1].pretension"),
    (edit_text("pretension = 1.0", "pretension = nan"), "cables[1].pretension"),
    (edit_text("max_tension = 50.0", "max_tension = 0.5"), "cables[1].max_tension"),
    (edit_text('mode = "displacement"', 'mode = "position"'), "cables[1].stiffness"),
    (edit_text('mode = "displacement"', 'mode = "slack"'), "cables[1].mode"),
    (edit_text("thickness = 0.0", "thickness = -0.001"), "linkage[1].thickness"),
]


def planar_text() -> str:
    """The paper's planar arm with a spring on every joint and rest angles, upright under
    gravity."""
    base = (ROOT / "python" / "cdsm" / "robots" / "paper.toml").read_text(encoding="utf-8")
    parts = base.split("[[linkage]]\n")
    springs = ["stiffness = 0.05\nrest_angle = 0.02\n", "stiffness = 0.03\nrest_angle = -0.01\n",
               "stiffness = 0.02\nrest_angle = 0.0\n"]
    text = parts[0] + "".join("[[linkage]]\n" + s + p for s, p in zip(springs, parts[1:]))
    assert not re.search(r"(?m)^gravity", text)
    return "gravity = [-9.80665, 0.0]\n" + text
