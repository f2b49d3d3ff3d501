"""Inverse kinematics: FK round trips, branches, continuity, reachability, singularities."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import ConvergenceError, ReachabilityError, SingularityError
from robolobe.robots import Robot, link_frames, load_robot, tcp_pose
from robolobe.robots.ik import (
    ik,
    ik_batch,
    ik_branches,
    ik_numeric,
    ik_numeric_many,
    is_closed_form,
    nearest,
    pose_error,
)
from robolobe.robots.limits import sample_postures, within_limits
from robolobe.robots.model import Joint

EXAMPLE = Path(__file__).parents[2] / "examples" / "robots" / "my_robot.toml"


@pytest.fixture(scope="module", params=["A", "B", "C", "example"])
def robot(request: pytest.FixtureRequest) -> Robot:
    return load_robot(EXAMPLE if request.param == "example" else request.param)


def _same_angles(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether postures are equal modulo 2*pi per joint; shape (...,)."""
    d = np.abs(np.mod(a - b + np.pi, 2 * np.pi) - np.pi)
    return np.all(d < 1e-7, axis=-1)


def test_builtins_are_closed_form(robot: Robot) -> None:
    assert is_closed_form(robot)


def test_round_trip_500_random_postures(robot: Robot, rng: np.random.Generator) -> None:
    q = sample_postures(robot, 500, rng)
    poses = tcp_pose(robot, q)
    q8, ok = ik_branches(robot, poses)
    assert ok.sum(axis=1).min() >= 2  # at least the posture's own wrist pair
    # every existing branch reproduces the pose
    dp, da = pose_error(tcp_pose(robot, np.where(ok[..., None], q8, 0.0)), poses[:, None])
    assert np.all(dp[ok] < 1e-9)
    assert np.all(da[ok] < 1e-9)
    # the original posture is among the branches (mod 2*pi) ...
    assert np.all(np.any(_same_angles(q8, q[:, None]) & ok, axis=1))
    # ... and, exactly (incl. its 2*pi turn), among ik()'s valid solutions
    for i in range(0, 500, 10):
        res = ik(robot, poses[i])
        assert np.any(np.all(np.abs(res.q_valid - q[i]) < 1e-7, axis=1))
        np.testing.assert_array_equal(res.valid, within_limits(robot, res.q))
        dp, da = pose_error(tcp_pose(robot, res.q), poses[i])
        assert dp.max() < 1e-9
        assert da.max() < 1e-9


def test_numeric_search_finds_no_solution_outside_the_branches(
    robot: Robot, rng: np.random.Generator
) -> None:
    """Independent completeness check: DLS from 40 random seeds per pose."""
    q = sample_postures(robot, 4, rng)
    for qi in q:
        pose = tcp_pose(robot, qi)
        q8, ok = ik_branches(robot, pose[None])
        found = q8[0][ok[0]]
        qn, conv = ik_numeric_many(robot, pose, rng.uniform(-np.pi, np.pi, (40, 6)),
                                   max_iter=80)  # fmt: skip
        assert conv.sum() >= 4  # the search does find solutions
        for x in qn[conv]:
            assert np.any(_same_angles(found, x)), np.degrees(x)


def test_eight_branches_in_front_of_the_robot() -> None:
    r = load_robot("A")
    q = np.radians([10, -80, 100, 30, 45, 20])
    res = ik(r, tcp_pose(r, q))
    assert res.n_branches == 8
    q8, ok = ik_branches(r, tcp_pose(r, q)[None])
    assert ok.all()
    # 8 distinct postures
    assert len({tuple(np.round(np.mod(x, 2 * np.pi), 6)) for x in q8[0]}) == 8


def test_turn_multiples_within_limits() -> None:
    r = load_robot("A")  # q4, q6 in [-350, 350]
    q = np.radians([10, -80, 100, 100, 45, -20])
    res = ik(r, tcp_pose(r, q))
    same_branch = res.q[res.valid & (np.abs(res.q[:, 4] - q[4]) < 1e-9)]
    q4s = np.sort(np.round(np.degrees(same_branch[:, 3]), 6))
    assert {-260.0, 100.0} <= set(q4s.tolist())
    q6s = set(np.round(np.degrees(same_branch[:, 5]), 6).tolist())
    assert {-20.0, 340.0} <= q6s
    qv = res.q[res.valid]
    assert np.all((qv >= r.q_min - 1e-9) & (qv <= r.q_max + 1e-9))


