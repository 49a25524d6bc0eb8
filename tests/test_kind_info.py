"""The kind as data (issue 33 item 1): the facts that differ between the arm
kinds are the Rust core's (``rust/kinds.rs``: ``KindInfo``; ``model::Structure``),
exported by the binding (``_cdsm.kind_info``, ``CoreRobot.structure``), and the
Python names that held a second copy read them from there. The expected values
are written out as the code had them before they became data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROBOTS = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "robots"


def test_kind_info_holds_the_facts_of_each_kind(cdsm):
    from cdsm import _cdsm

    p, s = _cdsm.kind_info("planar"), _cdsm.kind_info("spatial")
    assert (p["name"], p["dim"], p["task"], p["rotation"]) == ("planar", 2, 3, "angle")
    assert (s["name"], s["dim"], s["task"], s["rotation"]) == ("spatial", 3, 6, "vector")
    assert p["task_axes"] == ["x", "y", "phi"] and p["task_units"] == ["m", "m", "rad"]
    assert s["task_axes"] == ["x", "y", "z", "rx", "ry", "rz"] and s["task_units"] == ["m"] * 3 + ["rad"] * 3
    assert p["quantities"] == ["dX", "dY", "dphi", "dXY"] and p["quantity_units"] == ["m", "m", "rad", "m"]
    assert s["quantities"] == ["dX", "dY", "dZ", "dXYZ", "rot"]
    assert s["quantity_units"] == ["m", "m", "m", "m", "rad"]
    assert (p["hole_grouping"], s["hole_grouping"]) == ("per_end_disk", "per_cable")
    assert len(p["quantities"]) == _cdsm.QUANTITIES
    with pytest.raises(cdsm.CdsmInputError, match=r'^`kind`: must be "planar" or "spatial", got "flat"$'):
        _cdsm.kind_info("flat")
    with pytest.raises(cdsm.CdsmInputError, match="`kind`"):
        cdsm.robot.kind_facts("flat")
    facts = cdsm.robot.kind_facts("planar")
    with pytest.raises(TypeError):
        facts["task"] = 4  # read-only: one copy, the core's


def test_python_names_read_the_cores_facts(cdsm):
    """The library, the Monte-Carlo quantities and the task widths as they were
    written in Python before (same names, same order: the order is the search
    order of the diagnosis and the columns of montecarlo.csv)."""
    from cdsm.accuracy import montecarlo
    from cdsm.calibration import plant

    assert plant.BLOCKS == ("actuation_scale", "cable_offset", "hole_height", "link_length", "cable_elasticity",
                            "hole_clearance", "frame_misalignment", "tip_offset", "backlash", "clearance_width",
                            "cable_friction")
    assert plant.EFFECTS == tuple(b for b in plant.BLOCKS if b != "clearance_width")
    assert plant.SPATIAL_EFFECTS == ("actuation_scale", "cable_offset", "hole_position", "link_length",
                                     "cable_elasticity", "frame_misalignment", "tip_offset", "backlash",
                                     "hole_clearance", "joint_axis", "cable_friction")
    assert montecarlo.QUANTITY_NAMES == ("dX", "dY", "dphi", "dXY")
    assert montecarlo.QUANTITY_UNITS == ("m", "m", "rad", "m")
    assert montecarlo.SPATIAL_QUANTITY_NAMES == ("dX", "dY", "dZ", "dXYZ", "rot")
    assert montecarlo.SPATIAL_QUANTITY_UNITS == ("m", "m", "m", "m", "rad")
    for path in sorted(ROBOTS.glob("*.toml")):
        r = cdsm.Robot.from_toml(path)
        facts = cdsm.robot.kind_facts(r.kind)
        assert tuple(plant.layout(r)) == facts["layout"], path.name
        assert plant.effects_of(r) == (plant.EFFECTS if r.kind == "planar" else plant.SPATIAL_EFFECTS)
        assert (r.task, plant.width(r), plant.dims(r)) == ((3, 3, 2) if r.kind == "planar" else (6, 6, 3))
        assert r.gravity.shape == ((2,) if r.kind == "planar" else (3,))


def test_structure_of_a_planar_arm_groups_holes_per_end_disk(cdsm):
    """Paper arm: cables in pairs (upper = position, lower = force, ending at
    disk 1, 2, 3), one coherent hole group per disk: the y coordinate of every
    hole of its two cables, + for the upper, - for the lower cable (the hole
    height of docs/model.md), which is Robot.hole_height_error's move."""
    r = cdsm.Robot.paper()
    st = r.core.structure()
    assert st["position"] == [0, 2, 4] and st["force"] == [1, 3, 5] and st["pairs"] is True
    flat = r.flat_holes
    assert len(st["hole_groups"]) == r.n
    for d, g in enumerate(st["hole_groups"]):
        assert g["coherent"] is True
        dh = np.zeros(r.n)
        dh[d] = 1e-3
        moved = flat.copy()
        moved[np.array(g["coords"])] += np.array(g["coefs"]) * dh[d]
        want = r.with_holes(r.hole_height_error(dh)).flat_holes
        np.testing.assert_array_equal(moved, want)


def test_structure_of_a_spatial_arm_groups_holes_per_cable(cdsm):
    r = cdsm.Robot.from_toml(ROBOTS / "two_universal.toml")
    st = r.core.structure()
    assert st["position"] == list(r.position_cables) and st["pairs"] is False
    assert sorted(st["position"] + st["force"]) == list(range(r.cables))
    groups = st["hole_groups"]
    assert len(groups) == r.cables and not any(g["coherent"] for g in groups)
    # every hole coordinate in exactly one group, cable by cable in order
    assert [i for g in groups for i in g["coords"]] == list(range(r.flat_holes.size))
    assert [len(g["coords"]) for g in groups] == [h.size for h in r.holes_by_cable()]


def test_with_loads_sets_any_arms_force_tensions_and_gravity(cdsm):
    """``with_loads`` is one path for both kinds: the force-controlled cables'
    tensions (file order) and gravity with the kind's dimension."""
    r = cdsm.Robot.from_toml(ROBOTS / "two_universal.toml")
    force = r.core.structure()["force"]
    t = 0.5 + np.arange(len(force))
    moved = r.with_loads(lower_tension=t, gravity=[0.0, 0.0, -9.81])
    np.testing.assert_array_equal(moved.cable_tensions[force], t)
    np.testing.assert_array_equal(moved.gravity, [0.0, 0.0, -9.81])
    np.testing.assert_array_equal(moved.flat_holes, r.flat_holes)
    with pytest.raises(cdsm.CdsmInputError, match="gravity"):
        r.with_loads(gravity=[0.0, -9.81])
