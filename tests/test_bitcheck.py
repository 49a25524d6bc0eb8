"""The bit-identity harness of the refactors (``benches/bitcheck.py``) keeps
working: a small in-process dump compares equal to itself, and ``compare``
sees a one-ulp change, a signed zero, a missing entry point and a shape,
accepts what ``--allow`` names, and takes every NaN as equal to every NaN."""

import importlib.util
import io
import sys
from pathlib import Path

import numpy as np
import pytest

_PATH = Path(__file__).resolve().parents[1] / "benches" / "bitcheck.py"
_SPEC = importlib.util.spec_from_file_location("bitcheck", _PATH)
bitcheck = importlib.util.module_from_spec(_SPEC)
sys.modules[_SPEC.name] = bitcheck  # its dataclasses look their module up
_SPEC.loader.exec_module(bitcheck)

ONLY = ["_module/_cdsm.REASONS", "*/core.maps/fk/*", "*/core.maps/within_limits/rows", "*/core.solve_cables/auto/*",
        "*/core.ik/pose/lm/free/zero", "*/core.monte_carlo/d*/auto/slack", "*/core.plant/predict/backlash",
        "*/core.tensions/friction/*", "*/core.describe/to_toml", "*/api.statics/tensions/wrench",
        "*/py.deviation/dL"]


def _compare(a, b, allow=()):
    out = io.StringIO()
    return bitcheck.compare(a, b, allow, stream=out), out.getvalue()


def test_a_quick_dump_of_both_kinds_compares_equal_to_itself(tmp_path):
    path = tmp_path / "dump.npz"
    arrays = bitcheck.dump(path, quick=True, threads=1, robots=["paper", "two_universal"], only=ONLY)
    cases = {k.partition("#")[0] for k in arrays if not k.startswith("__")}
    for key in ("paper/core.maps/fk/rows", "two_universal/core.ik/pose/lm/free/zero",
                "paper/core.monte_carlo/dh/auto/slack", "two_universal/core.plant/predict/backlash",
                "paper/core.tensions/friction/release", "two_universal/py.deviation/dL"):
        assert key in cases
    assert not [k for k in arrays if k.endswith("!missing") or "!setup" in k]
    assert "paper/core.maps/fk/ragged#!error" in arrays  # an error path, stored as text
    assert arrays["paper/core.solve_cables/auto/free/zero#theta"].dtype == np.float64
    rc, text = _compare(path, path)
    assert rc == 0 and "IDENTICAL" in text


def _pair(tmp_path, b_changes):
    x = np.array([1.0, 0.0, np.nan, -2.5, 3.0])
    a = {"r/c/v#x": x, "r/c/v#n": np.array([1, 2], np.int64), "r/c/w#": np.array("text"),
         "__meta__#json": np.array("{}")}
    b = {k: v.copy() for k, v in a.items()}
    b_changes(b)
    np.savez(tmp_path / "a.npz", **a)
    np.savez(tmp_path / "b.npz", **b)
    return tmp_path / "a.npz", tmp_path / "b.npz"


def _set(key, i, value):
    def change(b):
        b[key][i] = value
    return change


def test_compare_sees_a_one_ulp_change(tmp_path):
    a, b = _pair(tmp_path, _set("r/c/v#x", 4, np.nextafter(3.0, 4.0)))
    rc, text = _compare(a, b)
    assert rc == 1 and "DIFFERENT" in text
    (d,) = bitcheck.differences(bitcheck.load(a), bitcheck.load(b))[0]
    assert (d.key, d.what, d.count, d.size) == ("r/c/v#x", "value", 1, 5)
    assert d.max_abs == pytest.approx(4.440892098500626e-16) and d.max_rel > 0


def test_compare_reports_a_signed_zero_apart(tmp_path):
    a, b = _pair(tmp_path, _set("r/c/v#x", 1, -0.0))
    rc, text = _compare(a, b)
    assert rc == 1 and "signed zero" in text
    (d,) = bitcheck.differences(bitcheck.load(a), bitcheck.load(b))[0]
    assert (d.what, d.count) == ("signed zero", 1)


@pytest.mark.parametrize("bits", [0x7FF8000000000001, 0xFFF8000000000000, 0x7FF0000000000123])
def test_every_nan_equals_every_nan(tmp_path, bits):
    nan = np.array([bits], np.uint64).view(np.float64)[0]
    assert np.isnan(nan)
    a, b = _pair(tmp_path, _set("r/c/v#x", 2, nan))
    assert _compare(a, b)[0] == 0


def test_compare_reports_missing_entry_points_shapes_and_text(tmp_path):
    def change(b):
        del b["r/c/v#x"], b["r/c/v#n"]
        b["r/c/v#!missing"] = np.array("AttributeError: no such method")
        b["r/c/w#"] = np.array("other")
        b["r/c/z#"] = np.zeros(2)

    a, b = _pair(tmp_path, change)
    diffs = {d.key: d.what for d in bitcheck.differences(bitcheck.load(a), bitcheck.load(b))[0]}
    assert diffs == {"r/c/v": "missing in B", "r/c/w#": "text", "r/c/z": "absent in A"}
    a, b = _pair(tmp_path, lambda b: b.__setitem__("r/c/v#n", np.array([1, 2, 3])))
    (d,) = bitcheck.differences(bitcheck.load(a), bitcheck.load(b))[0]
    assert d.what == "shape"


def test_allow_accepts_named_differences_with_their_reason(tmp_path):
    a, b = _pair(tmp_path, _set("r/c/v#x", 0, 1.5))
    allow = bitcheck.parse_allow(["r/c/*=S11 moves the spatial deviation to log_so3"])
    rc, text = _compare(a, b, allow)
    assert rc == 0 and "S11 moves the spatial deviation" in text
    assert _compare(a, b, bitcheck.parse_allow(["r/other/*=no"]))[0] == 1