def test_nearest_and_q_ref_order(robot: Robot, rng: np.random.Generator) -> None:
    q = sample_postures(robot, 20, rng)
    for qi in q:
        got = nearest(robot, tcp_pose(robot, qi), qi + 0.01)
        np.testing.assert_allclose(got, qi, atol=1e-7)


def test_path_continuity(robot: Robot, rng: np.random.Generator) -> None:
    q0, q1 = sample_postures(robot, 2, rng)
    # stay clear of the wrist singularity so the path is unique
    q0[4] = q1[4] = np.clip(q0[4], 0.3, 1.0) if robot.q_max[4] > 1.0 else q0[4]
    path = q0 + np.linspace(0, 1, 200)[:, None] * (q1 - q0)
    path = path[within_limits(robot, path)]
    poses = tcp_pose(robot, path)
    got = ik_batch(robot, poses, path[0], continuity=True)
    np.testing.assert_allclose(got, path, atol=1e-7)
    steps = np.abs(np.diff(got, axis=0)).max()
    assert steps < 2 * np.abs(np.diff(path, axis=0)).max() + 1e-9
    # without continuity every pose takes the solution nearest q_ref
    alone = ik_batch(robot, poses, path[0], continuity=False)
    dp, _ = pose_error(tcp_pose(robot, alone), poses)
    assert dp.max() < 1e-9


def test_unreachable_pose() -> None:
    r = load_robot("B")
    pose = np.eye(4)
    pose[:3, 3] = [8.0, 0.0, 1.0]
    with pytest.raises(ReachabilityError, match=r"xyz_mm = \[8000.0, 0.0, 1000.0\].*out of reach"):
        ik(r, pose)
    with pytest.raises(ReachabilityError, match="waypoint 1"):
        ik_batch(r, np.stack([tcp_pose(r, np.radians([0, 0, -90, 0, 30, 0])), pose]), np.zeros(6))


def test_no_solution_within_limits() -> None:
    # A: a pose only reachable with q1 beyond +-185 deg is not the case; use a q2 that is
    # reachable geometrically but outside [-140, -5]: the arm bent down (q2 = +30)
    r = load_robot("A")
    q = np.radians([0, 30, 20, 0, 40, 0])
    pose = tcp_pose(r, q)
    res = ik(r, pose)
    with pytest.raises(ReachabilityError, match=r"no solution .* within its joint limits"):
        nearest(r, pose, np.zeros(6))
    assert not res.valid.any()


def test_wrist_singularity_flagged_and_resolved() -> None:
    r = load_robot("A")
    q = np.radians([20, -70, 95, 40, 0.0, 10])  # q5 = 0: axes 4 and 6 aligned
    pose = tcp_pose(r, q)
    res = ik(r, pose)
    assert "wrist" in res.singular
    with pytest.raises(SingularityError, match="wrist singularity"):
        nearest(r, pose, q, allow_singular=False)
    # allowed: q4 is taken from the reference and q6 compensates
    ref = q.copy()
    ref[3] = np.radians(55)
    got = nearest(r, pose, ref)
    assert got[3] == pytest.approx(ref[3], abs=1e-9)
    dp, da = pose_error(tcp_pose(r, got), pose)
    assert dp < 1e-9
    assert da < 1e-9
    # far from it: no flag
    q[4] = np.radians(30)
    assert ik(r, tcp_pose(r, q)).singular == ()


def test_elbow_and_shoulder_singularities_flagged() -> None:
    r = load_robot("A")
    # elbow: wrist centre in line with the upper arm: in DH frame 2 the wrist centre is
    # Rz(theta3) (a3, d4, 0), so theta3 = q3 - 90 deg = -atan2(d4, a3)
    q3 = np.arctan2(0.115, 1.22)
    q = np.array([0.0, -np.radians(60), q3, 0.0, 0.5, 0.0])
    assert "elbow" in ik(r, tcp_pose(r, q)).singular
    # shoulder: wrist centre on axis 1
    rot = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])  # flange z horizontal (+x)
    wc = np.array([0.0, 0.0, 1.9])
    flange = np.eye(4)
    flange[:3, :3] = rot
    flange[:3, 3] = wc + 0.24 * rot[:, 2]
    res = ik(r, flange @ r.tool)
    assert "shoulder" in res.singular
    f = link_frames(r, res.q[0])
    np.testing.assert_allclose(f[5, :2, 3], 0.0, atol=1e-9)  # wrist centre on the axis


