"""MJCF and URDF out (``Robot.to_mjcf``, ``Robot.to_urdf``, ``cdsm export``;
docs/interop.md), checked against the peers that read them.

MuJoCo (``mujoco``) computes the spatial tendons' lengths and Jacobian ``ten_J``
and the bias force ``qfrc_bias`` from the exported MJCF alone; pinocchio (``pin``)
computes the forward kinematics and the generalized gravity from the URDF. Both
are independent of cdsm: the tendon lengths and ``ten_J`` must equal cdsm's
``cable_lengths`` and ``cable_jacobian``, and at rest the joint torques balance,
``qfrc_bias + ten_J^T T = 0`` (MuJoCo) and ``g(q) + J^T T = 0`` (pinocchio), with
cdsm's statics tensions ``T`` (force cables at their set tension), to 1e-12
(relative to the largest term); the URDF's ``tip`` frame equals ``fk_matrix``.
Robots: the packaged planar ``paper`` and ``paper_vertical`` (gravity in the
plane), the spatial ``two_universal``, ``sjtu_snake`` and ``paper_spatial``, and a
spatial arm written here whose disks carry one, two and three joints with
offsets between them, oblique axes and off-axis ``link_after`` (the case where a
body's joints sit at different points). The peers are the optional ``interop``
extra; without them those tests skip (CI installs them). The structure checks
and the command run without them.

How it was checked that these tests can fail: with the MJCF hinges all at their
body's origin (anchors dropped), ``test_mujoco_tendons`` failed on the arm
written here (max |L_mujoco - L_cdsm| = 7.8e-4 m) and so did its statics
(relative residual 5.3e-2); with the URDF's inertial origin at the disk's face a
instead of its centre of mass, ``test_pinocchio_tip_and_gravity`` failed on the
four robots with gravity (relative residual 1.1e-2 to 9.2e-2).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest

PACKAGED = ["paper", "paper_vertical", "two_universal", "sjtu_snake", "paper_spatial"]
TOL = 1e-12

#: A spatial arm with 1, 2 and 3 joints per disk, offsets between a disk's
#: joints, oblique axes, off-axis link_after and centres of mass, a routing
#: length, and force cables (SI units).
OBLIQUE = """
kind = "spatial"
name = "oblique test arm"
gravity = [0.5, -3.0, -9.0]

[cable]
youngs_modulus = 1.8e11
diameter = 0.0003
routing_length = 0.4

[base]
radius = 0.03

[[linkage]]
joints = [{ axis = [0.1, 0.2, 1.0], offset = [0.012, 0.001, -0.002], limits = [-0.5, 0.6] }]
link_after = [0.01, 0.0015, -0.001]
thickness = 0.004
radius = 0.03
mass = 0.02
com = [0.002, 0.001, -0.0005]

[[linkage]]
joints = [
  { axis = [0.0, 0.6, 0.8], offset = [0.01, 0.002, -0.001], limits = [-0.4, 0.4] },
  { axis = [1.0, 0.2, 0.3], offset = [0.004, -0.001, 0.002], limits = [-0.7, 0.3] },
]
link_after = [0.006, 0.001, 0.0005]
thickness = 0.005
radius = 0.028
mass = 0.015
com = [0.0025, -0.001, 0.0007]

