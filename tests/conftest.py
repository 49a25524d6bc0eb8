"""Shared fixtures: the NumPy reference, test robots and their TOML texts.

The reference (the package ``python/cdsm/reference/``) is loaded straight from its files
so that its self-checks run even when the compiled extension (and hence the
``cdsm`` package) cannot be imported; tests that need the Rust core ask for
the ``cdsm`` fixture.
"""

from __future__ import annotations

import importlib.util
import math
import re
import sys
from dataclasses import dataclass
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

_REF = ROOT / "python" / "cdsm" / "reference"
_spec = importlib.util.spec_from_file_location(
    "cdsm_reference_standalone", _REF / "__init__.py", submodule_search_locations=[str(_REF)]
)
reference = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = reference  # dataclasses need the module registered
_spec.loader.exec_module(reference)

#: +-35 deg, the paper prototype's joint limit (rad).
LIM35 = math.radians(35.0)


@pytest.fixture(scope="session")
def ref():
    """The NumPy reference module."""
    return reference


@pytest.fixture(scope="session")
def cdsm():
    """The package under test (the Rust core through its Python wrapper)."""
    import cdsm as _cdsm

    return _cdsm


# --------------------------------------------------------------------------
# Robot descriptions
# --------------------------------------------------------------------------
@dataclass
class Linkage:
    """One ``[[linkage]]`` table (SI units)."""

    link_before: float
    link_after: float
    thickness: float
    hole_height: float
    mass: float = 0.03
    lower_tension: float = 0.1
    joint_limits: tuple = (-LIM35, LIM35)


def robot_toml(linkages, name="test robot", declare_n=True) -> str:
    """TOML text of a robot made of ``linkages`` (list of :class:`Linkage`)."""
    lines = [f'name = "{name}"']
    if declare_n:
        lines.append(f"n = {len(linkages)}")
    for lk in linkages:
        lines += [
            "",
            "[[linkage]]",
            f"link_before = {lk.link_before!r}   # m",
            f"link_after = {lk.link_after!r}   # m",
            f"thickness = {lk.thickness!r}   # m",
            f"hole_height = {lk.hole_height!r}   # m",
            f"mass = {lk.mass!r}   # kg",
            f"lower_tension = {lk.lower_tension!r}   # N",
            f"joint_limits = [{lk.joint_limits[0]!r}, {lk.joint_limits[1]!r}]   # rad",
        ]
    return "\n".join(lines) + "\n"


def reference_robot(linkages, **loads):
    """The reference :class:`Robot` of ``linkages`` (built without Rust): the robot
    file :func:`robot_toml` writes; ``loads``: ``gravity`` (in-plane, m/s^2) and the
    cable material (``routing_length``, ...)."""
    return reference.Robot.from_heights(
        [lk.link_before for lk in linkages],
        [lk.link_after for lk in linkages],
        [lk.thickness for lk in linkages],
        [lk.hole_height for lk in linkages],
        [lk.joint_limits for lk in linkages],
        mass=[lk.mass for lk in linkages],
        lower_tension=[lk.lower_tension for lk in linkages],
        **loads,
    )


PAPER_LINKAGES = [
    Linkage(0.033, 0.033, 0.010, 0.030),
    Linkage(0.033, 0.033, 0.010, 0.028),
    Linkage(0.033, 0.033, 0.010, 0.026),
]

N1_LINKAGES = [Linkage(0.030, 0.040, 0.012, 0.020)]

# Twelve distinct linkages; hole heights comparable to the links so that the
# fold of every upper cable (where dL/dtheta_k = 0) stays far outside +-35 deg.
N12_LINKAGES = [
    Linkage(
        link_before=0.015 + 0.001 * i,
        link_after=0.025 - 0.0008 * i,
        thickness=0.008 + 0.0003 * i,
        hole_height=0.025 - 0.0008 * i,
        joint_limits=(-LIM35, LIM35) if i % 3 else (-0.5, 0.6),
    )
    for i in range(12)
]


def hole_perturbation(n: int, scale: float, seed: int) -> np.ndarray:
    """Random per-hole offsets ``(2n, n+1, 2, 2)`` m on the used entries only."""
    rng = np.random.default_rng(seed)
    d = rng.normal(0.0, scale, (2 * n, n + 1, 2, 2))
    return d * reference.used_hole_mask(n)[..., None]


@dataclass
class RobotPair:
    """The same robot as ``cdsm.Robot`` (``rust``) and reference (``ref``)."""

    name: str
    rust: object
    ref: object


def make_pair(cdsm_mod, name: str) -> RobotPair:
    """Build one of the named test robots in both implementations."""
    if name == "paper":
        return RobotPair(name, cdsm_mod.Robot.paper(), reference.Robot.paper())
    if name == "n1":
        lk = N1_LINKAGES
    elif name == "n12":
        lk = N12_LINKAGES
    elif name in ("n2", "n4"):
        # the sizes the solvers compile with constant dimensions, besides 1 and 3
        lk = N12_LINKAGES[: int(name[1:])]
    elif name in ("paper_perturbed", "n12_perturbed"):
        base = make_pair(cdsm_mod, name.removesuffix("_perturbed"))
        d = hole_perturbation(base.ref.n, 3e-4, seed=7)
        holes = base.ref.planar.holes + d
        return RobotPair(name, base.rust.with_holes(holes), base.ref.with_planar_holes(holes))
    else:  # pragma: no cover
        raise KeyError(name)
    return RobotPair(name, cdsm_mod.Robot.from_toml_str(robot_toml(lk)), reference_robot(lk))


