"""Optional robot compliances: joint tilt and end-effector mount DOFs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import tomli_w

from robolobe.robots import load_robot, robot_to_toml, robots_allclose, sample_postures
from robolobe.robots.io import robot_to_dict
from robolobe.robots.kinematics import tcp_pose
from robolobe.robots.transforms import pose_from_xyz_zyx
from robolobe.twin.model import Twin
from robolobe.twin.params import PARAMETER_GROUPS, ParametrizedTwin, apply_parameters

Q = np.radians([[-2, 21, -27, 5, 1, -29], [-60, 50, -120, 115, -66, -197]])


def _plain_b():
    """Robot B with every optional compliance removed (nominal six-spring model)."""
    b = load_robot("B")
    for i in range(6):
        b = b.with_tilt(i, None, None)
    return b.with_mount(None, None)


def _compliant(r):
    return (
        r.with_tilt(1, (6e7, 4e7), (900.0, 700.0))
        .with_tilt(2, (3e7, 2e7), (500.0, 400.0))
        .with_mount((3e6, 2e6), (60.0, 50.0))
    )


def test_file_round_trip_and_dof_names(tmp_path: Path) -> None:
    r = _compliant(_plain_b())
    p = tmp_path / "r.toml"
    p.write_text(robot_to_toml(r))
    again = load_robot(p)
    assert robots_allclose(again, r)
    assert not robots_allclose(again, _plain_b())
    names = Twin(again).system(Q[0]).dof_names
    assert names == (
        "q1", "q2", "q3", "q4", "q5", "q6",
        "tilt2x", "tilt2y", "tilt3x", "tilt3y", "mount_x", "mount_y",
    )  # fmt: skip


def test_plain_file_keeps_exact_meaning(tmp_path: Path) -> None:
    # a FORMATS.md section 1 file (no optional keys) is the six-spring model
    plain = _plain_b()
    d = robot_to_dict(plain)
    assert "tilt_stiffness_Nm_per_rad" not in d["joints"][0]
    assert "mount_stiffness_Nm_per_rad" not in d["end_effector"]
    p = tmp_path / "plain.toml"
    p.write_text(tomli_w.dumps(d))
    s = Twin(load_robot(p)).system(Q)
    assert s.n_dof == 6
    np.testing.assert_array_equal(s.K[0], np.diag(plain.stiffness))


def test_stiff_compliances_recover_the_six_spring_model() -> None:
    plain = _plain_b()
    stiff = (
        plain.with_tilt(1, (1e12, 1e12), (0.0, 0.0))
        .with_tilt(0, (1e12, 1e12), (0.0, 0.0))
        .with_mount((1e12, 1e12), (0.0, 0.0))
    )
    f0 = Twin(plain).modes(Q).f_hz
    f1 = Twin(stiff).modes(Q).f_hz[:, :6]
    np.testing.assert_allclose(f1, f0, rtol=1e-4)


def test_mount_tcp_jacobian_matches_finite_rotation_of_the_tool() -> None:
    # independent: rotating the tool frame about flange x/y moves the TCP as the mount DOFs say
    r = _compliant(_plain_b())
    s = Twin(r).system(Q[1])
    i = s.dof_names.index("mount_x")
    eps = 1e-7
    p0 = tcp_pose(r, Q[1])[:3, 3]
    for col, zyx in ((i, (0.0, 0.0, eps)), (i + 1, (0.0, eps, 0.0))):
        tool = pose_from_xyz_zyx(np.zeros(3), np.array(zyx)) @ r.tool
        dp = (tcp_pose(r.replace(tool=tool), Q[1])[:3, 3] - p0) / eps
        np.testing.assert_allclose(s.tcp_jv[:, col], dp, atol=1e-6)


def test_tilt_lowers_frequencies_and_static_compliance_adds() -> None:
    plain = _plain_b()
    comp = _compliant(plain)
    f0 = Twin(plain).modes(Q).f_hz
    f1 = Twin(comp).modes(Q).f_hz
    assert np.all(f1[:, :6] <= f0 * (1 + 1e-9))  # Rayleigh: added flexibility
    h0 = Twin(plain).receptance(Q, [0.0])[:, 0].real
    h1 = Twin(comp).receptance(Q, [0.0])[:, 0].real
    assert np.all(np.linalg.eigvalsh(h1 - h0) > -1e-15)


def test_solve_and_modal_frf_agree_with_compliances() -> None:
    t = Twin(_compliant(_plain_b()))
    f = np.linspace(2.0, 60.0, 40)
    a = t.receptance(Q, f)
    b = t.receptance(Q, f, method="modal")
    assert np.max(np.abs(a - b)) < 1e-9 * np.max(np.abs(a))


def test_parametrized_twin_with_compliance_dofs() -> None:
    r = _compliant(_plain_b())
    q = sample_postures(r, 3, np.random.default_rng(0))
    groups = list(PARAMETER_GROUPS)
    theta = np.random.default_rng(1).normal(0.0, 0.1, sum(PARAMETER_GROUPS.values()))
    theta[-6:] = 3.0 * np.abs(theta[-6:])  # load stiffening (>= 0) beside the compliance DOFs
    pt = ParametrizedTwin(r, q, groups, n_modes=8)
    m1 = pt.modes(theta)
    m2 = Twin(apply_parameters(r, groups, theta)).modes(q)
    np.testing.assert_allclose(m1.f_hz, m2.f_hz, rtol=1e-9)
    np.testing.assert_allclose(m1.zeta, m2.zeta, rtol=1e-7)
    # Jacobian of the frequencies against finite differences
    jac = pt.log_jacobian(theta)
    v0 = np.log(pt.values(theta))
    for i in (1, 12, 20, 38):
        d = np.zeros_like(theta)
        d[i] = 1e-6
        fd = (np.log(pt.values(theta + d)) - v0) / 1e-6
        assert np.max(np.abs(fd[..., 0] - jac[..., 0, i])) < 0.05 * max(
            1e-3, np.max(np.abs(fd[..., 0]))
        )


@pytest.mark.parametrize(
    ("table", "key", "value", "needle"),
    [
        ("joint", "tilt_stiffness_Nm_per_rad", [-5.0, 1e7],
         "[[joints]][2].tilt_stiffness_Nm_per_rad[1]: expected a positive number"),
        ("ee", "mount_stiffness_Nm_per_rad", [1e6, 1e14],
         "end_effector.mount_stiffness_Nm_per_rad[2]: expected a number <="),
    ],
)  # fmt: skip
def test_cli_refuses_out_of_range_compliance_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], table: str, key: str, value, needle: str
) -> None:
    from robolobe.cli import main as cli_main

    d = robot_to_dict(_compliant(_plain_b()))
    (d["joints"][1] if table == "joint" else d["end_effector"])[key] = value
    p = tmp_path / "bad.toml"
    p.write_text(tomli_w.dumps(d))
    post = tmp_path / "p.csv"
    post.write_text("posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\nT1,-2,21,-27,5,1,-29\n")
    with pytest.raises(SystemExit) as exc:
        cli_main.main(["simulate", str(p), "--postures", str(post), "-o", str(tmp_path / "o")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert needle in err[0], err
    assert not (tmp_path / "o").exists()