[[linkage]]
joints = [
  { axis = [0.0, 1.0, 0.1], offset = [0.008, 0.0, 0.0], limits = [-0.6, 0.6] },
  { axis = [0.0, -0.1, 1.0], offset = [0.003, 0.0005, 0.0], limits = [-0.6, 0.6] },
  { axis = [1.0, 0.0, 0.0], offset = [0.002, 0.0, -0.0005], limits = [-0.5, 0.5] },
]
link_after = [0.007, -0.0005, 0.0]
thickness = 0.003
radius = 0.025
mass = 0.01
com = [0.0015, 0.0, 0.0002]
"""


def _cables():
    out = []
    ends = [1, 1, 2, 2, 2, 3, 3, 3, 3, 2]
    for c, e in enumerate(ends):
        angle = 2.0 * np.pi * c / len(ends) + 0.2
        r = 0.02 + 0.0005 * (c % 3)
        mode = 'mode = "force"\ntension = 0.8' if c in (1, 4, 8, 9) else 'mode = "position"'
        out.append(f"\n[[cables]]\nend = {e}\n{mode}\nradius = {r}\nangle = {angle}\n")
    return "".join(out)


OBLIQUE += _cables()


def _robot(cdsm, name):
    if name == "oblique":
        return cdsm.Robot.from_toml_str(OBLIQUE)
    return cdsm.Robot.paper() if name == "paper" else cdsm.Robot.packaged(name)


ROBOTS = PACKAGED + ["oblique"]


def _theta(robot, N, seed):
    lim = robot.joint_limits
    return np.random.default_rng(seed).uniform(lim[:, 0], lim[:, 1], (N, robot.n))


def _tensions(robot, theta):
    """All cables' tensions at theta (N): the position cables' from cdsm's statics,
    the force cables' set tension; None where the statics have no answer."""
    T = robot.cable_tensions.copy()
    tp = robot.tensions(theta)
    if not np.all(np.isfinite(tp)):
        return None
    T[robot.position_cables] = tp
    return T


# --------------------------------------------------------------------------
# MuJoCo
# --------------------------------------------------------------------------
def _ten_j(mujoco, m, d):
    """ten_J as a dense (ntendon, nv) array (MuJoCo >= 3.3 stores it sparse)."""
    if d.ten_J.size == m.ntendon * m.nv:
        return np.array(d.ten_J).reshape(m.ntendon, m.nv)
    out = np.zeros((m.ntendon, m.nv))
    mujoco.mju_sparse2dense(out, d.ten_J, m.ten_J_rownnz, m.ten_J_rowadr, m.ten_J_colind)
    return out


@pytest.mark.parametrize("name", ROBOTS)
def test_mujoco_tendons(cdsm, name):
    mujoco = pytest.importorskip("mujoco")
    robot = _robot(cdsm, name)
    m = mujoco.MjModel.from_xml_string(robot.to_mjcf())
    d = mujoco.MjData(m)
    assert (m.nq, m.nv, m.njnt, m.ntendon) == (robot.n, robot.n, robot.n, robot.cables)
    np.testing.assert_array_equal(m.jnt_range, robot.joint_limits)
    assert m.jnt_limited.all()
    np.testing.assert_array_equal(m.body_mass[1:], robot.mass)
    np.testing.assert_allclose(m.opt.gravity, robot.core.gravity, rtol=0, atol=0)
    tip = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tip")
    el = ej = et = 0.0
    for q in _theta(robot, 20, 1):
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        el = max(el, np.abs(d.ten_length - robot.cable_lengths(q)).max())
        ej = max(ej, np.abs(_ten_j(mujoco, m, d) - robot.cable_jacobian(q)).max())
        et = max(et, np.abs(d.site_xpos[tip] - robot.fk_matrix(q)[:3, 3]).max())
    assert el <= TOL, f"max |L_mujoco - L_cdsm| = {el:.3e} m"
    assert ej <= TOL, f"max |ten_J - dL/dtheta| = {ej:.3e} m/rad"
    assert et <= TOL, f"max |tip site - fk| = {et:.3e} m"


