"""``cdsm.Robot.from_caspr``: CASPR's multi-link models in (docs/interop.md).

The imported robot's cable lengths (Rust core) are checked against CASPR's model
evaluated independently from the same XML files (``tests/caspr_reference.py``,
written from CASPR's ``src/Model`` code, not from the importer) at random
configurations within the joint limits, to 1e-12 m: the SJTU snake CASPR ships
(24 joints, 36 cables; ``tests/data/caspr/SJTUSnake``, BSD-3-Clause) and a small
model written here that uses every revolute joint type (``R_AXIS``, ``U_YZ``,
``U_XY``, ``R_X``), off-axis parent locations, attachments relative to the centre
of mass and both attachment orders, with its links along each axis direction.
The snake imports as the packaged ``sjtu_snake`` (same kinematics and cable
lengths). What cannot be represented is an error naming it.

How it was checked that these tests can fail: with the importer's face-b holes
written without subtracting the thickness, ``test_snake_lengths_equal_caspr``
failed (max |L_import - L_CASPR| = 1.9 m) and so did
``test_model_lengths_equal_caspr`` (0.24 to 0.26 m); with ``U_YZ``'s two axes
swapped, ``test_model_lengths_equal_caspr`` failed on every direction (1.2e-2 to
2.5e-2 m).
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np
import pytest

import caspr_reference as caspr
from conftest import ROOT

SNAKE = ROOT / "tests" / "data" / "caspr" / "SJTUSnake"
BODIES = SNAKE / "SJTUSnake_bodies.xml"
CABLES = SNAKE / "SJTUSnake_cables.xml"
SET_ID = "base to link cable connection"
OTHER_SET = "link to link cable connection"
TOL = 1e-12  # m


def _quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return fn(*args, **kw)


@pytest.fixture(scope="module")
def snake(cdsm):
    return _quiet(cdsm.Robot.from_caspr, BODIES, CABLES)


def _theta(limits, N, seed):
    return np.random.default_rng(seed).uniform(limits[:, 0], limits[:, 1], (N, len(limits)))


# --------------------------------------------------------------------------
# The SJTU snake
# --------------------------------------------------------------------------
def test_snake_lengths_equal_caspr(snake):
    links = caspr.bodies(BODIES)
    set_id, cables = caspr.cables(CABLES)
    assert set_id == SET_ID
    assert snake.kind == "spatial" and (snake.n, snake.cables) == (24, 36)
    assert snake.position_cables == list(range(36))               # all position-controlled
    np.testing.assert_array_equal(snake.joint_limits, caspr.limits(links))   # CASPR's order
    theta = _theta(snake.joint_limits, 200, 24)
    mine, theirs = snake.cable_lengths(theta), caspr.lengths(links, cables, theta)
    err = np.abs(mine - theirs).max()
    assert err <= TOL, f"max |L_import - L_CASPR| = {err:.3e} m"
    assert np.ptp(theirs, axis=0).min() > 1e-3                      # the arm does bend
    # the cables in the file's order: cable i ends at the link its first attachment names
    assert snake.cable_ends == [att[0][0] for _, att in cables]


def test_snake_equals_packaged(snake, cdsm):
    packaged = cdsm.Robot.packaged("sjtu_snake")
    theta = _theta(packaged.joint_limits, 100, 7)
    assert np.abs(snake.cable_lengths(theta) - packaged.cable_lengths(theta)).max() <= TOL
    assert np.abs(snake.cable_jacobian(theta) - packaged.cable_jacobian(theta)).max() <= TOL
    assert np.abs(snake.fk_matrix(theta) - packaged.fk_matrix(theta)).max() <= TOL
    for attr in ("axes", "offsets", "joint_limits", "disk_link_after", "disk_thickness", "mass", "com"):
        np.testing.assert_allclose(getattr(snake, attr), getattr(packaged, attr), rtol=0, atol=1e-15,
                                   err_msg=attr)
    assert snake.joint_disks == packaged.joint_disks
    assert snake.cable_ends == packaged.cable_ends
    assert snake.position_cables == packaged.position_cables
    np.testing.assert_allclose(snake.flat_holes, packaged.flat_holes, rtol=0, atol=1e-15)
    # gravity: CASPR's 9.81 m/s^2 along -z; the packaged file uses the standard 9.80665
    np.testing.assert_array_equal(snake.gravity, [0.0, 0.0, -9.81])
    np.testing.assert_array_equal(packaged.gravity, [0.0, 0.0, -9.80665])


def test_snake_warning_and_sets(cdsm):
    with pytest.warns(UserWarning) as rec:
        default = cdsm.Robot.from_caspr(BODIES, CABLES)
    msg = " ".join(str(w.message) for w in rec)
    for part in ("inertia tensors of 12 links", "q_initial", "force_min, force_max) of 36 cables", repr(OTHER_SET)):
        assert part in msg, msg
    named = _quiet(cdsm.Robot.from_caspr, BODIES, CABLES, cable_set=SET_ID)
    assert named.to_toml() == default.to_toml()
    assert default.name == f"SJTUSnake (CASPR, cable set {SET_ID})"


def test_snake_errors(cdsm, tmp_path):
    with pytest.raises(cdsm.CdsmInputError, match=r"no cable set 'nope'.*'link to link cable connection', "
                                                 r"'base to link cable connection'"):
        _quiet(cdsm.Robot.from_caspr, BODIES, CABLES, cable_set="nope")
    # CASPR's other set runs link to link: its second cable starts at link 1
    with pytest.raises(cdsm.CdsmInputError, match=r"cable 2 \('cable 1 \(link 2\)'\): does not start at the base "
                                                 r"\(its attachments run on links 2 -> 1\)"):
        _quiet(cdsm.Robot.from_caspr, BODIES, CABLES, cable_set=OTHER_SET)
    text = BODIES.read_text()
    cases = [
        (text.replace('type="U_XZ"', 'type="S_EULER_XYZ"', 1),
         r"link 1 \('link 1'\): joint type 'S_EULER_XYZ' cannot be represented"),
        (text.replace('type="U_XZ"', 'type="P_X"', 1), r"joint type 'P_X' cannot be represented"),
        (text.replace('<joint type="U_XZ"', '<joint type="U_XZ" actuated="true"', 1),
         r"link 1 .*the joint is actuated"),
        (re.sub(r"(<link_rigid num=\"3\".*?<num>)2(</num>)", r"\g<1>1\g<2>", text, count=1, flags=re.S),
         r"link 3 .*its parent is link 1; cdsm arms are serial chains"),
        (text.replace('<end_location>0 0.09921 0</end_location>', '<end_location>0.01 0.09921 0</end_location>', 1),
         r"link 1 .*end_location \[0.01, 0.09921, 0.0\] does not point along"),
        (text.replace('<link_rigid num="2"', '<link_rigid num="7"', 1), r"link 2 .*num='7', expected 2"),
        (text.replace('q_max="0.35 0.35"', 'q_max="-0.35 0.35"', 1), r"q_min -0.35 is not below q_max -0.35"),
        (text.replace("<mass>0.061973305</mass>", "<mass>-1</mass>", 1), r"<mass> must be finite and >= 0 kg"),
        (text[:200], r"not well-formed XML"),
    ]
    for i, (bad, pattern) in enumerate(cases):
        path = tmp_path / f"bad{i}_bodies.xml"
        path.write_text(bad)
        with pytest.raises(cdsm.CdsmInputError, match=pattern):
            _quiet(cdsm.Robot.from_caspr, path, CABLES)
    with pytest.raises(cdsm.CdsmInputError, match=r"CASPR bodies file .*missing_bodies.xml.*does not exist"):
        cdsm.Robot.from_caspr(tmp_path / "missing_bodies.xml", CABLES)
    spring = CABLES.read_text().replace("cable_ideal", "cable_linear_spring")
    (tmp_path / "spring_cables.xml").write_text(spring)
    with pytest.raises(cdsm.CdsmInputError, match=r"<cable_linear_spring> cannot be represented"):
        _quiet(cdsm.Robot.from_caspr, BODIES, tmp_path / "spring_cables.xml")


# --------------------------------------------------------------------------
# A model with every revolute joint type, written here
# --------------------------------------------------------------------------
#: per link: joint type, extra joint attributes, length (m), parent location's
#: offset across the links' direction (m, CASPR frame, added to the parent's end).
LINKS = [
    ("R_AXIS", ' axis="1 2 0.5"', 0.05, (0.0, 0.0, 0.0)),
    ("U_YZ", "", 0.04, (0.003, -0.002, 0.001)),
    ("U_XY", "", 0.045, (-0.001, 0.002, 0.0)),
    ("R_X", "", 0.03, (0.0, 0.001, -0.002)),
]
LIMITS = {"R_AXIS": ("-0.7", "0.6"), "U_YZ": ("-0.5 -0.4", "0.45 0.55"), "U_XY": ("-0.6 -0.3", "0.3 0.6"),
          "R_X": ("-0.8", "0.8")}


def _perp(d):
    """Two unit vectors across ``d`` (so that the model's holes lie off its axis)."""
    a = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(d, a)
    u /= np.linalg.norm(u)
    return u, np.cross(d, u)


def _s(v):
    return " ".join(repr(float(x)) for x in v)


def _model(d):
    """``(bodies XML, cables XML)`` of the model whose links point along ``d``."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    u, w = _perp(d)
    body = ['<?xml version="1.0" encoding="utf-8"?>', "<bodies_system>", "  <links>"]
    prev_end = np.zeros(3)
    for k, (jt, extra, length, across) in enumerate(LINKS, start=1):
        lo, hi = LIMITS[jt]
        loc = prev_end + np.asarray(across)
        body += [f'    <link_rigid num="{k}" name="L{k}">',
                 f'      <joint type="{jt}"{extra} q_initial="{" ".join("0" for _ in lo.split())}" '
                 f'q_min="{lo}" q_max="{hi}"/>',
                 f"      <physical><mass>{0.01 * k}</mass>",
                 f"        <com_location>{_s(0.4 * length * d + 0.001 * u)}</com_location>",
                 f"        <end_location>{_s(length * d)}</end_location>",
                 '        <inertia ref="com"><Ixx>1e-6</Ixx><Iyy>1e-6</Iyy><Izz>1e-6</Izz><Ixy>0</Ixy><Ixz>0</Ixz>'
                 "<Iyz>0</Iyz></inertia>",
                 "      </physical>",
                 f"      <parent><num>{k - 1}</num><location>{_s(loc)}</location></parent>",
                 "    </link_rigid>"]
        prev_end = length * d
    body += ["  </links>", "</bodies_system>"]

    def hole(k, angle, r, along):
        return (k, along * d + r * (np.cos(angle) * u + np.sin(angle) * w))

    lengths = [lk[2] for lk in LINKS]
    cables = []   # (name, reference, points base first)
    for c in range(7):
        e = [1, 2, 2, 3, 4, 4, 4][c]
        angle = 2 * math.pi * c / 7 + 0.3
        r = 0.012 + 0.001 * c
        pts = [hole(0, angle, r, -0.004)]
        for k in range(1, e + 1):
            pts.append(hole(k, angle, r, 0.2 * lengths[k - 1]))
            if k < e or c % 2:        # two points on the links it passes; one or two on its end link
                pts.append(hole(k, angle + 0.05, r, 0.85 * lengths[k - 1]))
        cables.append((f"c{c + 1}", "com" if c == 5 else "joint", pts[::-1] if c % 3 == 0 else pts))
    cab = ['<?xml version="1.0" encoding="utf-8"?>', '<cables default_cable_set="all">', '  <cable_set id="all">']
    for name, ref, pts in cables:
        cab += [f'    <cable_ideal name="{name}" attachment_reference="{ref}">',
                "      <properties><force_min>0</force_min><force_max>100</force_max></properties>",
                "      <attachments>"]
        for k, p in pts:
            if ref == "com" and k > 0:   # the file then gives the point relative to the centre of mass
                p = p - (0.4 * lengths[k - 1] * d + 0.001 * u)
            cab.append(f"        <attachment><link>{k}</link><location>{_s(p)}</location></attachment>")
        cab += ["      </attachments>", "    </cable_ideal>"]
    cab += ["  </cable_set>", "</cables>"]
    return "\n".join(body) + "\n", "\n".join(cab) + "\n"


def _q_of(d):
    """The documented rotation: the smallest one taking ``d`` to +x (axis-angle)."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    ex = np.array([1.0, 0, 0])
    axis = np.cross(d, ex)
    s = np.linalg.norm(axis)
    if s < 1e-15:
        return np.eye(3) if d[0] > 0 else np.diag([-1.0, -1.0, 1.0])
    axis /= s
    angle = math.atan2(s, d @ ex)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


# (-1, 1e-160, 0): within 1e-154 of -x, where the rotation's (1 - c) / |v|^2
# overflowed and the import was NaN
DIRECTIONS = [(0, 0, 1), (1, 0, 0), (-1, 0, 0), (0, -1, 0), (0.6, 0.8, 0), (1, -2, 2), (-1, 1e-160, 0)]


@pytest.mark.parametrize("d", DIRECTIONS, ids=[str(d) for d in DIRECTIONS])
def test_model_lengths_equal_caspr(cdsm, tmp_path, d):
    bodies_text, cables_text = _model(d)
    (tmp_path / "M_bodies.xml").write_text(bodies_text)
    (tmp_path / "M_cables.xml").write_text(cables_text)
    links = caspr.bodies(tmp_path / "M_bodies.xml")
    _, cables = caspr.cables(tmp_path / "M_cables.xml", links=links)
    robot = _quiet(cdsm.Robot.from_caspr, tmp_path / "M_bodies.xml", tmp_path / "M_cables.xml")
    assert robot.n == 6 and robot.cables == 7 and robot.joint_disks == [1, 2, 2, 3, 3, 4]
    np.testing.assert_array_equal(robot.joint_limits, caspr.limits(links))
    assert robot.cable_ends == [1, 2, 2, 3, 4, 4, 4]
    theta = _theta(robot.joint_limits, 100, 5)
    theirs = caspr.lengths(links, cables, theta)
    err = np.abs(robot.cable_lengths(theta) - theirs).max()
    assert err <= TOL, f"max |L_import - L_CASPR| = {err:.3e} m"
    assert np.ptp(theirs, axis=0).min() > 1e-4
    # the end frame: CASPR's last link's end point and rotation, turned by Q
    Q = _q_of(d)
    p, R = caspr.tip(links, theta)
    T = robot.fk_matrix(theta)
    np.testing.assert_allclose(T[:, :3, 3], p @ Q.T, rtol=0, atol=TOL)
    np.testing.assert_allclose(T[:, :3, :3], Q @ R @ Q.T, rtol=0, atol=1e-12)
    np.testing.assert_allclose(robot.gravity, Q @ [0.0, 0.0, -9.81], rtol=0, atol=1e-14)
    np.testing.assert_allclose(robot.mass, [lk["mass"] for lk in links], rtol=0, atol=0)


def _write_model(tmp_path, bodies_text, cables_text):
    (tmp_path / "M_bodies.xml").write_text(bodies_text)
    (tmp_path / "M_cables.xml").write_text(cables_text)
    return tmp_path / "M_bodies.xml", tmp_path / "M_cables.xml"


def _route(cables_text, name, links):
    """The cable ``name``'s attachments rewritten to run on ``links`` (same points, links replaced)."""
    block = re.search(rf'<cable_ideal name="{name}".*?</cable_ideal>', cables_text, re.S).group(0)
    atts = re.findall(r"<attachment>.*?</attachment>", block)
    loc = re.search(r"<location>.*?</location>", atts[0]).group(0)
    new = "".join(f"<attachment><link>{k}</link>{loc}</attachment>" for k in links)
    return cables_text.replace(block, re.sub(r"<attachments>.*</attachments>", f"<attachments>{new}</attachments>",
                                             block, flags=re.S))


def test_model_route_errors(cdsm, tmp_path):
    bodies_text, cables_text = _model((0, 0, 1))
    cases = [
        ([0, 2, 2], r"cable 2 \('c2'\): skips from link 0 to link 2 \(links 0 -> 2 -> 2\)"),
        ([0, 1, 1, 2, 1], r"cable 2 \('c2'\): returns to link 1"),
        ([0, 1, 1, 1, 2], r"cable 2 \('c2'\): has 3 attachments on link 1"),
        ([0, 0, 1], r"cable 2 \('c2'\): has 2 attachments on the base"),
        ([1, 0, 1], r"cable 2 \('c2'\): does not start at the base"),
        ([1], r"cable 2 \('c2'\): 1 attachment\(s\)"),
        ([0, 9], r"link 9 does not exist"),
    ]
    for links, pattern in cases:
        b, c = _write_model(tmp_path, bodies_text, _route(cables_text, "c2", links))
        with pytest.raises(cdsm.CdsmInputError, match=pattern):
            _quiet(cdsm.Robot.from_caspr, b, c)
    # a cable set without default and with two sets: the ids are listed
    two = cables_text.replace('<cables default_cable_set="all">', "<cables>").replace(
        "</cables>", '<cable_set id="other"/></cables>')
    b, c = _write_model(tmp_path, bodies_text, two)
    with pytest.raises(cdsm.CdsmInputError, match=r"no default_cable_set and 2 sets: pass cable_set, one of 'all', "
                                                 r"'other'"):
        _quiet(cdsm.Robot.from_caspr, b, c)
    assert _quiet(cdsm.Robot.from_caspr, b, c, cable_set="all").cables == 7
    # fewer cables than joints: cdsm's own check, with the model named
    few = re.sub(r'<cable_ideal name="c[3-7]".*?</cable_ideal>', "", cables_text, flags=re.S)
    b, c = _write_model(tmp_path, bodies_text, few)
    with pytest.raises(cdsm.CdsmInputError, match=r"CASPR model .*M_bodies.xml.*cannot represent it.*2 "
                                                 r"position-controlled cables cannot determine 6 joints"):
        _quiet(cdsm.Robot.from_caspr, b, c)


# --------------------------------------------------------------------------
# Hostile input: names and paths are data, encodings and huge vectors
# --------------------------------------------------------------------------
def test_a_file_name_cannot_become_a_setting(cdsm, tmp_path):
    """The bodies file's name goes into the robot's name as data: a name that
    reads as TOML lines sets nothing (the robot was once built from text,
    and this file imported with E = 1 Pa)."""
    plain = _quiet(cdsm.Robot.from_caspr, BODIES, CABLES)
    stem = "x\ncable.youngs_modulus = 1.0\ncable.diameter = 0.00018\n#"
    hostile = tmp_path / f"{stem}_bodies.xml"
    hostile.write_bytes(BODIES.read_bytes())
    robot = _quiet(cdsm.Robot.from_caspr, hostile, CABLES)
    assert robot.youngs_modulus == plain.youngs_modulus == 1.8e11
    assert robot.cable_diameter == plain.cable_diameter == 0.18e-3
    assert robot.axial_stiffness == plain.axial_stiffness
    assert robot.name == f"{stem} (CASPR, cable set {SET_ID})"
    # everything but the name is the plain import's, and the name survives a save
    mine, theirs = robot.to_toml().splitlines(), plain.to_toml().splitlines()
    name_line = [i for i, line in enumerate(theirs) if line.startswith("name = ")]
    assert len(mine) == len(theirs) and [i for i, (a, b) in enumerate(zip(mine, theirs)) if a != b] == name_line
    back = cdsm.Robot.from_toml_str(robot.to_toml())
    assert back.name == robot.name and back.to_toml() == robot.to_toml()


def test_the_set_id_and_names_are_data(cdsm, tmp_path):
    """A cable set's id (in the robot's name) and link and cable names with
    line breaks, quotes and TOML syntax change nothing but the name."""
    bodies_text, cables_text = _model((0, 0, 1))
    sid = 'all"\n[cable]\nyoungs_modulus = 1.0\n# \\'
    attr = sid.replace('"', "&quot;").replace("\n", "&#10;")
    b, c = _write_model(tmp_path, bodies_text.replace('name="L1"', 'name="L1&#10;mass = 9"'),
                        cables_text.replace('"all"', f'"{attr}"').replace('name="c1"', 'name="c&#10;[base]"'))
    robot = _quiet(cdsm.Robot.from_caspr, b, c)
    assert robot.name == f"M (CASPR, cable set {sid})"
    assert robot.youngs_modulus == 1.8e11
    (tmp_path / "plain").mkdir()
    plain = _quiet(cdsm.Robot.from_caspr, *_write_model(tmp_path / "plain", bodies_text, cables_text))
    mine, theirs = robot.to_toml().splitlines(), plain.to_toml().splitlines()
    name_line = [i for i, line in enumerate(theirs) if line.startswith("name = ")]
    assert len(mine) == len(theirs) and [i for i, (a, b) in enumerate(zip(mine, theirs)) if a != b] == name_line


def test_names_xml_forbids_are_refused(cdsm, tmp_path):
    """A bodies file's name with a character XML forbids (a control character;
    a byte that is not UTF-8, a lone surrogate in Python) would give the
    robot a name no MJCF or URDF can carry: refused, naming the model, the
    field and the character."""
    for stem, code in [("x\x01", "U+0001"), ("\x1b[2J", "U+001B"), (os.fsdecode(b"x\xff"), "surrogate")]:
        path = tmp_path / f"{stem}_bodies.xml"
        path.write_bytes(BODIES.read_bytes())
        pattern = rf"CASPR model .*cdsm cannot represent it.*name.*{re.escape(code)}"
        with pytest.raises(cdsm.CdsmInputError, match=pattern):
            _quiet(cdsm.Robot.from_caspr, path, CABLES)


def test_declared_encodings(cdsm, tmp_path):
    """The files are read as XML, in the encoding they declare: one Python
    does not know (``utf-0``) or cannot feed to the XML parser (a multi-byte
    one) is an error naming the file and the encoding; a Latin-1 file that
    says so imports."""
    bodies_text, cables_text = _model((0, 0, 1))
    b, c = _write_model(tmp_path, bodies_text, cables_text)
    plain = _quiet(cdsm.Robot.from_caspr, b, c)
    for enc in ("utf-0", "shift_jis"):
        b.write_bytes(bodies_text.replace('encoding="utf-8"', f'encoding="{enc}"', 1).encode())
        with pytest.raises(cdsm.CdsmInputError, match=rf"CASPR bodies file .*M_bodies.xml.*declares encoding "
                                                     rf"'{enc}', which cdsm cannot decode"):
            _quiet(cdsm.Robot.from_caspr, b, c)
    latin = bodies_text.replace('encoding="utf-8"', 'encoding="ISO-8859-1"', 1).replace('name="L1"', 'name="L\xe9"')
    b.write_bytes(latin.encode("latin-1"))
    assert _quiet(cdsm.Robot.from_caspr, b, c).to_toml() == plain.to_toml()


def test_a_huge_axis_is_normalised_safely(cdsm, tmp_path):
    """An ``R_AXIS`` axis ``0 1e308 1e308`` is the axis ``0 1 1`` (its length
    overflows; the reader scales by the largest component first), as the
    robot file reader takes it."""
    bodies_text, cables_text = _model((0, 0, 1))
    robots = []
    for axis in ("0 1 1", "0 1e308 1e308", "0 1e-310 1e-310"):
        (tmp_path / axis).mkdir()
        robots.append(_quiet(cdsm.Robot.from_caspr, *_write_model(
            tmp_path / axis, bodies_text.replace('axis="1 2 0.5"', f'axis="{axis}"'), cables_text)))
    for r in robots[1:]:
        assert r.to_toml() == robots[0].to_toml()
    np.testing.assert_allclose(robots[0].axes[0], _q_of((0, 0, 1)) @ np.array([0.0, 1.0, 1.0]) / np.sqrt(2.0),
                               rtol=0, atol=1e-15)


def test_packaged_data_untouched():
    """The shipped test data are CASPR's files (the git blob ids in their README)."""
    import hashlib

    def blob(path):
        data = path.read_bytes()
        return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()

    assert blob(BODIES) == "44dbeaa069e00f6fb3271f7c6187ccdd7ab9c28e"
    assert blob(CABLES) == "cea105d99eda8b80f10df7167b620a66c929cfa4"