def test_numeric_fallback_for_non_ortho_parallel_robot(rng: np.random.Generator) -> None:
    base = load_robot("A")
    joints = list(base.joints)
    joints[1] = Joint(**{**joints[1].__dict__, "d_m": 0.08})  # lateral offset: still closed
    joints[4] = Joint(**{**joints[4].__dict__, "a_m": 0.03})  # non-spherical wrist: numeric
    r = base.replace(joints=tuple(joints))
    assert not is_closed_form(r)
    q = np.radians([10, -80, 100, 30, 45, 20])
    pose = tcp_pose(r, q)
    res = ik(r, pose, q_ref=q + 0.05)
    assert np.all(res.branch == -1)
    np.testing.assert_allclose(res.q[0], q, atol=1e-7)
    got = nearest(r, pose, q + 0.05)
    np.testing.assert_allclose(got, q, atol=1e-7)
    far = np.eye(4)
    far[:3, 3] = [9.0, 0, 0]
    with pytest.raises(ConvergenceError, match="did not converge"):
        ik_numeric(r, far, q)
    with pytest.raises(ConvergenceError, match="no solution"):
        ik(r, far)
    path = q + np.linspace(0, 0.2, 20)[:, None]
    np.testing.assert_allclose(ik_batch(r, tcp_pose(r, path), q), path, atol=1e-7)
    poses = tcp_pose(r, path[:4])
    poses[[1, 3]] = far
    with pytest.raises(ReachabilityError, match=r"^waypoint 1: .*2 of 4 waypoints.*first: 1, 3\)"):
        ik_batch(r, poses, q)


def test_lateral_offset_stays_closed_form(rng: np.random.Generator) -> None:
    base = load_robot("C")
    joints = list(base.joints)
    joints[2] = Joint(**{**joints[2].__dict__, "d_m": 0.07})  # d3 offset (modified DH)
    r = base.replace(joints=tuple(joints))
    assert is_closed_form(r)
    q = sample_postures(r, 100, rng)
    q8, ok = ik_branches(r, tcp_pose(r, q))
    assert np.all(np.any(_same_angles(q8, q[:, None]) & ok, axis=1))