@pytest.mark.parametrize("name", ROBOTS)
def test_mujoco_statics_and_actuators(cdsm, name):
    mujoco = pytest.importorskip("mujoco")
    robot = _robot(cdsm, name)
    m = mujoco.MjModel.from_xml_string(robot.to_mjcf())
    d = mujoco.MjData(m)
    pos = robot.position_cables
    force = [c for c in range(robot.cables) if c not in pos]
    ea = robot.axial_stiffness
    checked = 0
    worst = 0.0
    for q in _theta(robot, 20, 3):
        T = _tensions(robot, q)
        if T is None:
            continue
        d.qpos[:], d.qvel[:] = q, 0.0
        mujoco.mj_forward(m, d)
        J = _ten_j(mujoco, m, d)
        scale = max(np.abs(d.qfrc_bias).max(), np.abs(J.T * T).max())
        worst = max(worst, np.abs(d.qfrc_bias + J.T @ T).max() / scale)
        checked += 1
        # the actuators: a force cable pulls with its set tension whatever its control; a
        # position cable's force is kp (ctrl - L), clipped to [-E A, 0] (it only pulls)
        d.ctrl[:] = np.linspace(-1.0, 1.0, m.nu)
        mujoco.mj_forward(m, d)
        np.testing.assert_allclose(d.actuator_force[force], -robot.cable_tensions[force], rtol=1e-15, atol=0)
        kp = m.actuator_gainprm[pos, 0]
        want = np.clip(kp * (d.ctrl[pos] - d.ten_length[pos]), -ea, 0.0)
        np.testing.assert_allclose(d.actuator_force[pos], want, rtol=1e-12, atol=0)
    assert checked >= 10, f"only {checked} of 20 configurations have statics tensions"
    assert worst <= TOL, f"max |qfrc_bias + ten_J^T T| / scale = {worst:.3e}"
    # kp: the cable's axial stiffness over its straight length plus routing
    l0 = robot.cable_lengths(np.zeros(robot.n)) + robot.routing_length
    np.testing.assert_allclose(m.actuator_gainprm[pos, 0], ea / l0[pos], rtol=1e-15)


# --------------------------------------------------------------------------
# pinocchio
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ROBOTS)
def test_pinocchio_tip_and_gravity(cdsm, name):
    pin = pytest.importorskip("pinocchio")
    robot = _robot(cdsm, name)
    model = pin.buildModelFromXML(robot.to_urdf())
    data = model.createData()
    assert model.nq == robot.n and model.nv == robot.n
    assert [model.names[i] for i in range(1, model.njoints)] == [f"joint{j + 1}" for j in range(robot.n)]
    np.testing.assert_array_equal(model.lowerPositionLimit, robot.joint_limits[:, 0])
    np.testing.assert_array_equal(model.upperPositionLimit, robot.joint_limits[:, 1])
    assert model.existFrame("tip")
    tip = model.getFrameId("tip")
    model.gravity.linear = np.asarray(robot.core.gravity, dtype=float)
    et = eg = 0.0
    for q in _theta(robot, 20, 2):
        pin.framesForwardKinematics(model, data, q)
        et = max(et, np.abs(data.oMf[tip].homogeneous - robot.fk_matrix(q)).max())
        T = _tensions(robot, q)
        if T is None:
            continue
        g = pin.computeGeneralizedGravity(model, data, q)
        J = robot.cable_jacobian(q)
        eg = max(eg, np.abs(g + J.T @ T).max() / max(np.abs(g).max(), np.abs(J.T * T).max()))
    assert et <= TOL, f"max |tip - fk_matrix| = {et:.3e}"
    assert eg <= TOL, f"max |g + J^T T| / scale = {eg:.3e}"
    assert abs(sum(i.mass for i in model.inertias) - robot.mass.sum()) <= 1e-15


# --------------------------------------------------------------------------
# Structure (no peer needed)
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["paper", "oblique", "two_universal"])
def test_mjcf_structure(cdsm, name):
    robot = _robot(cdsm, name)
    root = ET.fromstring(robot.to_mjcf())
    assert root.tag == "mujoco" and root.get("model") == robot.name
    joints = root.findall(".//worldbody//joint")
    assert [j.get("name") for j in joints] == [f"joint{j + 1}" for j in range(robot.n)]
    assert all(j.get("type") == "hinge" for j in joints)
    assert len(root.findall(".//worldbody//body")) == len(robot.mass)
    holes = sum(2 * e + 1 for e in robot.cable_ends)
    assert len(root.findall(".//worldbody//site")) == holes + 1   # and the tip
    tendons = root.findall("./tendon/spatial")
    assert [t.get("name") for t in tendons] == [f"cable{c + 1}" for c in range(robot.cables)]
    assert [len(t) for t in tendons] == [2 * e + 1 for e in robot.cable_ends]
    acts = list(root.find("actuator"))
    pos = set(robot.position_cables)
    assert [a.tag for a in acts] == ["position" if c in pos else "general" for c in range(robot.cables)]
    for c, a in enumerate(acts):
        if c not in pos:
            assert float(a.get("biasprm").split()[0]) == -robot.cable_tensions[c]


