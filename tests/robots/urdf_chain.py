"""A minimal, independent URDF chain reader for test oracles (xml.etree only).

Computes the world poses of the links of a serial URDF chain with plain
homogeneous matrices, without any robolobe code, so tests can compare it
with robolobe's DH forward kinematics.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _origin(el: ET.Element | None) -> np.ndarray:
    t = np.eye(4)
    if el is None:
        return t
    xyz = [float(v) for v in (el.get("xyz") or "0 0 0").split()] or [0.0, 0.0, 0.0]
    rpy = [float(v) for v in (el.get("rpy") or "0 0 0").split()] or [0.0, 0.0, 0.0]
    t[:3, :3] = _rpy(*rpy)
    t[:3, 3] = xyz
    return t


def _axis_rot(axis: np.ndarray, q: float) -> np.ndarray:
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    t = np.eye(4)
    t[:3, :3] = np.eye(3) + np.sin(q) * kx + (1 - np.cos(q)) * kx @ kx
    return t


@dataclass
class UrdfJoint:
    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: float
    upper: float


@dataclass
class UrdfInertial:
    mass: float
    com: np.ndarray  # in the link frame
    inertia: np.ndarray  # 3x3 about the COM, link-frame axes


class UrdfChain:
    """Serial chain from ``root`` through the revolute joints, in file order."""

    def __init__(self, path: str | Path) -> None:
        root = ET.parse(path).getroot()
        self.inertials: dict[str, UrdfInertial] = {}
        for link in root.findall("link"):
            ine = link.find("inertial")
            if ine is None:
                continue
            org = _origin(ine.find("origin"))
            i = ine.find("inertia")
            assert i is not None
            g = {k: float(i.get(k, "0")) for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz")}
            tensor = np.array(
                [[g["ixx"], g["ixy"], g["ixz"]], [g["ixy"], g["iyy"], g["iyz"]],
                 [g["ixz"], g["iyz"], g["izz"]]]
            )  # fmt: skip
            r = org[:3, :3]
            mass_el = ine.find("mass")
            assert mass_el is not None
            self.inertials[link.get("name", "")] = UrdfInertial(
                mass=float(mass_el.get("value", "0")), com=org[:3, 3], inertia=r @ tensor @ r.T
            )
        self.joints: dict[str, UrdfJoint] = {}
        for j in root.findall("joint"):
            lim = j.find("limit")
            ax = j.find("axis")
            parent, child = j.find("parent"), j.find("child")
            assert parent is not None
            assert child is not None
            self.joints[j.get("name", "")] = UrdfJoint(
                name=j.get("name", ""),
                kind=j.get("type", ""),
                parent=parent.get("link", ""),
                child=child.get("link", ""),
                origin=_origin(j.find("origin")),
                axis=np.array(
                    [
                        float(v)
                        for v in (ax.get("xyz", "1 0 0") if ax is not None else "1 0 0").split()
                    ]
                ),
                lower=float(lim.get("lower", "0")) if lim is not None else 0.0,
                upper=float(lim.get("upper", "0")) if lim is not None else 0.0,
            )
        self.revolute = [j for j in self.joints.values() if j.kind == "revolute"]

    def link_poses(self, q: np.ndarray, root: str = "base_link") -> dict[str, np.ndarray]:
        """World poses of all links reachable from ``root`` for revolute angles q."""
        qmap = {j.name: float(v) for j, v in zip(self.revolute, q, strict=True)}
        poses = {root: np.eye(4)}
        changed = True
        while changed:
            changed = False
            for j in self.joints.values():
                if j.parent in poses and j.child not in poses:
                    t = poses[j.parent] @ j.origin
                    if j.kind == "revolute":
                        t = t @ _axis_rot(j.axis, qmap[j.name])
                    poses[j.child] = t
                    changed = True
        return poses