ROBOT_NAMES = ["paper", "n1", "n2", "n4", "n12", "paper_perturbed", "n12_perturbed"]


@pytest.fixture(params=ROBOT_NAMES)
def pair(request, cdsm) -> RobotPair:
    """Each test robot, in both implementations."""
    return make_pair(cdsm, request.param)


def random_theta(n: int, N: int = 500, seed: int = 0, lim: float = LIM35) -> np.ndarray:
    """Joint angles ``(N, n)`` rad, uniform in ``[-lim, lim]``, seeded."""
    return np.random.default_rng(seed).uniform(-lim, lim, (N, n))


# Table 3 of the seed paper: experiment points (m, m, rad) and theoretical
# deviations (mm) for a -1 mm error on cable 1 (upper cable of disk 1).
TABLE3_POINTS = np.array(
    [
        [0.228, 0.0, 0.0],
        [0.193, -0.097, 0.0],
        [0.196, -0.093, 0.0],
        [0.202, -0.083, 0.0],
        [0.202, -0.084, 0.0],
        [0.202, -0.085, 0.0],
        [0.225, -0.008, 0.0],
        [0.193, 0.097, 0.0],
        [0.196, 0.093, 0.0],
    ]
)
TABLE3_THEORETICAL_MM = np.array(
    [
        [-0.0415, 2.4299],
        [3.6630, 5.7446],
        [3.0294, 5.1021],
        [1.7697, 3.7680],
        [2.1139, 4.2225],
        [2.7725, 5.1599],
        [-0.6359, 0.6016],
        [-0.7987, 0.3510],
        [-0.7738, 0.1592],
    ]
)
TABLE3_DL = np.array([-1e-3, 0.0, 0.0])
#: The seed that selects the paper's theta_2 <= 0 branch at all nine points.
TABLE3_SEED = np.array([0.0, -1e-3, 0.0])


# --------------------------------------------------------------------------
# Report pages (issue 23): what every report opens with
# --------------------------------------------------------------------------
class _Body(HTMLParser):
    """The first element inside <body>, and every id and local link."""

    def __init__(self):
        super().__init__()
        self.in_body = False
        self.first = None
        self.ids, self.links = set(), set()

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "body":
            self.in_body = True
        elif self.in_body and self.first is None:
            self.first = (tag, a.get("id"))
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "a" and (a.get("href") or "").startswith("#"):
            self.links.add(a["href"][1:])


def check_report_page(out: Path) -> str:
    """Asserts of every report directory; returns the Markdown text."""
    html = (out / "report.html").read_text(encoding="utf-8")
    md = (out / "report.md").read_text(encoding="utf-8")
    check_report_text(html, md)
    for png in (out / "figures").glob("*.png"):
        from PIL import Image

        with Image.open(png) as im:
            assert im.size[0] <= 1144, (png.name, im.size)  # MAX_WIDTH_IN * DPI: not shrunk in the page
    return md


def check_report_text(html: str, md: str) -> None:
    """Asserts of every report's HTML and Markdown text: the body opens with
    the headline section, then the contents, whose links all have their
    anchors; the Markdown opens with the title and the headline's answers;
    no ``nan`` anywhere."""
    p = _Body()
    p.feed(html)
    assert p.first == ("section", "headline")
    assert "contents" in p.ids and p.links and p.links <= p.ids
    # the body opens with the section: nothing (not even text) before it
    assert re.search(r"<body><section id='headline'><h1>", html)
    # the headline comes before the contents, and the contents before the first other section
    assert html.index("id='headline'") < html.index("id='contents'") < html.index("<section id='", html.index(
        "id='contents'"))
    assert md.startswith("# ") and md.index("\n- ") < md.index("## Contents")
    for text in (html, md):
        assert not re.search(r"\bnan\b", text, re.IGNORECASE), re.search(r".{60}\bnan\b.{20}", text, re.I)


@pytest.fixture(scope="session")
def report_page():
    """:func:`check_report_page`: the checks of a written report directory."""
    return check_report_page


@pytest.fixture(scope="session")
def report_text():
    """:func:`check_report_text`: the checks of a report's text."""
    return check_report_text


def parameter_table(robot, values, std):
    """The diagnosis report's parameter rows ``{(effect, label): text}`` (in
    order) and its at-a-bound sentences for a fit of the effects ``values``
    ({effect: values}, SI) with standard deviations ``std`` (the same keys),
    made as the fit reports one."""
    from types import SimpleNamespace

    from cdsm.calibration import plant
    from cdsm.calibration.fit import Fit
    from cdsm.report import diagnosis as report

    effects = list(values)
    p = plant.params(robot, values)
    idx = np.concatenate([plant.effect_indices(robot, e) for e in effects])
    sd = np.concatenate([np.atleast_1d(np.asarray(std[e], float)) for e in effects])
    k = len(idx)
    fit = Fit(effects, p, plant.parameter_names(robot, idx), p[idx], sd, np.eye(k), np.ones(k), 1e-5, 1e-9, 10,
              0.0, 0.0, True, 3)
    d, cand = SimpleNamespace(prep=SimpleNamespace(robot=robot)), SimpleNamespace(fit=fit, effects=effects)
    rows = report.param_rows(d, cand)
    assert len({(e, lab) for e, lab, *_ in rows}) == len(rows), "a label repeats"
    return {(e, lab): txt for e, lab, txt, _, _ in rows}, report.bound_notes(d, cand)


@pytest.fixture(name="parameter_table", scope="session")
def parameter_table_fixture():
    """:func:`parameter_table`."""
    return parameter_table