def test_urdf_structure(cdsm):
    robot = _robot(cdsm, "oblique")
    root = ET.fromstring(robot.to_urdf())
    joints = root.findall("joint")
    assert [j.get("type") for j in joints] == ["revolute"] * robot.n + ["fixed"]
    assert joints[-1].find("child").get("link") == "tip"
    names = [j.find("child").get("link") for j in joints[:-1]]
    assert names == ["disk1", "disk2_joint2", "disk2", "disk3_joint4", "disk3_joint5", "disk3"]
    masses = [float(m.get("value")) for m in root.findall("link/inertial/mass")]
    np.testing.assert_array_equal(masses, robot.mass)


def test_massless_disk_is_refused_by_mjcf(cdsm):
    text = OBLIQUE.replace("mass = 0.015\n", "")
    robot = cdsm.Robot.from_toml_str(text)
    with pytest.raises(cdsm.CdsmInputError, match=r"disk 2 has no mass .*MuJoCo rejects a moving body"):
        robot.to_mjcf()
    root = ET.fromstring(robot.to_urdf())   # URDF takes it: no inertial on that link
    assert root.find("link[@name='disk2']/inertial") is None


def _with(text, **linkage1):
    """OBLIQUE with fields of its second linkage (disk 2: mass 0.015 kg, radius 0.028 m) replaced."""
    for key, value in linkage1.items():
        old = {"mass": "mass = 0.015\n", "radius": "radius = 0.028\n", "thickness": "thickness = 0.005\n"}[key]
        assert text.count(old) == 1
        text = text.replace(old, f"{key} = {value!r}\n")
    return text


def _refit(text, mass, radius, thickness):
    """The MJCF ``text`` with disk 2's inertial as cdsm writes it for ``mass`` (kg): what the exporter
    wrote before it checked the inertials."""
    from cdsm.interop.chain import cylinder_inertia, fmt

    root = ET.fromstring(text)
    inertial = root.find(".//body[@name='disk2']/inertial")
    inertial.set("mass", fmt(mass))
    inertial.set("diaginertia", fmt(*cylinder_inertia(mass, radius, thickness)))
    return ET.tostring(root, encoding="unicode")


def _loads(mujoco, text):
    try:
        mujoco.MjModel.from_xml_string(text)
    except ValueError as exc:
        assert "mass and inertia of moving bodies must be larger than mjMINVAL" in str(exc), exc
        return False
    return True


def test_mujocos_smallest_mass_and_inertia(cdsm):
    """to_mjcf refuses a disk whose mass or a moment of inertia is below
    MuJoCo's mjMINVAL, and exactly those: at the boundary (bisected over the
    doubles) the smallest mass cdsm exports loads in MuJoCo, and the next
    smaller one, which cdsm refuses naming the disk and the field, MuJoCo
    refuses too. Two boundaries: a disk of radius 0.028 m, where the inertia
    Iyy binds (1e-12 kg passed the old check, MuJoCo refused the file), and
    one of radius 10 m, where the mass does (at 1e-15 kg exactly)."""
    mujoco = pytest.importorskip("mujoco")
    from cdsm.interop.mjcf import MJMINVAL

    assert MJMINVAL == mujoco.mjMINVAL

    def exports(mass, radius):
        try:
            return cdsm.Robot.from_toml_str(_with(OBLIQUE, mass=mass, radius=radius)).to_mjcf()
        except cdsm.CdsmInputError:
            return None

    for radius, field in ((0.028, "Iyy"), (10.0, "mass")):
        lo, hi = 1e-20, 1e-9          # refused, taken
        assert exports(lo, radius) is None and exports(hi, radius) is not None
        while np.nextafter(lo, hi) < hi:
            mid = float(np.sqrt(lo * hi)) if hi / lo > 1.5 else (lo + hi) / 2.0
            mid = min(max(mid, np.nextafter(lo, hi)), np.nextafter(hi, lo))
            if exports(mid, radius) is None:
                lo = mid
            else:
                hi = mid
        text = exports(hi, radius)
        assert _loads(mujoco, text), f"radius {radius}: mass {hi!r} kg exported and MuJoCo refused it"
        with pytest.raises(cdsm.CdsmInputError, match=rf"disk 2 \(body 'disk2'\).*{field}.*below 1e-15"):
            cdsm.Robot.from_toml_str(_with(OBLIQUE, mass=lo, radius=radius)).to_mjcf()
        assert not _loads(mujoco, _refit(text, lo, radius, 0.005)), \
            f"radius {radius}: mass {lo!r} kg refused by cdsm, taken by MuJoCo"
        if field == "mass":
            assert hi == MJMINVAL
    with pytest.raises(cdsm.CdsmInputError, match=r"disk 2 \(body 'disk2'\): inertia Ixx = .*, Iyy = .*, Izz = .* "
                                                 r"kg m\^2 \(mass 1e-12 kg.* are below 1e-15"):
        cdsm.Robot.from_toml_str(_with(OBLIQUE, mass=1e-12)).to_mjcf()


