"""The URDF of an arm of either kind (:meth:`cdsm.Robot.to_urdf`;
``docs/interop.md``). SI units: m, kg, kg m^2, rad.

* Links ``base`` (cdsm's base frame: face b of the base disk), then one per
  joint: ``disk<k>`` for the last joint of disk ``k`` (the disk rides on
  it), ``disk<k>_joint<j>`` for the others (a universal joint's middle
  frame, no mass). Joint ``joint<j>`` (``j`` from 1, cdsm's order) is
  ``revolute`` about its axis, ``origin`` a pure translation (cdsm's frames
  carry no fixed rotation: :mod:`cdsm.interop.chain`), ``limit`` its joint
  limits; ``effort`` and ``velocity`` (required by URDF) are 0: the joints
  have no motors, the cables drive the arm. A model built from it has ``nq
  = n`` in cdsm's joint order.
* A disk's ``inertial``: its mass at its centre of mass, and (the robot file
  holds no inertia tensor) the inertia of a uniform solid cylinder of the
  disk's radius and thickness about that point, axis along the disk normal
  (``x``): ``ixx = m r^2 / 2``, ``iyy = izz = m (3 r^2 + t^2) / 12``. A disk
  of zero mass has no ``inertial``.
* ``tip``: a link fixed (joint ``tip_joint``) at cdsm's end frame, face b of
  the last disk: its pose is :meth:`cdsm.Robot.fk_matrix`.

Cables and gravity are not part of URDF and are not written.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from .chain import chain, comment, cylinder_inertia, fmt, xml_text

__all__ = ["to_urdf"]


def to_urdf(robot) -> str:
    """The URDF text (UTF-8 XML) of ``robot`` (a :class:`cdsm.Robot` of either
    kind); see the module doc for the mapping. :class:`CdsmInputError` for a
    text that is not well-formed XML (a name with a character XML forbids:
    the text is parsed back before it is returned)."""
    ch = chain(robot)
    root = ET.Element("robot", name=ch.name)
    root.append(comment(f"written by cdsm (Robot.to_urdf) from the {ch.kind} robot {ch.name!r}: "
                        f"{len(ch.joints)} revolute joints in cdsm's joint order, link 'tip' at the end "
                        "frame; SI units (m, kg, rad)"))
    ET.SubElement(root, "link", name="base")
    parent = "base"
    for j in ch.joints:
        k = j.disk
        name = f"disk{k}" if j.last else f"disk{k}_joint{j.index + 1}"
        link = ET.SubElement(root, "link", name=name)
        if j.last and ch.mass[k - 1] > 0:
            i = k - 1
            inertial = ET.SubElement(link, "inertial")
            ET.SubElement(inertial, "origin", xyz=fmt(*ch.com[i]), rpy="0 0 0")
            ET.SubElement(inertial, "mass", value=fmt(ch.mass[i]))
            ixx, iyy, izz = cylinder_inertia(ch.mass[i], ch.radius[i], ch.thickness[i])
            ET.SubElement(inertial, "inertia", ixx=fmt(ixx), ixy="0", ixz="0", iyy=fmt(iyy), iyz="0",
                          izz=fmt(izz))
        joint = ET.SubElement(root, "joint", name=f"joint{j.index + 1}", type="revolute")
        ET.SubElement(joint, "parent", link=parent)
        ET.SubElement(joint, "child", link=name)
        ET.SubElement(joint, "origin", xyz=fmt(*j.pos), rpy="0 0 0")
        ET.SubElement(joint, "axis", xyz=fmt(*j.axis))
        lo, hi = j.limits
        ET.SubElement(joint, "limit", lower=fmt(lo), upper=fmt(hi), effort="0", velocity="0")
        parent = name
    ET.SubElement(root, "link", name="tip")
    tip = ET.SubElement(root, "joint", name="tip_joint", type="fixed")
    ET.SubElement(tip, "parent", link=parent)
    ET.SubElement(tip, "child", link="tip")
    ET.SubElement(tip, "origin", xyz=fmt(*ch.face_b[-1]), rpy="0 0 0")
    return xml_text(root, "to_urdf", ch.name)
