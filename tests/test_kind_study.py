"""The study's scenarios and CSV tables from the kind's data (issue 33, P5a):
one scenario builder and one row builder per table over
:attr:`cdsm.kinds.Kind.csv`, reproducing the columns each kind's files had
(the headers below are those of ``cdsm paper`` and ``cdsm paper --robot
two_universal`` as written before the change) and the scenarios' keys,
labels and errors."""

from __future__ import annotations

import numpy as np
import pytest

HEADERS = {
    "planar": {
        "scenarios.csv": "scenario,label,figure,protocol,configurations,solved,unreachable,no_solution_after_error,"
                         "rms_dxy_m,max_dxy_m,max_abs_dx_m,max_abs_dy_m,max_abs_dphi_rad,jump_points",
        "jumps.csv": "scenario,protocol,jump_points,jump_pairs,jumps_branch_switch,jumps_cable_fold,"
                     "jumps_near_singular,jumps_reach_boundary,jumps_steep",
        "montecarlo.csv": "protocol,theta1_rad,theta2_rad,theta3_rad,x_m,y_m,samples,failed,mean_dx_m,mean_dy_m,"
                          "mean_dphi_rad,mean_dxy_m,p95_dxy_m,max_dxy_m",
        "configurations.csv": "protocol,theta1_rad,theta2_rad,theta3_rad,x_m,y_m,phi_rad,reachable,singular_measure,"
                              "feasible,tension_cable1_n,tension_cable3_n,tension_cable5_n,worst_single_dxy_m,"
                              "worst_single_scenario,jump_point,mc_p95_dxy_m,mc_failed,mc_slack",
    },
    "spatial": {
        "scenarios.csv": "scenario,label,protocol,kind,cable,sign,error_m,configurations,solved,rms_dxyz_m,"
                         "max_dxyz_m,max_abs_dx_m,max_abs_dy_m,max_abs_dz_m,rms_rotation_rad,max_rotation_rad,"
                         "jump_points,jump_pairs,jump_points_near_singular",
        "jumps.csv": "scenario,protocol,jump_points,jump_pairs,jump_points_near_singular",
        "montecarlo.csv": "protocol,theta1_rad,theta2_rad,theta3_rad,theta4_rad,x_m,y_m,z_m,samples,failed,"
                          "mean_dx_m,mean_dy_m,mean_dz_m,mean_dxyz_m,p95_dxyz_m,max_dxyz_m,std_dxyz_m,"
                          "mean_rotation_rad,max_rotation_rad",
        "configurations.csv": "protocol,theta1_rad,theta2_rad,theta3_rad,theta4_rad,x_m,y_m,z_m,rx_rad,ry_rad,"
                              "rz_rad,reachable,singular_measure,feasible,tension_cable1_n,tension_cable2_n,"
                              "tension_cable5_n,tension_cable6_n,worst_single_dxyz_m,worst_single_scenario,"
                              "jump_point,mc_p95_dxyz_m,mc_failed,mc_slack",
    },
}


@pytest.fixture(scope="module")
def small_studies(cdsm):
    from cdsm import study

    grid = np.radians(np.array(np.meshgrid(*[np.arange(-30.0, 31.0, 15.0)] * 3, indexing="ij")).reshape(3, -1).T)
    return {"planar": study.run(cdsm.Robot.paper(), samples=20, grid=grid, progress=False),
            "spatial": study.run(cdsm.Robot.from_toml("two_universal"), samples=20, configurations=12,
                                 progress=False)}


@pytest.mark.parametrize("kind", ("planar", "spatial"))
def test_the_tables_have_the_columns_each_kind_had(cdsm, small_studies, kind):
    from cdsm.report.study import StudyReport

    tables = StudyReport(small_studies[kind]).tables()
    for name, header in HEADERS[kind].items():
        assert ",".join(tables[name][0]) == header, name