def test_thin_disks_load_in_mujoco(cdsm):
    """A disk 1e-9 m thin (MuJoCo refuses a geom ``fromto`` shorter than
    1e-7 m; the display cylinder is placed by its centre and axis), and a
    wide thin disk whose cylinder inertia m (3 r^2 + t^2) / 12 rounds below
    Ixx / 2 (MuJoCo refuses Iyy + Izz < Ixx): both load."""
    mujoco = pytest.importorskip("mujoco")
    from cdsm.interop.chain import cylinder_inertia

    m, r, t = 0.042, 20.76, 2e-7
    old = m * (3.0 * r * r + t * t) / 12.0
    assert old + old < m * r * r / 2.0            # the old formula breaks the triangle inequality here
    ix, iy, iz = cylinder_inertia(m, r, t)
    assert iy + iz >= ix and ix + iy >= iz and iy == iz
    for text in (_with(OBLIQUE, thickness=1e-9), _with(OBLIQUE, mass=m, radius=r, thickness=t)):
        robot = cdsm.Robot.from_toml_str(text)
        model = mujoco.MjModel.from_xml_string(robot.to_mjcf())
        np.testing.assert_array_equal(model.body_mass[1:], robot.mass)
    # the display geom spans the disk, face a to face b
    robot = cdsm.Robot.from_toml_str(OBLIQUE)
    model = mujoco.MjModel.from_xml_string(robot.to_mjcf())
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    g = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "disk3")
    ends = data.geom_xpos[g] + np.outer([-1.0, 1.0], data.geom_xmat[g].reshape(3, 3)[:, 2] * model.geom_size[g, 1])
    np.testing.assert_allclose(ends[1], robot.fk_matrix(np.zeros(robot.n))[:3, 3], rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.linalg.norm(ends[1] - ends[0]), 0.003, rtol=1e-12)


def test_cylinder_inertia_keeps_the_triangle_inequality():
    """Over random thin and thick disks the moments written satisfy MuJoCo's
    Iyy + Izz >= Ixx exactly in floating point (the old formula failed on
    about one thin disk in ten), and equal the solid cylinder's to rounding."""
    from cdsm.interop.chain import cylinder_inertia

    rng = np.random.default_rng(0)
    for _ in range(20000):
        m, r = 10 ** rng.uniform(-6, 3), 10 ** rng.uniform(-4, 2)
        t = r * 10 ** rng.uniform(-12, 1)
        ix, iy, iz = cylinder_inertia(m, r, t)
        assert iy + iz >= ix and ix + iy >= iz and iy == iz
        assert abs(iy - m * (3 * r * r + t * t) / 12) <= 1e-15 * iy and ix == m * r * r / 2


class _Renamed:
    """A robot whose ``name`` is any string (the readers refuse the names
    these tests give), for the exporters' own check."""

    def __init__(self, robot, name):
        self.robot, self.name = robot, name

    def __getattr__(self, attr):
        return getattr(self.robot, attr)


