"""MuJoCo's MJCF of an arm of either kind (:meth:`cdsm.Robot.to_mjcf`;
``docs/interop.md``). SI units: m, kg, kg m^2, rad, N.

* One body per disk (``disk<k>``), nested base to tip, each placed by a
  translation only, carrying its disk's joints as ``hinge``s
  (``joint<j>``, cdsm's order) about their axes, each at its anchor
  (:mod:`cdsm.interop.chain`; MuJoCo composes a body's joints in order, each
  about its own anchor, which is cdsm's chain), ``range`` the joint limits:
  ``nq = nv = n`` and ``qpos`` is cdsm's ``theta``. Gravity: the robot's
  (``<option gravity>``; planar arms ``(gx, gy, 0)``).
* The disk's ``<inertial>``: its mass at its centre of mass and, since a
  robot file holds no inertia tensor, the inertia of a uniform solid
  cylinder of the disk's radius and thickness about that point, axis along
  the disk normal (``x``): ``m r^2 / 2``, ``m (3 r^2 + t^2) / 12`` twice.
  MuJoCo rejects a moving body whose mass or any moment of inertia is below
  ``mjMINVAL`` (:data:`MJMINVAL`, 1e-15): such a disk (zero mass included)
  is an error naming it and the field. A cylinder ``geom`` shows the disk
  (no contacts, no mass: ``inertiafromgeom="false"``), placed by its centre
  and axis (``pos``, ``zaxis``, half-thickness in ``size``; not ``fromto``,
  which MuJoCo 4.0 refuses shorter than 1e-7 m).
* The robot's name is the ``model`` attribute: the text is parsed back
  before it is returned, and a name with a character XML forbids (which
  the robot readers refuse) is an error, not a file.
* A ``site`` at every hole (``cable<c>_hole<i>``, ``c`` from 1 in cdsm's
  order, ``i = 0 .. 2 end``: base face b, then faces a and b of each disk),
  a site ``tip`` at the end frame's origin, and one spatial ``tendon`` per
  cable (``cable<c>``) through its sites: its length is cdsm's cable length
  (straight segments between consecutive holes) and ``ten_J`` its Jacobian.
* A position cable gets a ``position`` actuator (``cable<c>_position``):
  force ``kp (ctrl - L)`` with ``ctrl`` the commanded length (m) and ``kp =
  E A / (L_0 + routing_length)`` (N/m; ``L_0`` the cable's length at ``theta
  = 0``): the cable as a linear spring about the straight arm; it only pulls
  (``forcerange = [-E A, 0]`` N, ``E A`` the axial stiffness). A force cable
  gets a ``general`` actuator (``cable<c>_force``) whose force is the
  constant ``-T`` whatever its control (``gainprm = 0``, ``biastype =
  affine``, ``biasprm = [-T, 0, 0]``): it pulls with its set tension ``T``.
  (A tendon actuator's positive force lengthens the tendon, so a pull is
  negative.)
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..inputs import CdsmInputError
from .chain import chain, comment, cylinder_inertia, fmt, xml_text

__all__ = ["to_mjcf", "MJMINVAL"]


#: MuJoCo's ``mjMINVAL`` (``mujoco.mjMINVAL``): its compiler refuses a moving
#: body whose mass or any principal moment of inertia is below it ("mass and
#: inertia of moving bodies must be larger than mjMINVAL").
MJMINVAL = 1e-15


def _check_inertials(ch) -> None:
    """:class:`CdsmInputError` naming the disk (its body) and the field when
    the mass or a moment of inertia written for it is one MuJoCo refuses:
    below :data:`MJMINVAL`, or not finite."""
    for k in range(ch.disks):
        m, r, t = float(ch.mass[k]), float(ch.radius[k]), float(ch.thickness[k])
        where = f"to_mjcf: disk {k + 1} (body 'disk{k + 1}')"
        if m == 0:
            raise CdsmInputError(f"to_mjcf: disk {k + 1} has no mass (0.0 kg, body 'disk{k + 1}'); MuJoCo rejects a "
                                 "moving body without mass and inertia: give the disk its mass")
        if not m >= MJMINVAL:
            raise CdsmInputError(f"{where}: mass {m!r} kg is below {MJMINVAL!r} (MuJoCo's mjMINVAL: it rejects a "
                                 "moving body of smaller mass or inertia): give the disk its mass")
        moments = zip(("Ixx", "Iyy", "Izz"), cylinder_inertia(m, r, t), ("m r^2 / 2", *["m (3 r^2 + t^2) / 12"] * 2))
        bad = [(field, value, formula) for field, value, formula in moments if not MJMINVAL <= value < np.inf]
        if bad:
            problem = ("is not finite" if bad[0][1] >= MJMINVAL else
                       f"{'is' if len(bad) == 1 else 'are'} below {MJMINVAL!r} (MuJoCo's mjMINVAL)")
            raise CdsmInputError(f"{where}: inertia {', '.join(f'{f} = {x} = {v!r}' for f, v, x in bad)} kg m^2 "
                                 f"(mass {m!r} kg, radius {r!r} m, thickness {t!r} m: a uniform solid cylinder) "
                                 f"{problem}; MuJoCo rejects a moving body whose mass or inertia is smaller: give "
                                 "the disk more mass or a larger radius")


def to_mjcf(robot) -> str:
    """The MJCF text (UTF-8 XML) of ``robot`` (a :class:`cdsm.Robot` of either
    kind); see the module doc for the mapping. :class:`CdsmInputError` for
    what MuJoCo would refuse: a disk whose mass or inertia is below
    :data:`MJMINVAL` (zero mass included), naming the disk and the field,
    or a text that is not well-formed XML (a name with a character XML
    forbids)."""
    ch = chain(robot)
    _check_inertials(ch)
    root = ET.Element("mujoco", model=ch.name)
    root.append(comment(f"written by cdsm (Robot.to_mjcf) from the {ch.kind} robot {ch.name!r}: "
                        f"{len(ch.joints)} hinges in cdsm's joint order, {len(ch.cables)} cables as spatial "
                        "tendons; SI units (m, kg, rad, N)"))
    ET.SubElement(root, "compiler", angle="radian", autolimits="true", inertiafromgeom="false")
    ET.SubElement(root, "option", gravity=fmt(*ch.gravity))
    world = ET.SubElement(root, "worldbody")
    size = fmt(robot.cable_diameter / 2.0)

    body = {0: world}              # disk (0: the base) -> its body
    shift = {0: np.zeros(3)}       # disk -> its frame's origin in its body's frame
    for j in ch.joints:
        k = j.disk
        if j.first:
            body[k] = ET.SubElement(body[k - 1], "body", name=f"disk{k}", pos=fmt(*(shift[k - 1] + j.pos)))
        lo, hi = j.limits
        ET.SubElement(body[k], "joint", name=f"joint{j.index + 1}", type="hinge", pos=fmt(*j.anchor),
                      axis=fmt(*j.axis), range=fmt(lo, hi), limited="true")
        if j.last:
            shift[k] = j.anchor
    for k in range(1, ch.disks + 1):
        s, i = shift[k], k - 1
        body[k].insert(0, ET.Element("inertial", pos=fmt(*(s + ch.com[i])), mass=fmt(ch.mass[i]),
                                     diaginertia=fmt(*cylinder_inertia(ch.mass[i], ch.radius[i], ch.thickness[i]))))
        half = ch.thickness[i] / 2.0
        ET.SubElement(body[k], "geom", name=f"disk{k}", type="cylinder", size=fmt(ch.radius[i], half),
                      pos=fmt(*(s + ch.face_a[i] + (half, 0.0, 0.0))), zaxis="1 0 0", contype="0",
                      conaffinity="0", group="1")
    for c in ch.cables:
        for i, (k, point) in enumerate(c.holes):
            ET.SubElement(body[k], "site", name=f"cable{c.index + 1}_hole{i}", pos=fmt(*(shift[k] + point)),
                          size=size)
    # cdsm's end frame: face b of the last disk
    last = ch.disks
    ET.SubElement(body[last], "site", name="tip", pos=fmt(*(shift[last] + ch.face_b[-1])), size=size)

    for k in range(1, ch.disks):   # each disk's own elements first, then the next disk's body
        body[k].remove(body[k + 1])
        body[k].append(body[k + 1])

    tendons = ET.SubElement(root, "tendon")
    for c in ch.cables:
        sp = ET.SubElement(tendons, "spatial", name=f"cable{c.index + 1}", width=size)
        for i in range(len(c.holes)):
            ET.SubElement(sp, "site", site=f"cable{c.index + 1}_hole{i}")

    actuators = ET.SubElement(root, "actuator")
    ea = robot.axial_stiffness
    l0 = robot.cable_lengths(np.zeros(robot.n)) + robot.routing_length
    for c in ch.cables:
        tendon = f"cable{c.index + 1}"
        if c.mode == "position":
            ET.SubElement(actuators, "position", name=f"{tendon}_position", tendon=tendon,
                          kp=fmt(ea / l0[c.index]), forcelimited="true", forcerange=fmt(-ea, 0.0))
        else:
            ET.SubElement(actuators, "general", name=f"{tendon}_force", tendon=tendon, gaintype="fixed",
                          gainprm="0", biastype="affine", biasprm=fmt(-c.tension, 0.0, 0.0))
    return xml_text(root, "to_mjcf", ch.name)
