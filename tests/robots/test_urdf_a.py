"""Robot A against KUKA's own URDF chain (independent FK with xml.etree)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.robots import link_frames, load_robot

from .urdf_chain import UrdfChain

URDF = Path(__file__).parent / "data" / "kr300_r2700_2_clean.urdf"


def test_flange_matches_urdf_tool0(rng: np.random.Generator) -> None:
    chain = UrdfChain(URDF)
    robot = load_robot("A")
    for _ in range(50):
        q = rng.uniform(chain_lower(chain), chain_upper(chain))
        ref = chain.link_poses(q)["tool0"]
        np.testing.assert_allclose(link_frames(robot, q)[6], ref, atol=1e-5)


def chain_lower(chain: UrdfChain) -> np.ndarray:
    return np.array([j.lower for j in chain.revolute])


def chain_upper(chain: UrdfChain) -> np.ndarray:
    return np.array([j.upper for j in chain.revolute])


def test_limits_match_urdf() -> None:
    chain = UrdfChain(URDF)
    robot = load_robot("A")
    # A3 upper: URDF 168 deg = REFERENCES table; others identical up to rounding
    np.testing.assert_allclose(robot.q_min, chain_lower(chain), atol=1e-6)
    np.testing.assert_allclose(robot.q_max, chain_upper(chain), atol=1e-6)


def test_link_bodies_match_urdf_in_world(rng: np.random.Generator) -> None:
    """Each link's mass, world COM and world inertia equal KUKA's (file rounding 6 digits)."""
    chain = UrdfChain(URDF)
    robot = load_robot("A")
    for _ in range(5):
        q = rng.uniform(-2, 2, 6)
        poses = chain.link_poses(q)
        frames = link_frames(robot, q)
        for i in range(6):
            ine = chain.inertials[f"link_{i + 1}"]
            body = robot.joints[i].body
            tu, td = poses[f"link_{i + 1}"], frames[i + 1]
            assert body.mass_kg == pytest.approx(ine.mass, rel=1e-5)
            com_ref = tu[:3, :3] @ ine.com + tu[:3, 3]
            com = td[:3, :3] @ body.com_m + td[:3, 3]
            np.testing.assert_allclose(com, com_ref, atol=5e-6)
            i_ref = tu[:3, :3] @ ine.inertia @ tu[:3, :3].T
            i_dh = td[:3, :3] @ body.inertia_kgm2 @ td[:3, :3].T
            np.testing.assert_allclose(i_dh, i_ref, atol=1e-5 * np.abs(i_ref).max())


def test_builtin_bodies_match_their_derivation() -> None:
    """A, B, C link bodies equal tests/robots/derive_builtin_robots.py (6 digits)."""
    from .derive_builtin_robots import robot_a, robot_b, robot_c

    for name, derive in (("A", robot_a), ("B", robot_b), ("C", robot_c)):
        robot = load_robot(name)
        for joint, body in zip(robot.joints, derive(), strict=True):
            assert joint.body.mass_kg == pytest.approx(body.m, rel=1e-5)
            np.testing.assert_allclose(joint.body.com_m, body.c, rtol=1e-5, atol=1e-9)
            np.testing.assert_allclose(joint.body.inertia_kgm2, body.inertia, rtol=1e-5, atol=1e-8)
