"""CASPR's model of a cable-driven arm, evaluated in NumPy straight from its XML
files, the way CASPR's ``src/Model`` code does (https://github.com/darwinlau/CASPR,
BSD-3-Clause); written for the tests, independently of ``cdsm.interop.caspr``:

* bodies (``SystemModelBodies.update``, ``BodyModelRigid``, the joint classes):
  ``R_0k = R_0p R_pe(q)`` and the joint of link k at ``p_k = p_p + R_0p r_Parent``
  (CASPR stores ``r_OP`` in the link frame, ``R_pe^T (r_OP_p + r_Parent)``: the
  same point); ``q`` is the links' joint variables in link order. ``R_pe`` of
  each revolute joint type as CASPR's classes write it: ``RevoluteX``,
  ``RevoluteY``, ``RevoluteZ`` (the matrices below), ``RevoluteAxis``
  (``I + sin t A + (1 - cos t) A^2``, ``A`` the cross matrix of the
  normalised axis), ``UniversalXY`` = ``R_x(a) R_y(b)``, ``UniversalXZ`` =
  ``R_x(a) R_z(g)``, ``UniversalYZ`` = ``R_y(b) R_z(g)``;
* cables (``CableAttachmentPoint``, ``CableSegmentModel``,
  ``CableModelBase.length``): a point ``r_A`` on link k is ``p_k + R_0k r_A``
  with ``attachment_reference = "joint"``, ``p_k + R_0k (r_G + r_A)`` with
  ``"com"`` (on link 0 ``r_A`` itself), and a cable's length is the sum of the
  straight segments between its consecutive attachment points, in the file's
  order.

SI units: m, rad, kg.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np


def _vec(text: str) -> np.ndarray:
    v = np.array([float(s) for s in text.split()])
    assert v.shape == (3,), text
    return v


def _rx(t):
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def _ry(t):
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def _rz(t):
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _raxis(axis):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    A = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])

    def rot(t):
        return np.eye(3) + np.sin(t)[:, None, None] * A + (1 - np.cos(t))[:, None, None] * (A @ A)
    return rot


def joint_rotation(joint_type: str, axis=None):
    """``(number of variables, R_pe(q (N, k)) -> (N, 3, 3))`` of a CASPR revolute joint type."""
    if joint_type == "R_AXIS":
        rot = _raxis(axis)
        return 1, lambda q: rot(q[:, 0])
    return {
        "R_X": (1, lambda q: _rx(q[:, 0])),
        "R_Y": (1, lambda q: _ry(q[:, 0])),
        "R_Z": (1, lambda q: _rz(q[:, 0])),
        "U_XY": (2, lambda q: _rx(q[:, 0]) @ _ry(q[:, 1])),
        "U_XZ": (2, lambda q: _rx(q[:, 0]) @ _rz(q[:, 1])),
        "U_YZ": (2, lambda q: _ry(q[:, 0]) @ _rz(q[:, 1])),
    }[joint_type]


def bodies(path):
    """The links of a ``_bodies.xml`` as dicts (SI units), in file order."""
    root = ET.parse(path).getroot()
    links_el = root if root.tag == "links" else root.find("links")
    links = []
    for el in links_el.findall("link_rigid"):
        joint, phys, parent = el.find("joint"), el.find("physical"), el.find("parent")
        axis = joint.get("axis")
        links.append(
            dict(
                num=int(el.get("num")),
                type=joint.get("type"),
                axis=None if axis is None else [float(s) for s in axis.split()],
                q_min=[float(s) for s in joint.get("q_min").split()],
                q_max=[float(s) for s in joint.get("q_max").split()],
                mass=float(phys.find("mass").text),
                com=_vec(phys.find("com_location").text),
                end=_vec(phys.find("end_location").text),
                parent=int(parent.find("num").text),
                location=_vec(parent.find("location").text),
            )
        )
    return links


def cables(path, set_id=None, links=None):
    """``(set id, [(name, [(link, r_A in the joint frame), ...]), ...])`` of a
    cable set (None: the file's ``default_cable_set``), in file order; the
    attachment points in the file's order ("com" references moved to the
    joint frame with ``links``' centres of mass)."""
    root = ET.parse(path).getroot()
    set_id = root.get("default_cable_set") if set_id is None else set_id
    (cable_set,) = [s for s in root.findall("cable_set") if s.get("id") == set_id]
    out = []
    for c in cable_set:
        assert c.tag == "cable_ideal", c.tag
        ref = c.get("attachment_reference")
        att = []
        for a in c.find("attachments"):
            k, r = int(a.find("link").text), _vec(a.find("location").text)
            if ref == "com" and k > 0:
                r = links[k - 1]["com"] + r
            att.append((k, r))
        out.append((c.get("name"), att))
    return set_id, out


def frames(links, q):
    """World rotations ``R (N, K+1, 3, 3)`` and joint points ``p (N, K+1, 3)`` of
    every link (index 0: the base, identity), CASPR's base frame, for ``q (N,
    n)`` in CASPR's order."""
    N = q.shape[0]
    R = np.zeros((N, len(links) + 1, 3, 3))
    p = np.zeros((N, len(links) + 1, 3))
    R[:, 0] = np.eye(3)
    col = 0
    for lk in links:
        k, a = lk["num"], lk["parent"]
        assert a < k  # parents first: one pass suffices
        nq, rel = joint_rotation(lk["type"], lk["axis"])
        R[:, k] = R[:, a] @ rel(q[:, col: col + nq])
        p[:, k] = p[:, a] + R[:, a] @ lk["location"]
        col += nq
    assert col == q.shape[1]
    return R, p


def points(R, p, attachments):
    """World points ``(N, len(attachments), 3)`` of one cable's attachments."""
    return np.stack([p[:, k] + R[:, k] @ r for k, r in attachments], axis=1)


def lengths(links, cable_list, q):
    """CASPR's cable lengths ``(N, m)``: the sum of the segments between consecutive points."""
    R, p = frames(links, q)
    out = np.empty((q.shape[0], len(cable_list)))
    for c, (_, att) in enumerate(cable_list):
        P = points(R, p, att)
        out[:, c] = np.linalg.norm(np.diff(P, axis=1), axis=-1).sum(axis=1)
    return out


def tip(links, q):
    """The end point of the last link (its ``end_location``), base frame, ``(N, 3)``;
    and the last link's rotation ``(N, 3, 3)``."""
    R, p = frames(links, q)
    return p[:, -1] + R[:, -1] @ links[-1]["end"], R[:, -1]


def limits(links):
    """``(n, 2)`` joint limits in CASPR's order."""
    lo = np.concatenate([lk["q_min"] for lk in links])
    hi = np.concatenate([lk["q_max"] for lk in links])
    return np.stack([lo, hi], axis=1)
