"""The spatial statics' quadratic program (``docs/spatial.md``, "Statics"):
minimum-norm position-cable tensions ``T`` with ``M_p T = b`` and every
``T >= min_tension``, or the verdict "slack" when none exists.

Robots: ``two_universal`` with every force cable made position-controlled
(8 position cables, 4 joints: a 4-dimensional set of balancing tensions, so
the floor constraints decide; antagonistic pairs at every joint, so a
balance above any floor exists everywhere), and the same without the 270 deg
cables under a tip moment (6 cables: both verdicts occur). On 300 random
configurations of the joint box at floors 0 and 0.3 N the Rust core
(``SpatialRobot.tensions`` / ``feasible``) matches the NumPy reference
(``cdsm.reference.statics``, which enumerates all 2^m active sets):
the same verdicts, the tensions to 1e-9 relative. A higher floor can only
shrink the feasible set: feasible at 0.3 N implies feasible at 0 N.

The active set before the Lawson–Hanson method (pin the most negative
tension, give up when the free cables cannot close the balance) called 24
(floor 0) and 181 (floor 0.3 N) of the eight-cable configurations slack.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import ROOT, reference

FLOORS = (0.0, 0.3)  # N
N_CONFIGS = 300
TIP_MOMENT = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.01])  # N, N m


def all_position_text() -> str:
    """``two_universal.toml`` with each ``mode = "force"`` cable made
    ``mode = "position"`` and its ``tension`` line dropped."""
    text = (ROOT / "python" / "cdsm" / "robots" / "two_universal.toml").read_text(encoding="utf-8")
    out, n = re.subn(r'mode = "force"\s*\n\s*tension = [^\n]*\n', 'mode = "position"\n', text)
    assert n == 4 and "force" not in re.sub(r"#[^\n]*", "", out)
    return out


def six_cable_text() -> str:
    """:func:`all_position_text` without the two cables at 270 deg."""
    head, *cables = all_position_text().split("[[cables]]")
    kept = [c for c in cables if "angle = 4.71238898038469" not in c]
    assert len(kept) == 6
    return head + "".join("[[cables]]" + c for c in kept)


VARIANTS = {
    "eight": (all_position_text, None),
    "six": (six_cable_text, TIP_MOMENT),
}


@pytest.fixture(params=sorted(VARIANTS), scope="module")
def case(request, cdsm):
    """``(name, rust robot, reference robot, tip wrench, theta (300, 4))``."""
    make, wrench = VARIANTS[request.param]
    text = make()
    rust, ref = cdsm.Robot.from_toml_str(text), reference.read_robot(text)
    m = 8 if request.param == "eight" else 6
    assert len(rust.position_cables) == m and len(reference.position_cables(ref)) == m and rust.n == 4
    lo, hi = ref.joint_limits[:, 0], ref.joint_limits[:, 1]
    theta = np.random.default_rng(20240611).uniform(lo, hi, (N_CONFIGS, ref.n))
    return request.param, rust, ref, wrench, theta


@pytest.mark.parametrize("floor", FLOORS)
def test_tensions_equal_the_enumerated_optimum(case, floor):
    name, rust, ref, wrench, theta = case
    T_ref, ok_ref = reference.feasible_tensions(ref, theta, min_tension=floor, tip_wrench=wrench)
    T = np.asarray(rust.tensions(theta, min_tension=floor, tip_wrench=wrench))
    ok = np.asarray(rust.feasible(theta, min_tension=floor, tip_wrench=wrench))
    if name == "eight":
        assert ok_ref.all()
    else:  # both verdicts occur
        assert 0 < ok_ref.sum() < len(theta)
    bad = np.flatnonzero(ok != ok_ref)
    assert bad.size == 0, f"{bad.size} verdicts differ at floor {floor} N (rows {bad[:10]})"
    np.testing.assert_array_equal(np.isnan(T).any(axis=1), ~ok)
    assert np.isnan(T[~ok]).all()
    np.testing.assert_allclose(T[ok], T_ref[ok], rtol=1e-9, atol=1e-9 * np.abs(T_ref[ok]).max())
    assert np.all(T[ok] >= floor)  # at or above the floor exactly, not to a tolerance
    # the floor binds somewhere: the active set matters
    assert np.any(T[ok] == floor)


def test_a_higher_floor_only_shrinks_the_feasible_set(case):
    _, rust, _, wrench, theta = case
    low, high = (np.asarray(rust.feasible(theta, min_tension=f, tip_wrench=wrench)) for f in FLOORS)
    assert high.sum() > 0
    wrong = np.flatnonzero(high & ~low)
    assert wrong.size == 0, f"feasible at {FLOORS[1]} N but slack at {FLOORS[0]} N: rows {wrong[:10]}"


def test_the_balance_holds_at_the_answer(case):
    """M_p T = -(tau + 0) to 1e-10 of the moments' scale (no force cables)."""
    _, rust, ref, wrench, theta = case
    M = reference.moment_matrices(ref, theta)[:, :, reference.position_cables(ref)]
    tau = reference.external_moments(ref, theta, wrench)
    for floor in FLOORS:
        T = np.asarray(rust.tensions(theta, min_tension=floor, tip_wrench=wrench))
        ok = ~np.isnan(T).any(axis=1)
        res = np.einsum("nij,nj->ni", M[ok], T[ok]) + tau[ok]
        scale = np.abs(M[ok]).max(axis=(1, 2)) * np.abs(T[ok]).max(axis=1) + np.abs(tau[ok]).max(axis=1)
        assert np.all(np.abs(res).max(axis=1) <= 1e-10 * scale)
