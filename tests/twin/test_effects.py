"""Physics effects: a physical check for each, validation, serialisation."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import Robot, load_robot, point_jacobian
from robolobe.robots.kinematics import TCP_FRAME
from robolobe.twin.dynamics import gravity_torques
from robolobe.twin.effects import (
    EFFECTS,
    AddedMass,
    BaseCompliance,
    CoupledJointStiffness,
    Effect,
    FrictionDamping,
    GravityStiffening,
    HammerDirection,
    JointDamping,
    JointStiffness,
    LinkFlexibility,
    SensorDelay,
    SensorGain,
    SensorMisalignment,
    ServoMode,
    TcpOffset,
    ToolMode,
    effect_from_dict,
    effect_to_dict,
    link_bending_axes,
)
from robolobe.twin.model import Twin
from robolobe.twin.modes import undamped_modes

FREQ = np.linspace(0.0, 60.0, 121)


@pytest.fixture(scope="module")
def robot() -> Robot:
    return load_robot("B")


@pytest.fixture(scope="module")
def q() -> np.ndarray:
    # three postures inside B's tested ranges (seed Table 3, deg)
    return np.radians(
        [[-2, 21, -27, 5, 1, -29], [23, -28, -101, -82, 124, 168], [30, 30, -102, -145, 106, -11]]
    )


def _f_undamped(twin: Twin, q: np.ndarray) -> np.ndarray:
    s = twin.system(q)
    w, _ = undamped_modes(s.M, s.K)
    return w / (2 * np.pi)


# ---------------------------------------------------------------- added mass
def test_added_mass_lowers_every_frequency(robot: Robot, q: np.ndarray) -> None:
    f0 = _f_undamped(Twin(robot), q)
    f1 = _f_undamped(Twin(robot, (AddedMass(20.0),)), q)
    assert np.all(f1 < f0)


def test_added_point_mass_is_woodbury_update(robot: Robot, q: np.ndarray) -> None:
    m = 12.0
    h = Twin(robot).receptance(q, FREQ)
    h_m = Twin(robot, (AddedMass(m),)).receptance(q, FREQ)
    w2 = (2 * np.pi * FREQ) ** 2
    # H' = H (I - w^2 m H)^-1 (3x3 Sherman-Morrison-Woodbury)
    expected = h @ np.linalg.inv(np.eye(3) - w2[:, None, None] * m * h)
    np.testing.assert_allclose(h_m, expected, rtol=1e-7, atol=1e-9 * np.abs(h).max())


def test_added_point_mass_1d_form() -> None:
    # 1-D: H' = H / (1 - w^2 m H) on a single-direction, single-joint system
    from robolobe.twin.frf import receptance

    mm, k, c, m = 3.0, 1e5, 20.0, 0.8
    h = receptance([[mm]], [[k]], [[c]], [[1.0]], FREQ)[:, 0, 0]
    h_m = receptance([[mm + m]], [[k]], [[c]], [[1.0]], FREQ)[:, 0, 0]
    w2 = (2 * np.pi * FREQ) ** 2
    np.testing.assert_allclose(h_m, h / (1 - w2 * m * h), rtol=1e-10)


def test_added_mass_with_offset_matches_point_jacobian(robot: Robot, q: np.ndarray) -> None:
    off = np.array([0.1, -0.05, -0.2])
    m = 7.0
    dm = Twin(robot, (AddedMass(m, tuple(off)),)).mass_matrix(q) - Twin(robot).mass_matrix(q)
    jp = point_jacobian(robot, q, TCP_FRAME, off)[..., :3, :]
    np.testing.assert_allclose(dm, m * np.swapaxes(jp, -1, -2) @ jp, rtol=1e-8, atol=1e-8)


def test_added_mass_without_end_effector(robot: Robot, q: np.ndarray) -> None:
    bare = robot.replace(end_effector=None)
    dm = Twin(bare, (AddedMass(5.0),)).mass_matrix(q) - Twin(bare).mass_matrix(q)
    jv = point_jacobian(bare, q, TCP_FRAME)[..., :3, :]
    np.testing.assert_allclose(dm, 5.0 * np.swapaxes(jv, -1, -2) @ jv, rtol=1e-8, atol=1e-8)


# ------------------------------------------------------------- joint effects
def test_joint_stiffness_and_damping_factors(robot: Robot, q: np.ndarray) -> None:
    s = Twin(robot, (JointStiffness(3, 0.5), JointDamping(5, 2.0))).system(q)
    k = robot.stiffness.copy()
    k[2] *= 0.5
    c = robot.damping.copy()
    c[4] *= 2.0
    np.testing.assert_allclose(s.K[0], np.diag(k))
    np.testing.assert_allclose(s.C[0], np.diag(c))
    # softening one joint lowers (never raises) every frequency
    assert np.all(
        _f_undamped(Twin(robot, (JointStiffness(3, 0.5),)), q) <= _f_undamped(Twin(robot), q) + 1e-9
    )


def test_gravity_stiffening_follows_gravity_torque(robot: Robot, q: np.ndarray) -> None:
    eff = GravityStiffening(beta=0.5, tau_ref_Nm=2e4)
    s = Twin(robot, (eff,)).system(q)
    tau = gravity_torques(robot, q)
    expected = robot.stiffness * (1 + 0.5 * np.abs(tau) / 2e4)
    np.testing.assert_allclose(np.diagonal(s.K, axis1=-2, axis2=-1), expected, rtol=1e-12)
    assert np.all(np.abs(tau[:, 1]) > 100)  # axis 2 carries the arm: the term matters
    assert np.all(_f_undamped(Twin(robot, (eff,)), q) >= _f_undamped(Twin(robot), q) - 1e-9)
    s0 = Twin(robot, (GravityStiffening(beta=0.0),)).system(q)
    np.testing.assert_array_equal(s0.K, Twin(robot).system(q).K)


def test_coupled_joint_stiffness(robot: Robot, q: np.ndarray) -> None:
    s = Twin(robot, (CoupledJointStiffness(2e5),)).system(q)
    assert np.all(s.K[:, 1, 2] == 2e5)
    assert np.all(s.K[:, 2, 1] == 2e5)
    k23 = float(np.sqrt(robot.stiffness[1] * robot.stiffness[2]))
    with pytest.raises(InputError, match="positive definite"):
        Twin(robot, (CoupledJointStiffness(1.01 * k23),)).system(q)


def test_friction_damping_falls_with_force_level(robot: Robot, q: np.ndarray) -> None:
    base = Twin(robot).modes(q).zeta
    low = Twin(robot, (FrictionDamping(torque_Nm=5.0, force_N=100.0),)).modes(q).zeta
    high = Twin(robot, (FrictionDamping(torque_Nm=5.0, force_N=1000.0),)).modes(q).zeta
    assert np.all(low[:, :5] > high[:, :5])
    assert np.all(high[:, :5] > base[:, :5])
    s = Twin(robot).system(q)
    dc = FrictionDamping(torque_Nm=5.0, force_N=100.0).added_damping(s)
    dc2 = FrictionDamping(torque_Nm=5.0, force_N=200.0).added_damping(s)
    dc_half = FrictionDamping(torque_Nm=5.0, force_N=50.0).added_damping(s)
    # c_eq = 4 T / (pi w X), X proportional to F: halves when F doubles (below the stick cap).
    # An entry is below the cap at 100 N (hence at 200 N) iff halving the force still raises it.
    free = dc < dc_half
    assert free.any()
    np.testing.assert_allclose(dc2[free], dc[free] / 2, rtol=1e-12)
    zero = FrictionDamping(torque_Nm=0.0).added_damping(s)
    np.testing.assert_array_equal(zero, 0.0)


# ------------------------------------------------------------ extra DOFs
def test_base_compliance_lowers_modes_and_adds_dofs(robot: Robot, q: np.ndarray) -> None:
    twin = Twin(robot, (BaseCompliance(stiffness_Nm_per_rad=2e7, mass_kg=400.0),))
    s = twin.system(q)
    assert s.dof_names[6:] == ("base_rx", "base_ry")
    f0 = _f_undamped(Twin(robot), q)
    f1 = _f_undamped(twin, q)
    # the nominal model is the base-locked (constrained) one: interlacing
    assert np.all(f1[:, :6] <= f0 + 1e-9)
    # a rigid base recovers the nominal model
    stiff = _f_undamped(Twin(robot, (BaseCompliance(stiffness_Nm_per_rad=1e12),)), q)
    np.testing.assert_allclose(stiff[:, :6], f0, rtol=1e-4)


def test_base_translation_carries_the_total_mass(robot: Robot, q: np.ndarray) -> None:
    eff = BaseCompliance(mass_kg=300.0, translational_stiffness_N_per_m=1e9)
    s = Twin(robot, (eff,)).system(q)
    ix = s.dof_names.index("base_x")
    assert s.dof_names[ix : ix + 3] == ("base_x", "base_y", "base_z")
    total = robot.total_mass_kg + 300.0
    block = s.M[:, ix : ix + 3, ix : ix + 3]
    np.testing.assert_allclose(block, np.broadcast_to(total * np.eye(3), block.shape), rtol=1e-12)
    # damping ratio of each base DOF's own oscillator is 5 %
    c = s.C[:, ix, ix]
    np.testing.assert_allclose(c, 2 * 0.05 * np.sqrt(1e9 * total), rtol=1e-12)


def test_link_flexibility(robot: Robot, q: np.ndarray) -> None:
    twin = Twin(robot, (LinkFlexibility(link=3, stiffness_Nm_per_rad=5e6),))
    s = twin.system(q)
    assert s.dof_names[-1] == "flex3"
    jv, jw = s.bodies.jv[..., -1], s.bodies.jw[..., -1]  # (n, nb, 3)
    names = s.bodies.names
    # links 1..3 do not move with the hinge; links 4..6 and the end effector rotate with it
    for i, nm in enumerate(names):
        if nm in ("link1", "link2", "link3"):
            np.testing.assert_array_equal(jv[:, i], 0.0)
            np.testing.assert_array_equal(jw[:, i], 0.0)
        else:
            np.testing.assert_allclose(np.linalg.norm(jw[:, i], axis=-1), 1.0, rtol=1e-12)
            np.testing.assert_allclose(jw[:, i], s.frames[:, 3, :3, 0], rtol=1e-12)  # x of frame 3
    assert np.all(np.linalg.norm(jv[:, names.index("end_effector")], axis=-1) > 0.1)
    assert np.all(_f_undamped(twin, q)[:, :6] <= _f_undamped(Twin(robot), q) + 1e-9)
    stiff = _f_undamped(Twin(robot, (LinkFlexibility(link=3, stiffness_Nm_per_rad=1e11),)), q)
    np.testing.assert_allclose(stiff[:, :6], _f_undamped(Twin(robot), q), rtol=1e-3)


def test_tool_mode_on_rigid_robot_resonates_at_its_frequency(robot: Robot, q: np.ndarray) -> None:
    rigid = robot.with_stiffness(robot.stiffness * 1e8)
    md = Twin(rigid, (ToolMode(f_hz=150.0, zeta=0.02, mass_kg=4.0, direction="y"),)).modes(q)
    assert md.f_hz[:, 0] == pytest.approx(150.0, rel=1e-4)
    assert md.zeta[:, 0] == pytest.approx(0.02, rel=1e-3)


def test_tool_mode_shows_as_a_peak_in_every_posture(robot: Robot, q: np.ndarray) -> None:
    eff = ToolMode(f_hz=90.0, zeta=0.02, mass_kg=2.0, direction="xyz")
    s = Twin(robot, (eff,)).system(q)
    assert s.dof_names[-3:] == ("tool_x", "tool_y", "tool_z")
    f = np.linspace(60.0, 120.0, 601)
    h = Twin(robot, (eff,)).receptance(q, f)
    peak = f[np.argmax(np.abs(h[:, :, 0, 0]), axis=1)]
    # on a heavy robot (M_eff >> 2 kg) the peak stays within a few % of 90 Hz everywhere
    np.testing.assert_allclose(peak, 90.0, rtol=0.05)


# ------------------------------------------------------------ measurement
def test_sensor_misalignment_rotates_the_response(robot: Robot, q: np.ndarray) -> None:
    h = Twin(robot).receptance(q, FREQ)
    eff = SensorMisalignment(rx_rad=0.0, ry_rad=0.0, rz_rad=0.1)
    h_m = Twin(robot, (eff,)).receptance(q, FREQ)
    c, s = np.cos(0.1), np.sin(0.1)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    np.testing.assert_allclose(h_m, rot.T @ h, rtol=1e-12)
    # reciprocity breaks and x picks up y
    asym = np.abs(h_m - np.swapaxes(h_m, -1, -2)).max()
    assert asym > 0.05 * np.abs(h).max()
    zero = Twin(robot, (SensorMisalignment(),)).receptance(q, FREQ)
    np.testing.assert_allclose(zero, h, rtol=1e-15)


def test_sensor_delay_is_linear_phase(robot: Robot, q: np.ndarray) -> None:
    tau = 1.5e-3
    h = Twin(robot).receptance(q, FREQ)
    h_d = Twin(robot, (SensorDelay(tau),)).receptance(q, FREQ)
    np.testing.assert_allclose(np.abs(h_d), np.abs(h), rtol=1e-12)
    ratio = h_d[..., 1:, 0, 0] / h[..., 1:, 0, 0]
    phase = np.unwrap(np.angle(ratio), axis=-1)
    np.testing.assert_allclose(phase, -2 * np.pi * FREQ[1:] * tau * np.ones((3, 1)), atol=1e-9)


# ------------------------------------------------------------ the mechanism
def test_effect_order_does_not_matter(robot: Robot, q: np.ndarray) -> None:
    a = (
        ToolMode(f_hz=120.0),
        AddedMass(3.0),
        SensorDelay(1e-3),
        BaseCompliance(),
        JointStiffness(2, 1.3),
    )
    h1 = Twin(robot, a).receptance(q, FREQ)
    h2 = Twin(robot, a[::-1]).receptance(q, FREQ)
    np.testing.assert_allclose(h1, h2, rtol=1e-9, atol=1e-12 * np.abs(h1).max())


def test_twin_modes_agree_with_its_receptance(robot: Robot, q: np.ndarray) -> None:
    twin = Twin(robot).with_effects(BaseCompliance(), ToolMode(f_hz=70.0), LinkFlexibility())
    md = twin.modes(q)
    h = twin.receptance(q, FREQ)
    np.testing.assert_allclose(md.frf(FREQ), h, rtol=1e-7, atol=1e-8 * np.abs(h).max())
    assert md.n_modes == 6 + 2 + 3 + 1


def test_twin_receptance_methods_agree(robot: Robot, q: np.ndarray) -> None:
    twin = Twin(robot, (ToolMode(f_hz=70.0), SensorDelay(2e-3)))
    h = twin.receptance(q, FREQ)
    np.testing.assert_allclose(
        twin.receptance(q, FREQ, method="modal"), h, rtol=1e-8, atol=1e-10 * np.abs(h).max()
    )
    with pytest.raises(InputError, match="method"):
        twin.receptance(q, FREQ, method="fast")  # type: ignore[arg-type]


def test_twin_rejects_non_effects(robot: Robot) -> None:
    with pytest.raises(InputError, match="effects"):
        Twin(robot, ("added_mass",))  # type: ignore[arg-type]


# ------------------------------------------------------------ validation, files
@pytest.mark.parametrize(
    ("cls", "kwargs", "match"),
    [
        (AddedMass, {"mass_kg": -1.0}, "mass_kg"),
        (AddedMass, {"mass_kg": 1.0, "offset_m": (0, 0)}, "offset_m"),
        (AddedMass, {"mass_kg": 1.0, "offset_m": (0, 0, 9)}, "offset_m"),
        (JointStiffness, {"joint": 7, "factor": 1.0}, "joint"),
        (JointStiffness, {"joint": 2, "factor": 0.0}, "factor"),
        (JointStiffness, {"joint": True, "factor": 1.0}, "joint"),
        (JointDamping, {"joint": 1, "factor": float("nan")}, "factor"),
        (GravityStiffening, {"beta": -1.0}, "beta"),
        (GravityStiffening, {"joints": (2, 2)}, "distinct"),
        (CoupledJointStiffness, {"joints": (3, 3)}, "different"),
        (FrictionDamping, {"force_N": 0.0}, "force_N"),
        (BaseCompliance, {"stiffness_Nm_per_rad": 10.0}, "stiffness"),
        (BaseCompliance, {"translational_stiffness_N_per_m": -5.0}, "translational"),
        (LinkFlexibility, {"link": 6}, "link"),
        (LinkFlexibility, {"axis": (0, 0, 0)}, "axis"),
        (ToolMode, {"zeta": 2.0}, "zeta"),
        (ToolMode, {"direction": "w"}, "direction"),
        (ToolMode, {"f_hz": "fast"}, "f_hz"),
        (SensorMisalignment, {"rx_rad": 2.0}, "rx_rad"),
        (SensorDelay, {"delay_s": 1.0}, "delay_s"),
        (ToolMode, {"mass_in_file": "yes"}, "mass_in_file"),
        (ServoMode, {"joint": 0}, "joint"),
        (ServoMode, {"stiffness_Nm_per_rad": 1.0}, "stiffness"),
        (ServoMode, {"rotor_inertia_kgm2": 0.0}, "rotor_inertia"),
        (TcpOffset, {"offset_m": (0, 0, 2.0)}, "offset_m"),
        (SensorGain, {"gain": (1.0, 0.0, 1.0)}, "gain"),
        (HammerDirection, {"ry_rad": 3.0}, "ry_rad"),
    ],
)
def test_parameter_validation(cls: type[Effect], kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        cls(**kwargs)


@pytest.mark.parametrize("cls", list(EFFECTS.values()))
def test_round_trip(cls: type[Effect]) -> None:
    e = cls()
    d = effect_to_dict(e)
    assert d["name"] == cls.name
    assert all(not isinstance(v, tuple) for v in d.values())
    back = effect_from_dict(d)
    assert back == e


def test_from_dict_errors() -> None:
    with pytest.raises(InputError, match="expected one of"):
        effect_from_dict({"name": "magic"})
    with pytest.raises(InputError, match="unknown parameter"):
        effect_from_dict({"name": "added_mass", "mass": 3.0})
    with pytest.raises(InputError, match=r"model\.toml"):
        effect_from_dict({"name": "added_mass", "mass_kg": -3.0}, source="model.toml[effects][1]")
    with pytest.raises(InputError, match="name"):
        effect_from_dict({"mass_kg": 3.0})


# ------------------------------------------------------------ lab effects (issue 13)
def _static(twin: Twin, q: np.ndarray) -> np.ndarray:
    """Receptance at 0 Hz, shape (n, 3, 3)."""
    return twin.receptance(q, np.array([0.0]))[:, 0]


def test_servo_mode_is_a_series_spring_and_a_low_holding_mode(robot: Robot, q: np.ndarray) -> None:
    ks = 3e5
    twin = Twin(robot, (ServoMode(joint=1, stiffness_Nm_per_rad=ks, rotor_inertia_kgm2=40.0),))
    s = Twin(robot).system(q)
    # static: the joint's compliance is 1/k1 + 1/ks (springs in series)
    Kinv = np.linalg.inv(s.K)
    Kinv[..., 0, 0] += 1.0 / ks
    np.testing.assert_allclose(
        _static(twin, q).real, s.J @ Kinv @ np.swapaxes(s.J, -1, -2), rtol=1e-8
    )
    f_servo = _f_undamped(twin, q)
    assert np.all(f_servo[:, 0] < 0.6 * _f_undamped(Twin(robot), q)[:, 0])  # the holding mode
    # a stiff loop leaves the arm's modes as they were
    stiff = Twin(robot, (ServoMode(joint=1, stiffness_Nm_per_rad=1e11),))
    np.testing.assert_allclose(_f_undamped(stiff, q)[:, :6], _f_undamped(Twin(robot), q), rtol=1e-3)


def test_tcp_offset_sees_the_wrist_rotations(robot: Robot, q: np.ndarray) -> None:
    d = np.array([0.0, 0.0, 0.05])
    twin = Twin(robot, (TcpOffset(offset_m=tuple(d)),))
    s = Twin(robot).system(q)
    r = s.tcp_rotation @ d  # (n, 3)
    # v_p = v + w x r, column by column, in the TCP frame
    jp = np.swapaxes(s.tcp_rotation, -1, -2) @ (
        s.tcp_jv + np.cross(s.tcp_jw, r[:, :, None], axis=1)
    )
    np.testing.assert_allclose(
        _static(twin, q).real, jp @ np.linalg.inv(s.K) @ np.swapaxes(jp, -1, -2), rtol=1e-8
    )
    assert not np.allclose(_static(twin, q), _static(Twin(robot), q), rtol=1e-3)


def test_hammer_direction_mixes_columns_and_a_rotated_sensor_rows(
    robot: Robot, q: np.ndarray
) -> None:
    ang = {"rx_rad": 0.05, "ry_rad": 0.17, "rz_rad": -0.03}
    H = Twin(robot).receptance(q, FREQ)
    Hh = Twin(robot, (HammerDirection(**ang),)).receptance(q, FREQ)
    Hs = Twin(robot, (SensorMisalignment(**ang),)).receptance(q, FREQ)
    # H is symmetric, so an off-axis hammer is the rotated sensor's transpose
    np.testing.assert_allclose(Hh, np.swapaxes(Hs, -1, -2), rtol=1e-10, atol=1e-20)
    assert not np.allclose(Hh, Hs, rtol=1e-3)
    assert not np.allclose(Hh, H, rtol=1e-3)


def test_sensor_gain_scales_its_channel_only(robot: Robot, q: np.ndarray) -> None:
    H = Twin(robot).receptance(q, FREQ)
    Hg = Twin(robot, (SensorGain(gain=(1.0, 1.12, 1.0)),)).receptance(q, FREQ)
    np.testing.assert_allclose(Hg[..., 1, :], 1.12 * H[..., 1, :], rtol=1e-12)
    np.testing.assert_allclose(Hg[..., [0, 2], :], H[..., [0, 2], :], rtol=1e-12)


def test_local_tool_mode_keeps_the_arm_mass(robot: Robot, q: np.ndarray) -> None:
    ee = robot.end_effector
    assert ee is not None
    m = 0.1 * ee.mass_kg  # below the arm's effective mass at the TCP (M stays definite)
    stiff_local = Twin(robot, (ToolMode(f_hz=5000.0, mass_kg=m, direction="x", mass_in_file=True),))
    stiff_extra = Twin(robot, (ToolMode(f_hz=5000.0, mass_kg=m, direction="x"),))
    f0 = _f_undamped(Twin(robot), q)
    # a rigid local mode changes nothing below it; an extra mass lowers the modes
    np.testing.assert_allclose(_f_undamped(stiff_local, q)[:, :6], f0, rtol=2e-3)
    assert np.all(_f_undamped(stiff_extra, q)[:, 0] < 0.995 * f0[:, 0])
    with pytest.raises(InputError, match="mass_in_file"):
        Twin(robot, (ToolMode(mass_kg=2 * ee.mass_kg, direction="x", mass_in_file=True),)).system(q)


@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_link_bending_axes_are_across_the_next_joint(name: str) -> None:
    rb = load_robot(name)
    qq = np.radians([[10.0, -60.0, 40.0, 10.0, 30.0, 0.0]])
    for link in range(1, 6):
        a1, a2 = (np.array(a) for a in link_bending_axes(rb, link))
        assert abs(a1 @ a2) < 1e-9
        for a in (a1, a2):
            # every variant evaluates (B's links 1, 3-5 about y used to be singular)
            f = _f_undamped(Twin(rb, (LinkFlexibility(link=link, axis=tuple(a)),)), qq)
            assert np.all(np.isfinite(f))


def test_link_flexibility_about_the_next_joint_axis_is_refused() -> None:
    rb = load_robot("B")
    qq = np.radians([[10.0, -60.0, 40.0, 10.0, 30.0, 0.0]])
    with pytest.raises(InputError, match="series compliance"):
        Twin(rb, (LinkFlexibility(link=3, axis=(0.0, 1.0, 0.0)),)).system(qq)
