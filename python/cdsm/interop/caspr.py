"""CASPR's multi-link models as cdsm robot files (:meth:`cdsm.Robot.from_caspr`;
``docs/interop.md``). SI units: m, rad, kg, N, m/s^2.

CASPR (https://github.com/darwinlau/CASPR, BSD-3-Clause) describes a
cable-driven arm in two XML files: ``<name>_bodies.xml`` (``link_rigid``
links, each with a joint, its mass, centre of mass, end location, inertia
and its parent's location of the joint) and ``<name>_cables.xml`` (cable
sets of ``cable_ideal`` cables, each a list of attachment points on links).
The conventions below are read from CASPR's ``src/Model`` code
(``SystemModelBodies``, ``BodyModelRigid``, the joint classes,
``CableAttachmentPoint``, ``CableModelBase``).

Conversion (:func:`caspr_robot_data`: the robot file's data, built as data,
never as text):

* One constant rotation ``Q`` takes CASPR's vectors to cdsm's: the smallest
  rotation taking the links' common direction ``d`` (that of their
  ``end_location``) to ``+x``, cdsm's disk normal (for links along CASPR's
  ``y``: ``(x, y, z) -> (y, -x, z)``; along ``-x``: a half turn about
  ``z``). Every link's ``end_location`` must point along ``d``.
* Link ``k`` is disk ``k``: face a is the link's joint frame (``link_after
  = 0``), face b its ``end_location`` (``thickness = |end_location|``). Its
  joint's axes, in order, each in the frame turned by the ones before
  (``R_pe`` of CASPR's joint classes: ``R_X``, ``R_Y``, ``R_Z``, ``R_AXIS``
  one axis; ``U_XY``, ``U_XZ``, ``U_YZ`` two), are cdsm's joints (``Q``
  applied), numbered in CASPR's order (link by link), limits ``[q_min,
  q_max]``. The first joint of link ``k`` sits at the parent's ``location``
  (``offset = Q location - (thickness of the parent, 0, 0)``; the base:
  ``Q location``), the others at offset 0. Links must form a chain: link
  ``k``'s parent is link ``k - 1``.
* Mass and centre of mass (``Q com_location``, face-a frame) per disk;
  gravity CASPR's, ``9.81 m/s^2`` along the base frame's ``-z`` (``Q``
  applied).
* Cables in the file's order, all position-controlled (CASPR's cables are
  actuators). A cable's attachments, ordered from the base (CASPR lists
  them in either direction; its length is the sum of the straight segments
  between consecutive attachments), must be: one point on the base (link 0),
  then one or two points on each link ``1, 2, ..., e`` in turn (``e`` the
  link the cable ends at). The base point is the base face-b hole; on link
  ``k`` the first point is the face-a hole and the second (or, with one
  point, the same) the face-b hole, in that face's frame: cdsm's length,
  ``sum |A_k - B_(k-1)| + |B_k - A_k|``, is then CASPR's sum of segments
  exactly. Attachments given relative to the centre of mass
  (``attachment_reference = "com"``) are moved to the joint frame
  (``com_location + location``), as CASPR does.
* Disk and base radii (CASPR has none): the largest distance of a hole on
  that disk (base) from its axis; a disk without an off-axis hole takes
  the largest over the arm.
* The robot's name: ``"<stem> (CASPR, cable set <id>)"``, ``<stem>`` the
  bodies file's name without ``_bodies.xml``. It is data, like every value
  here: the robot is built from the dict, never from formatted text, so no
  file name or id can become a setting. (A name XML forbids, e.g. a control
  character in the file's name, is refused by the robot reader.)
* The files are read as XML: in the encoding they declare (UTF-8 without a
  declaration). One Python does not know, or a multi-byte one other than
  UTF-8 and UTF-16, is an error naming the file and the encoding.

What cdsm cannot represent is an error naming the link or cable: another
link type, joint type (prismatic, spherical, planar, ...), or an actuated
joint; a tree or a link whose parent is not the previous link; an
``end_location`` of zero length or off the common direction; a cable type
other than ``cable_ideal``, a pulley attachment, a cable that does not start
at the base, skips a link, returns to an earlier one or has more than two
points on a link. What is read but not kept (inertia tensors, initial
joint values, cable force limits and diameters, names, other cable sets,
operational spaces) is listed in one warning.
"""

from __future__ import annotations

import math
import os
import re
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..files import read_bytes
from ..inputs import CdsmInputError

__all__ = ["caspr_robot_data", "JOINT_AXES", "GRAVITY"]

