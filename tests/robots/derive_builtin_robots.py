"""Derivation of the link bodies of the built-in robots A, B and C (a record, not a test).

Run ``python -m tests.robots.derive_builtin_robots`` from the project root to
print the ``[[joints]]`` body values (mass, COM, inertia in the robot's DH
frames) that ``src/robolobe/data/robots/{A,B,C}.toml`` hold. It is how those
numbers were made; the files themselves are the source of truth (their
stiffness, damping and end-effector values are calibrated separately and must
not be overwritten from here).

Method
------
1. KUKA's URDFs (shared/robot-data, Apache-2.0) give each link's mass, COM and
   inertia in the URDF link frame. A fixed transform (constant for all q,
   checked here) maps each URDF link frame onto standard-DH frame i of the
   same arm, with the DH frames of ``A.toml`` (KR 300 R2700-2) and of the
   KR 300 R2800-2 MT with the same DH layout.
2. All three robots use the same physical frame layout at the "home" posture
   (upper arm vertical, forearm horizontal: DH theta2 = -90 deg, theta3 = 0),
   so a body in standard-DH frame i of one arm can be carried to another arm.
3. B (Comau NJ 650-2.7, 2450 kg): the R2800-2 MT set (2443 kg, the same mass
   class) with masses scaled so that the total incl. the estimated
   parallelogram parts is 2450 kg; COMs and inertias of links 2 and 3 scaled
   by the upper-arm / forearm length ratios (COM ~ L, inertia ~ m L^2).
   C (ABB IRB 4400/60, 1040 kg): the R2700-2 (quantec) set scaled by
   (1040 - parallelogram parts) / 1100.8 likewise.
4. The parallelogram (est.): the rod is lumped half into link 2 (at mid upper
   arm) and half into link 3 (at the elbow); crank/lever and counterweight are
   lumped into link 3 as a body at the elbow behind axis 3. A serial model
   cannot represent the rod's translation exactly; the error is of the order
   of the rod's rotational inertia (small).
5. Standard-DH bodies are re-expressed in the modified-DH frames of B and C.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robolobe.robots.kinematics import link_frames
from robolobe.robots.model import Joint, RigidBody, Robot

from .urdf_chain import UrdfChain

DATA = Path(__file__).resolve().parent / "data"  # copies of shared/robot-data URDFs
D = np.radians


def make_robot(convention, dh, coupling, offsets_deg, name="x") -> Robot:
    body = RigidBody(1.0, np.zeros(3), np.eye(3))
    joints = tuple(
        Joint(a, D(al), d, D(off), -7.0, 7.0, body, 1.0, 1.0)
        for (a, al, d), off in zip(dh, offsets_deg, strict=True)
    )
    return Robot(name, convention, joints, coupling=np.asarray(coupling, float))


def kuka_std(d1, a1, a2, a3, d4, d6) -> Robot:
    """Standard-DH model of a KUKA quantec/fortec arm, q = KUKA axis angles."""
    dh = [(a1, -90, d1), (a2, 0, 0), (a3, -90, 0), (0, 90, d4), (0, -90, 0), (0, 0, d6)]
    return make_robot("standard-dh", dh, np.diag([-1, 1, 1, -1, 1, -1.0]), [0, 0, -90, 0, 0, 180])


@dataclass
class Body:
    m: float
    c: np.ndarray
    inertia: np.ndarray

    def moved(self, t: np.ndarray) -> Body:
        """The same body expressed in a frame in which our frame has pose t."""
        r = t[:3, :3]
        return Body(self.m, r @ self.c + t[:3, 3], r @ self.inertia @ r.T)

    def scaled(self, s_mass: float, s_len: float) -> Body:
        return Body(self.m * s_mass, self.c * s_len, self.inertia * s_mass * s_len**2)


def combine(*bodies: Body) -> Body:
    m = sum(b.m for b in bodies)
    c = sum(b.m * b.c for b in bodies) / m
    inertia = np.zeros((3, 3))
    for b in bodies:
        d = b.c - c
        inertia += b.inertia + b.m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))
    return Body(m, c, inertia)


def rod(m: float, length: float, axis: int, center) -> Body:
    """Slender rod of mass m and length along body axis ``axis`` (0..2)."""
    i = np.full(3, m * length**2 / 12.0)
    i[axis] = 1e-3 * m * length**2 / 12.0 + 1e-4 * m
    return Body(m, np.asarray(center, float), np.diag(i))


def urdf_bodies_in_std_dh(urdf: Path, robot: Robot) -> list[Body]:
    chain = UrdfChain(urdf)
    names = [f"link_{i}" for i in range(1, 7)]
    rels = []
    for seed in range(4):
        q = np.zeros(6) if seed == 0 else np.random.default_rng(seed).uniform(-2, 2, 6)
        poses = chain.link_poses(q)
        frames = link_frames(robot, q)
        rels.append([np.linalg.inv(frames[i + 1]) @ poses[n] for i, n in enumerate(names)])
        flange_err = np.abs(frames[6] - poses["tool0"]).max()
        assert flange_err < 1e-9, flange_err
    for i in range(6):
        assert max(np.abs(r[i] - rels[0][i]).max() for r in rels) < 1e-9
    out = []
    for i, n in enumerate(names):
        ine = chain.inertials[n]
        out.append(Body(ine.mass, ine.com, ine.inertia).moved(rels[0][i]))
    return out


def std_to_mod(std: Robot, mod: Robot, bodies: list[Body]) -> list[Body]:
    fs, fm = link_frames(std, np.zeros(6)), link_frames(mod, np.zeros(6))
    assert np.abs(fs[6] - fm[6]).max() < 1e-9, "std and modified models differ"
    out = []
    for i, b in enumerate(bodies):
        t = np.linalg.inv(fm[i + 1]) @ fs[i + 1]
        out.append(b.moved(t))
    return out


# ------------------------------------------------------------------ robots
def robot_a() -> list[Body]:
    return urdf_bodies_in_std_dh(
        DATA / "kr300_r2700_2_clean.urdf", kuka_std(0.645, 0.33, 1.15, 0.115, 1.22, 0.24)
    )


PARALLEL_COUPLING_B = [
    [-1, 0, 0, 0, 0, 0],
    [0, 1, 0, 0, 0, 0],
    [0, -1, -1, 0, 0, 0],
    [0, 0, 0, -1, 0, 0],
    [0, 0, 0, 0, 1, 0],
    [0, 0, 0, 0, 0, -1],
]
PARALLEL_COUPLING_C = [
    [1, 0, 0, 0, 0, 0],
    [0, 1, 0, 0, 0, 0],
    [0, -1, 1, 0, 0, 0],
    [0, 0, 0, 1, 0, 0],
    [0, 0, 0, 0, 1, 0],
    [0, 0, 0, 0, 0, 1],
]


def _std_mod(d1, a1, a2, a3, d4, d6, coupling, offsets):
    std = make_robot(
        "standard-dh",
        [(a1, -90, d1), (a2, 0, 0), (a3, -90, 0), (0, 90, d4), (0, -90, 0), (0, 0, d6)],
        coupling,
        offsets,
    )
    mod = make_robot(
        "modified-dh",
        [(0, 0, d1), (a1, -90, 0), (a2, 0, 0), (a3, -90, d4), (0, 90, 0), (0, -90, d6)],
        coupling,
        offsets,
    )
    return std, mod


def robot_b() -> list[Body]:
    mt = urdf_bodies_in_std_dh(
        DATA / "kr300_r2800_2_mt_clean.urdf", kuka_std(0.86, 0.5, 1.25, 0.18, 1.0345, 0.305)
    )
    rod_m, lever_m = 80.0, 60.0  # (est.) parallelogram rod; crank/lever + counterweight
    s = (2450.0 - rod_m - lever_m) / 2443.02
    lam = [1.0, 1.05 / 1.25, 1.205 / 1.0345, 1.0, 1.0, 1.0]
    bodies = [b.scaled(s, lam[i]) for i, b in enumerate(mt)]
    # std frame 2: origin at axis 3, x2 along the upper arm (base -> elbow)
    bodies[1] = combine(bodies[1], rod(rod_m / 2, 1.05, 0, [-0.525, 0.0, 0.25]))
    # std frame 3: origin on axis 4 above axis 3; x3 = "up", z3 = along the forearm
    bodies[2] = combine(
        bodies[2],
        rod(rod_m / 2, 0.3, 0, [-0.25, 0.0, -0.1]),
        rod(lever_m, 0.6, 2, [-0.25, 0.0, -0.35]),
    )
    std, mod = _std_mod(1.14, 0.46, 1.05, 0.25, 1.205, 0.282, PARALLEL_COUPLING_B,
                        [0, -90, -90, 0, 0, 180])  # fmt: skip
    return std_to_mod(std, mod, bodies)


def robot_c() -> list[Body]:
    a = robot_a()
    rod_m, lever_m = 25.0, 20.0  # (est.)
    s = (1040.0 - rod_m - lever_m) / 1100.8
    lam = [1.0, 0.89 / 1.15, 0.88 / 1.22, 1.0, 1.0, 1.0]
    bodies = [b.scaled(s, lam[i]) for i, b in enumerate(a)]
    bodies[1] = combine(bodies[1], rod(rod_m / 2, 0.89, 0, [-0.445, 0.0, 0.2]))
    bodies[2] = combine(
        bodies[2],
        rod(rod_m / 2, 0.25, 0, [-0.15, 0.0, -0.1]),
        rod(lever_m, 0.4, 2, [-0.15, 0.0, -0.25]),
    )
    std, mod = _std_mod(0.68, 0.2, 0.89, 0.15, 0.88, 0.14, PARALLEL_COUPLING_C,
                        [0, -90, 0, 0, 0, 180])  # fmt: skip
    return std_to_mod(std, mod, bodies)


def fmt(x: float) -> str:
    v = float(f"{x:.6g}")
    return "0.0" if v == 0 else repr(v)


def main() -> None:
    for name, fn in (("A", robot_a), ("B", robot_b), ("C", robot_c)):
        bodies = fn()
        print(f"# ---- {name}: total moving mass {sum(b.m for b in bodies):.1f} kg")
        for i, b in enumerate(bodies):
            comps = [b.inertia[0, 0], b.inertia[1, 1], b.inertia[2, 2],
                     b.inertia[0, 1], b.inertia[0, 2], b.inertia[1, 2]]  # fmt: skip
            print(f"joint {i + 1}")
            print(f"mass_kg = {fmt(b.m)}")
            print(f"com_m = [{', '.join(fmt(v) for v in b.c)}]")
            print(f"inertia_kgm2 = [{', '.join(fmt(v) for v in comps)}]")


if __name__ == "__main__":
    main()