@pytest.mark.parametrize("bad", ["\x00", "\x01", "\x1b", "\ufffe", "\uffff", "\ud800"])
def test_exports_are_well_formed_or_refused(cdsm, bad):
    """The exporters parse what they wrote back: a name XML forbids (which
    no robot reader lets through any more) is an error, not a text that no
    XML reader takes."""
    from cdsm.interop.mjcf import to_mjcf
    from cdsm.interop.urdf import to_urdf

    real = cdsm.Robot.from_toml_str(OBLIQUE)
    for export, what in ((to_mjcf, "to_mjcf"), (to_urdf, "to_urdf")):
        with pytest.raises(cdsm.CdsmInputError, match=rf"{what}: the XML of robot .* would not be well-formed"):
            export(_Renamed(real, f"arm {bad}"))
    fine = _Renamed(real, "arm \t\n\x7f \U0001F4AA")
    for xml in (to_mjcf(fine), to_urdf(fine)):
        root = ET.fromstring(xml)
        assert root.get("model", root.get("name")) == fine.name


def test_names_are_escaped(cdsm):
    text = OBLIQUE.replace('name = "oblique test arm"', 'name = "a <b> & \\"c\\" -- d"')
    robot = cdsm.Robot.from_toml_str(text)
    for xml in (robot.to_mjcf(), robot.to_urdf()):
        root = ET.fromstring(xml)
        assert root.get("model", root.get("name")) == 'a <b> & "c" -- d'


# --------------------------------------------------------------------------
# cdsm export
# --------------------------------------------------------------------------
def _cli(capsys, monkeypatch, tmp_path, *args):
    """``cdsm export ARGS`` run in ``tmp_path``: (exit status, stdout, stderr)."""
    from cdsm.cli import main

    monkeypatch.chdir(tmp_path)
    rc = main(["export", *args])
    out, err = capsys.readouterr()
    return rc, out, err


def test_export_command(cdsm, tmp_path, capsys, monkeypatch):
    rc, out, err = _cli(capsys, monkeypatch, tmp_path, "--robot", "two_universal", "--mjcf", "a.xml", "--urdf",
                        "a.urdf")
    assert rc == 0, err
    assert "two universal joints" in out and "a.xml" in out and "a.urdf" in out
    robot = cdsm.Robot.packaged("two_universal")
    assert (tmp_path / "a.xml").read_text(encoding="utf-8") == robot.to_mjcf()
    assert (tmp_path / "a.urdf").read_text(encoding="utf-8") == robot.to_urdf()
    rc, out, err = _cli(capsys, monkeypatch, tmp_path, "--urdf", "p.urdf")   # default: the paper's prototype
    assert rc == 0, err
    assert (tmp_path / "p.urdf").read_text(encoding="utf-8") == cdsm.Robot.paper().to_urdf()
    assert not (tmp_path / "p.xml").exists()


def test_export_errors(tmp_path, capsys, monkeypatch):
    def run(*args):
        rc, _, err = _cli(capsys, monkeypatch, tmp_path, *args)
        assert rc == 2, err
        return err

    assert "give --mjcf OUT.xml and/or --urdf OUT.urdf" in run("--robot", "two_universal")
    assert "--mjcf 'no/such/dir/a.xml': directory" in run("--mjcf", "no/such/dir/a.xml")
    assert "both name" in run("--mjcf", "x.xml", "--urdf", "x.xml")
    assert "no packaged robot has that name" in run("--robot", "nope", "--urdf", "n.urdf")
    (tmp_path / "massless.toml").write_text(OBLIQUE.replace("mass = 0.015\n", ""))
    assert "disk 2 has no mass" in run("--robot", "massless.toml", "--mjcf", "m.xml", "--urdf", "m.urdf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["massless.toml"]   # nothing written, no temporary
    (tmp_path / "tiny.toml").write_text(_with(OBLIQUE, mass=1e-12))
    assert "disk 2 (body 'disk2'): inertia Ixx" in run("--robot", "tiny.toml", "--mjcf", "t.xml", "--urdf", "t.urdf")
    (tmp_path / "named.toml").write_text(OBLIQUE.replace('"oblique test arm"', '"arm \\u001b[2J"'))
    err = run("--robot", "named.toml", "--mjcf", "n.xml", "--urdf", "n.urdf")
    assert "`name`" in err and "U+001B" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["massless.toml", "named.toml", "tiny.toml"]