#: CASPR's revolute joint types and their axes in order (``R_pe`` the product
#: of the rotations about them, each about the frame turned by the previous);
#: ``R_AXIS`` takes its axis from the joint's ``axis`` attribute.
JOINT_AXES: Dict[str, Tuple[Tuple[float, float, float], ...]] = {
    "R_X": ((1.0, 0.0, 0.0),),
    "R_Y": ((0.0, 1.0, 0.0),),
    "R_Z": ((0.0, 0.0, 1.0),),
    "R_AXIS": ((math.nan, math.nan, math.nan),),
    "U_XY": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),
    "U_XZ": ((1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "U_YZ": ((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
}

#: CASPR's gravity (``SystemModel.GRAVITY_CONSTANT``, m/s^2) along ``-z`` of its base frame.
GRAVITY = 9.81


@dataclass
class _Link:
    num: int
    name: str
    joint_type: str
    axes: List[np.ndarray]      # CASPR frame, unit
    q_min: List[float]
    q_max: List[float]
    mass: float
    com: np.ndarray
    end: np.ndarray
    parent: int
    location: np.ndarray


@dataclass
class _Cable:
    name: str
    points: List[Tuple[int, np.ndarray]]   # base first; joint-frame locations (CASPR axes)


#: An XML declaration's encoding (the bytes of its name).
_DECLARED_ENCODING = re.compile(rb"""\A(?:\xef\xbb\xbf)?\s*<\?xml[^>]*?\bencoding\s*=\s*["']([^"']*)["']""")


class _Reader:
    """Field access with errors that name the file and the element."""

    def __init__(self, path: str, what: str):
        self.path, self.what = os.fspath(path), what
        data = read_bytes(path, f"CASPR {what}")
        try:
            self.root = ET.fromstring(data)   # decoded as the file declares (XML's rule)
        except ET.ParseError as exc:
            raise self.error(f"not well-formed XML ({exc})") from None
        except (LookupError, ValueError) as exc:
            # the declared encoding: unknown to Python (LookupError), or multi-byte (ValueError:
            # expat decodes UTF-8, UTF-16 and single-byte encodings only)
            m = _DECLARED_ENCODING.match(data)
            declared = m.group(1).decode("ascii", "backslashreplace") if m else "?"
            raise self.error(f"declares encoding {declared!r}, which cdsm cannot decode ({exc}); "
                             "save the file as UTF-8") from None

    def error(self, msg: str) -> CdsmInputError:
        return CdsmInputError(f"CASPR {self.what} file {self.path!r}: {msg}")

    def child(self, el: ET.Element, tag: str, where: str) -> ET.Element:
        c = el.find(tag)
        if c is None:
            raise self.error(f"{where}: <{tag}> is missing")
        return c

    def text(self, el: ET.Element, tag: str, where: str) -> str:
        c = self.child(el, tag, where)
        if c.text is None or not c.text.strip():
            raise self.error(f"{where}: <{tag}> is empty")
        return c.text

    def numbers(self, text: Optional[str], where: str, count: Optional[int] = None) -> List[float]:
        if text is None:
            raise self.error(f"{where} is missing")
        try:
            v = [float(s) for s in text.replace(",", " ").split()]
        except ValueError:
            raise self.error(f"{where}: expected numbers, got {text.strip()!r}") from None
        if count is not None and len(v) != count:
            raise self.error(f"{where}: expected {count} numbers, got {len(v)} ({text.strip()!r})")
        if not all(math.isfinite(x) for x in v):
            raise self.error(f"{where}: non-finite value in {text.strip()!r}")
        return v

    def vec3(self, el: ET.Element, tag: str, where: str) -> np.ndarray:
        return np.array(self.numbers(self.text(el, tag, where), f"{where} <{tag}>", 3))


def _links(bodies: _Reader, ignored: List[str]) -> List[_Link]:
    root = bodies.root
    links_el = root if root.tag == "links" else root.find("links")
    if links_el is None:
        raise bodies.error("no <links> element")
    if root.find("operational_spaces") is not None or root.find("operational_set") is not None:
        ignored.append("the operational spaces")
    links: List[_Link] = []
    inertia = q_init = names = 0
    for i, el in enumerate(links_el):
        where = f"link {i + 1} ({el.get('name', '')!r})" if el.get("name") else f"link {i + 1}"
        if el.tag != "link_rigid":
            raise bodies.error(f"{where}: <{el.tag}> is not supported (cdsm reads link_rigid links)")
        num = el.get("num")
        if num is None or num.strip() != str(i + 1):
            raise bodies.error(f"{where}: num={num!r}, expected {i + 1} (links are numbered in order from 1)")
        joint = bodies.child(el, "joint", where)
        jt = joint.get("type")
        if jt not in JOINT_AXES:
            raise bodies.error(f"{where}: joint type {jt!r} cannot be represented (cdsm arms have revolute "
                               f"joints: {', '.join(JOINT_AXES)})")
        if (joint.get("actuated") or "").strip().lower() == "true":
            raise bodies.error(f"{where}: the joint is actuated (a joint motor); cdsm arms are driven by "
                               "their cables only")
        axes = [np.array(a) for a in JOINT_AXES[jt]]
        if jt == "R_AXIS":
            a = _unit(np.array(bodies.numbers(joint.get("axis"), f"{where} joint axis", 3)))
            if a is None:
                raise bodies.error(f"{where}: joint axis {joint.get('axis')!r} is a zero vector")
            axes = [a]
        q_min = bodies.numbers(joint.get("q_min"), f"{where} joint q_min", len(axes))
        q_max = bodies.numbers(joint.get("q_max"), f"{where} joint q_max", len(axes))
        for v, (lo, hi) in enumerate(zip(q_min, q_max)):
            if not lo < hi:
                raise bodies.error(f"{where}: joint variable {v + 1}: q_min {lo} is not below q_max {hi}")
        q_init += joint.get("q_initial") is not None
        names += el.get("name") is not None
        phys = bodies.child(el, "physical", where)
        try:
            mass = float(bodies.text(phys, "mass", where))
        except ValueError:
            raise bodies.error(f"{where}: <mass> is not a number") from None
        if not (math.isfinite(mass) and mass >= 0):
            raise bodies.error(f"{where}: <mass> must be finite and >= 0 kg, got {mass}")
        inertia += phys.find("inertia") is not None
        parent = bodies.child(el, "parent", where)
        try:
            parent_num = int(bodies.text(parent, "num", f"{where} <parent>"))
        except ValueError:
            raise bodies.error(f"{where}: <parent><num> is not an integer") from None
        if parent_num != i:
            raise bodies.error(f"{where}: its parent is link {parent_num}; cdsm arms are serial chains "
                               f"(link k's parent must be link k - 1, here {i})")
        links.append(_Link(i + 1, el.get("name", ""), jt, axes, q_min, q_max, mass,
                           bodies.vec3(phys, "com_location", where), bodies.vec3(phys, "end_location", where),
                           parent_num, bodies.vec3(parent, "location", f"{where} <parent>")))
    if not links:
        raise bodies.error("no links")
    if inertia:
        ignored.append(f"the inertia tensors of {inertia} links (cdsm keeps mass and centre of mass)")
    if q_init:
        ignored.append(f"the initial joint values (q_initial) of {q_init} links")
    if names:
        ignored.append("the link names")
    return links


def _cable_set(cables: _Reader, cable_set: Optional[str], ignored: List[str]) -> Tuple[str, ET.Element]:
    root = cables.root
    sets = root.findall("cable_set") if root.tag != "cable_set" else [root]
    ids = [s.get("id", "") for s in sets]
    if not sets:
        raise cables.error("no <cable_set>")
    listing = ", ".join(repr(i) for i in ids)
    if cable_set is None:
        default = root.get("default_cable_set")
        if default is not None:
            if default not in ids:
                raise cables.error(f"default_cable_set {default!r} is not a cable set (sets: {listing})")
            cable_set = default
        elif len(sets) == 1:
            cable_set = ids[0]
        else:
            raise cables.error(f"no default_cable_set and {len(sets)} sets: pass cable_set, one of {listing}")
    if cable_set not in ids:
        raise CdsmInputError(f"`cable_set`: no cable set {cable_set!r} in {cables.path!r} (sets: {listing})")
    others = [i for i in ids if i != cable_set]
    if others:
        ignored.append(f"the other cable sets ({', '.join(repr(i) for i in others)})")
    return cable_set, sets[ids.index(cable_set)]


def _cables(cables: _Reader, set_el: ET.Element, set_id: str, links: Sequence[_Link],
            ignored: List[str]) -> List[_Cable]:
    out: List[_Cable] = []
    limits = diameters = 0
    for i, el in enumerate(set_el):
        name = el.get("name", "")
        where = f"cable set {set_id!r}, cable {i + 1} ({name!r})"
        if el.tag != "cable_ideal":
            raise cables.error(f"{where}: <{el.tag}> cannot be represented (cdsm's cables are ideal: "
                               "cable_ideal)")
        ref = el.get("attachment_reference")
        if ref not in ("joint", "com"):
            raise cables.error(f"{where}: attachment_reference {ref!r}, expected 'joint' or 'com'")
        props = el.find("properties")
        if props is not None:
            limits += props.find("force_min") is not None or props.find("force_max") is not None
            diameters += props.find("diameter") is not None
        att_el = cables.child(el, "attachments", where)
        points: List[Tuple[int, np.ndarray]] = []
        for a, at in enumerate(att_el):
            if at.tag != "attachment":
                raise cables.error(f"{where}: attachment {a + 1} <{at.tag}> cannot be represented (cdsm's "
                                   "cables run through holes: point attachments)")
            try:
                k = int(cables.text(at, "link", f"{where}, attachment {a + 1}"))
            except ValueError:
                raise cables.error(f"{where}, attachment {a + 1}: <link> is not an integer") from None
            if not 0 <= k <= len(links):
                raise cables.error(f"{where}, attachment {a + 1}: link {k} does not exist (0..{len(links)})")
            r = cables.vec3(at, "location", f"{where}, attachment {a + 1}")
            if ref == "com" and k > 0:
                r = links[k - 1].com + r
            points.append((k, r))
        if len(points) < 2:
            raise cables.error(f"{where}: {len(points)} attachment(s); a cable needs at least 2")
        order = [k for k, _ in points]
        if order[0] != 0 and order[-1] == 0:
            points.reverse()
            order.reverse()
        route = " -> ".join(str(k) for k in order)
        if order[0] != 0:
            raise cables.error(f"{where}: does not start at the base (its attachments run on links {route}); "
                               "cdsm's cables run from the base (link 0) through every link up to their end")
        if order.count(0) > 1:
            raise cables.error(f"{where}: has {order.count(0)} attachments on the base (links {route}); cdsm "
                               "keeps one base hole per cable")
        prev, count = 0, 0
        for k in order[1:]:
            if k == prev:
                count += 1
                if count > 2:
                    raise cables.error(f"{where}: has {order.count(k)} attachments on link {k} (links "
                                       f"{route}); cdsm keeps two holes per disk (faces a and b)")
            elif k == prev + 1:
                prev, count = k, 1
            else:
                what = "returns to" if k < prev else f"skips from link {prev} to"
                raise cables.error(f"{where}: {what} link {k} (links {route}); cdsm's cables run through every "
                                   "link in turn from the base to their end")
        out.append(_Cable(name, points))
    if not out:
        raise cables.error(f"cable set {set_id!r} has no cables")
    if limits:
        ignored.append(f"the force limits (force_min, force_max) of {limits} cables")
    if diameters:
        ignored.append(f"the diameters of {diameters} cables")
    ignored.append("the cable names")
    return out


def _norm(v: np.ndarray) -> float:
    """``|v|`` computed without overflow or underflow (``v`` scaled by its
    largest component first): ``inf`` only when ``|v|`` itself overflows."""
    s = float(np.abs(v).max())
    if s == 0.0 or not math.isfinite(s):
        return s
    return s * float(np.linalg.norm(v / s))


def _unit(v: np.ndarray) -> Optional[np.ndarray]:
    """The unit vector along ``v`` (finite), computed without overflow or
    underflow (``0 1e308 1e308`` is ``(0, 1, 1) / sqrt 2``); None for a
    zero vector."""
    s = float(np.abs(v).max())
    if s == 0.0:
        return None
    u = v / s
    return u / np.linalg.norm(u)


def _rotation(links: Sequence[_Link], bodies: _Reader) -> np.ndarray:
    """``Q`` (3, 3): the smallest rotation taking the links' common unit
    direction (CASPR frame) to ``+x``."""
    dirs = []
    for lk in links:
        u = _unit(lk.end)
        if u is None:
            raise bodies.error(f"link {lk.num} ({lk.name!r}): end_location is zero; cdsm's disks have a "
                               "positive thickness along their normal")
        dirs.append(u)
    d = dirs[-1]
    for lk, u in zip(links, dirs):
        if np.abs(u - d).max() > 1e-12:
            raise bodies.error(f"link {lk.num} ({lk.name!r}): end_location {lk.end.tolist()} does not point along "
                               f"the last link's {links[-1].end.tolist()}; cdsm's disks all have their faces along "
                               "their own x axis (one constant rotation from CASPR's frames)")
    ex = np.array([1.0, 0.0, 0.0])
    v, c = np.cross(d, ex), float(d @ ex)
    n = _unit(v)
    if n is None:
        return np.eye(3) if c > 0 else np.diag([-1.0, -1.0, 1.0])

    def skew(a: np.ndarray) -> np.ndarray:
        return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])

    # Rodrigues with the unit axis n = v / |v| (sin = |v|, 1 - cos): the
    # form vx @ vx (1 - c) / |v|^2 overflows to inf * 0 (NaN), or loses
    # digits in a subnormal |v|^2, where d is within ~1e-154 of -x
    nx = skew(n)
    return np.eye(3) + skew(v) + (nx @ nx) * (1.0 - c)


def _floats(v) -> List[float]:
    return [float(x) + 0.0 for x in v]   # -0.0 kept as 0.0


def caspr_robot_data(bodies_xml: "str | os.PathLike[str]", cables_xml: "str | os.PathLike[str]",
                     cable_set: Optional[str] = None) -> dict:
    """The cdsm spatial robot file of a CASPR model, as data (a dict of the
    file's structure, ``docs/spatial.md``; SI units) for
    :meth:`cdsm.Robot.from_data`: ``bodies_xml`` and ``cables_xml`` are the
    paths of its ``_bodies.xml`` and ``_cables.xml`` files; ``cable_set``
    the id of the cable set (None: the file's ``default_cable_set``, else
    its only set). The robot's ``name`` is ``"<stem> (CASPR, cable set
    <id>)"``, ``<stem>`` the bodies file's name without ``_bodies.xml``. The
    conversion is the module doc's; what is not kept is said in one
    warning (``UserWarning``), what cannot be represented raises
    :class:`CdsmInputError` naming it."""
    ignored: List[str] = []
    bodies = _Reader(bodies_xml, "bodies")
    cables = _Reader(cables_xml, "cables")
    links = _links(bodies, ignored)
    set_id, set_el = _cable_set(cables, cable_set, ignored)
    cable_list = _cables(cables, set_el, set_id, links, ignored)
    Q = _rotation(links, bodies)
    K = len(links)
    thick = [_norm(lk.end) for lk in links]
    ex = np.array([1.0, 0.0, 0.0])

    # holes in face frames (cdsm axes): base face b, then faces a and b of disks 1..e
    holes: List[List[np.ndarray]] = []
    for cb in cable_list:
        pts = [Q @ cb.points[0][1]]
        by_link: Dict[int, List[np.ndarray]] = {}
        for k, r in cb.points[1:]:
            by_link.setdefault(k, []).append(Q @ r)
        for k in range(1, max(by_link) + 1):
            a = by_link[k][0]
            b = by_link[k][-1]
            pts.append(a)
            pts.append(b - thick[k - 1] * ex)
        holes.append(pts)

    # radii: the farthest hole from the axis on each face (0: the base)
    reach = np.zeros(K + 1)
    for pts in holes:
        for i, p in enumerate(pts):
            k = (i + 1) // 2
            reach[k] = max(reach[k], math.hypot(p[1], p[2]))
    if not reach.max() > 0:
        raise cables.error(f"cable set {set_id!r}: every hole lies on its disk's axis (no cable can bend the arm)")
    radius = np.where(reach > 0, reach, reach.max())

    stem = os.path.basename(os.fspath(bodies_xml))
    stem = stem[:-len("_bodies.xml")] if stem.endswith("_bodies.xml") else os.path.splitext(stem)[0]
    linkage = []
    for i, lk in enumerate(links):
        before = thick[i - 1] if i > 0 else 0.0
        joints = [{"axis": _floats(Q @ ax),
                   "offset": _floats(Q @ lk.location - before * ex if v == 0 else np.zeros(3)),
                   "limits": _floats([lk.q_min[v], lk.q_max[v]])}
                  for v, ax in enumerate(lk.axes)]
        linkage.append({"joints": joints, "link_after": [0.0, 0.0, 0.0], "thickness": thick[i],
                        "radius": float(radius[i + 1]), "mass": float(lk.mass), "com": _floats(Q @ lk.com)})
    if ignored:
        warnings.warn(f"CASPR model {stem!r}: not kept: " + "; ".join(ignored), UserWarning, stacklevel=3)
    return {
        "kind": "spatial",
        "name": f"{stem} (CASPR, cable set {set_id})",
        "gravity": _floats(Q @ np.array([0.0, 0.0, -GRAVITY])),
        "base": {"radius": float(radius[0])},
        "linkage": linkage,
        "cables": [{"end": len(pts) // 2, "mode": "position", "holes": [_floats(p) for p in pts]} for pts in holes],
    }