def _random_path(robot: Robot, rng: np.random.Generator, n: int) -> np.ndarray:
    """Random walk through the joint space (within the limits), crossing branches."""
    knots = sample_postures(robot, 6, rng)
    t = np.linspace(0, 1, n)
    path = np.stack([np.interp(t, np.linspace(0, 1, 6), knots[:, j]) for j in range(6)], -1)
    path += rng.normal(scale=0.01, size=path.shape)
    return path[within_limits(robot, path)]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_compiled_continuity_equals_numpy_loop(
    name: str, rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    import importlib

    from robolobe import _jit

    ik_mod = importlib.import_module("robolobe.robots.ik")

    r = load_robot(name)
    path = _random_path(r, rng, 1500)
    poses = tcp_pose(r, path)
    monkeypatch.setattr(ik_mod, "_IK_CHUNK", 257)  # several chunks, carried across
    monkeypatch.setattr(ik_mod, "JIT_MIN_POSES", 0)  # compiled even for a short path
    got = ik_batch(r, poses, path[0], continuity=True)
    alone = ik_batch(r, poses, path[0], continuity=False)
    monkeypatch.setattr(_jit, "_STATE", {"ok": False})
    monkeypatch.setattr(ik_mod, "_IK_CHUNK", 10**9)
    ref = ik_batch(r, poses, path[0], continuity=True)
    ref_alone = ik_batch(r, poses, path[0], continuity=False)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(alone, ref_alone, rtol=0, atol=1e-9)
    # same branch choice: the chosen postures reproduce the poses and follow the path
    dp, da = pose_error(tcp_pose(r, got), poses)
    assert dp.max() < 1e-9
    assert da.max() < 1e-9


def test_unreachable_count_and_first_indices() -> None:
    r = load_robot("B")
    good = tcp_pose(r, np.radians([0, 0, -90, 0, 30, 0]))
    far = np.eye(4)
    far[:3, 3] = [8.0, 0.0, 1.0]
    poses = np.stack([good, far, good, far, far, good, far, far, far, far, far])
    with pytest.raises(ReachabilityError) as exc:
        ik_batch(r, poses, np.zeros(6))
    msg = str(exc.value)
    assert msg.startswith("waypoint 1:")
    assert "out of reach" in msg
    assert "8 of 11 waypoints" in msg
    assert "the first: 1, 3, 4, 6, 7, ..." in msg


@pytest.mark.parametrize("name", ["A", "B", "C", "example"])
def test_vectorized_continuity_equals_loop(name: str, rng: np.random.Generator) -> None:
    """The speculate-and-check continuity picks exactly what the per-pose loop picks.

    On a smooth path, a path with jumps that switch branches every few poses
    (many speculation passes, then the loop fallback), and poses out of reach.
    """
    import importlib

    ik_mod = importlib.import_module("robolobe.robots.ik")
    r = load_robot(EXAMPLE if name == "example" else name)
    smooth = _random_path(r, rng, 600)
    jumpy = smooth.copy()
    jumpy[::7] = sample_postures(r, jumpy[::7].shape[0], rng)  # far postures: branch changes
    poses = tcp_pose(r, np.concatenate([smooth, jumpy]))
    far = np.eye(4)
    far[:3, 3] = [9.0, 0.0, 1.0]
    poses[[5, 6, 300, 900]] = far  # no solution: skipped, the next one follows the last good
    q8, ok = ik_branches(r, poses, smooth[0])
    base, count = ik_mod._turn_base(r, q8, ok)
    exists = ok & np.all(count >= 1, axis=-1)
    wts = np.array([1.0, 2.0, 1.5, 0.5, 1.0, 0.7])
    p_ref, p_vec = smooth[0].copy(), smooth[0].copy()
    ref = ik_mod._continuity_numpy(r, base, count, exists, wts, p_ref)
    got = ik_mod._continuity_vectorized(r, base, count, exists, wts, p_vec)
    np.testing.assert_array_equal(got[0], ref[0])  # NaN where no solution, in both
    np.testing.assert_array_equal(got[1], ref[1])
    np.testing.assert_array_equal(got[2], ref[2])
    np.testing.assert_array_equal(p_vec, p_ref)
    assert not ref[1][[5, 6, 300, 900]].any()
    assert ref[1].sum() == len(poses) - 4
    # the path changes branch (the speculation was wrong at times)
    assert np.unique(ref[2][ref[1]]).size > 1


def test_lazy_fk_check_matches_checking_every_branch(
    rng: np.random.Generator, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ik_batch checks only the chosen branch; a chosen branch that fails the check
    makes the chunk be chosen again among checked branches (same result as checking all)."""
    import importlib

    ik_mod = importlib.import_module("robolobe.robots.ik")
    r = load_robot("A")
    path = _random_path(r, rng, 400)
    poses = tcp_pose(r, path)
    fast = ik_batch(r, poses, path[0])
    real = ik_mod._branches_unchecked

    def broken(
        robot: Robot, P: np.ndarray, q_ref: object, compiled: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        q, ok = real(robot, P, q_ref, compiled=compiled)
        q = q.copy()
        q[10, :, 0] += 0.3  # every branch of pose 10 misses its pose: must be refused
        return q, ok

    monkeypatch.setattr(ik_mod, "_branches_unchecked", broken)
    with pytest.raises(ReachabilityError, match=r"waypoint 10: .*out of reach"):
        ik_batch(r, poses, path[0])

    # every branch checked first (ik_branches), then chosen: the same postures
    def checked(
        robot: Robot, P: np.ndarray, q_ref: object, compiled: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        q, ok = real(robot, P, q_ref, compiled=compiled)
        return q, ok & ik_mod._reproduces(robot, q, ok, P[:, None])

    monkeypatch.setattr(ik_mod, "_branches_unchecked", checked)
    np.testing.assert_array_equal(ik_batch(r, poses, path[0]), fast)


@pytest.mark.slow  # compiles the kernel in a fresh cache (~7 s)
@pytest.mark.parametrize("name", ["A", "B", "C", "example"])
def test_compiled_closed_form_equals_numpy(name: str, rng: np.random.Generator) -> None:
    """The compiled closed form gives the numpy reference's branches to rounding
    (angles modulo 2*pi), the same existing branches, at singular and unreachable poses too."""
    import importlib

    from robolobe import _jit

    if not _jit.available():
        pytest.skip("numba not available (or ROBOLOBE_NO_JIT set): no compiled kernel")
    ik_mod = importlib.import_module("robolobe.robots.ik")
    r = load_robot(EXAMPLE if name == "example" else name)
    q = sample_postures(r, 400, rng)
    q[:20, 4] = 0.0  # wrist singular: theta4 from the reference
    poses = tcp_pose(r, q)
    poses[20:30, :3, 3] = [9.0, 0.0, 1.0]  # out of reach: no branch
    ref, ok_ref = ik_mod._branches_unchecked(r, poses, q[0], compiled=False)
    got, ok = ik_mod._branches_unchecked(r, poses, q[0], compiled=True)
    np.testing.assert_array_equal(ok, ok_ref)
    assert not ok[20:30].any()
    d = np.abs(np.mod(got - ref + np.pi, 2 * np.pi) - np.pi)[ok]
    assert d.max() < 1e-9
    np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