def test_the_headline_keeps_the_planar_names_of_cdsm_0_2(cdsm, small_studies):
    from cdsm.report.study import headline

    h = headline(small_studies["planar"])
    for p in ("attitude0", "joint"):
        assert h[f"mc_max_dxy_m_{p}"] == h[f"mc_max_m_{p}"]
        assert h[f"mc_max_p95_dxy_m_{p}"] == h[f"mc_max_p95_m_{p}"]
        assert h[f"worst_single_dxy_m_{p}"] == h[f"worst_single_m_{p}"]
    assert not any("dxy_m" in k for k in headline(small_studies["spatial"]))


def test_planar_scenarios_are_the_papers(cdsm):
    from cdsm import study

    sc = study.planar_scenarios(3)
    assert [s.key for s in sc] == ["cable1-", "cable1+", "cable3-", "cable3+", "cable5-", "cable5+",
                                   "disk1-", "disk1+", "disk2-", "disk2+", "disk3-", "disk3+"]
    assert sc[0].label == "-1 mm on cable 1" and sc[7].label == "+0.35 mm on disk 1's holes"
    assert [s.cable for s in sc] == [0, 0, 2, 2, 4, 4, 0, 0, 2, 2, 4, 4]
    np.testing.assert_array_equal(sc[2].dL, [0.0, -1e-3, 0.0])
    np.testing.assert_array_equal(sc[9].dh, [0.0, 0.35e-3, 0.0])
    np.testing.assert_array_equal(sc[9].dL, np.zeros(3))
    assert all(s.dholes is None for s in sc) and all(s.error == "hole" for s in sc[6:])
    # the same as the paper robot's own set
    own = study.scenario_set(cdsm.Robot.paper())
    assert [(s.key, s.label, s.cable, s.sign) for s in own] == [(s.key, s.label, s.cable, s.sign) for s in sc]


def test_spatial_scenarios_move_each_position_cable_and_its_holes(cdsm):
    from cdsm import study

    r = cdsm.Robot.from_toml("two_universal")
    sc = study.scenario_set(r)
    assert [s.key for s in sc[:2]] == ["cable1-", "cable1+"] and len(sc) == 24
    assert sc[1].label == "+1 mm on cable 1's length"
    radial = next(s for s in sc if s.key == "radial5+")
    assert radial.label == "+0.35 mm radially on cable 5's holes" and radial.dh is None
    # the move: 0.35 mm on each of cable 5's holes along its radius in the face plane, nothing elsewhere
    moves = np.split(radial.dholes, np.cumsum([3 * len(h) for h in r.holes])[:-1])
    for c, (m, h) in enumerate(zip(moves, r.holes)):
        m = m.reshape(-1, 3)
        if c != 4:
            assert not m.any()
            continue
        assert np.all(m[:, 0] == 0)
        r_hole = np.linalg.norm(h[:, 1:], axis=1)
        np.testing.assert_allclose(np.linalg.norm(m, axis=1), np.where(r_hole > 0, 0.35e-3, 0.0), rtol=1e-15)
        np.testing.assert_allclose(m[:, 1] * h[:, 2] - m[:, 2] * h[:, 1], 0.0, atol=1e-18)  # along the radius
    normal = next(s for s in sc if s.key == "normal6-")
    assert normal.label == "-0.35 mm along the disk normal on cable 6's holes"
    assert study.spatial_scenarios(r)[5].key == sc[5].key


def test_a_long_planar_arms_overview_names_its_own_errors(cdsm):
    """A planar arm with more single errors than thumbnails (serpentine8: 8
    pairs x 4) gets the matrix overview; it took a spatial arm's six columns
    (and crashed: 6 labels for 4 columns) and its |d(X, Y, Z)|."""
    from cdsm import study
    from cdsm.report import study_figures

    r = cdsm.Robot.from_toml("serpentine8")
    theta = np.random.default_rng(0).uniform(-0.3, 0.3, (12, r.n))
    st = study.run(r, samples=10, theta=theta, progress=False)
    fig = study_figures.overview_figure(st, st.main)
    title = fig._suptitle.get_text()
    assert "|d(X, Y)|" in title and "Z" not in title.split("—")[0]
    assert "columns: cable −, cable +, disk −, disk +" in title
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert labels == ["cable -", "cable +", "hole -", "hole +"]
    assert [t.get_text() for t in fig.axes[0].get_yticklabels()] == [str(c + 1) for c in r.position_cables]
