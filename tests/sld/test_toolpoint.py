"""Tool-point FRF: robot + tool modes rotated into the feed frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.sld import ModalModel, feed_frame, rotate_frf, tool_point_model


def test_feed_frame_is_altintas_frame() -> None:
    # TCP z out of the tool: tool axis (tip -> spindle) is -z; feed along TCP x
    r = feed_frame([1.0, 0.0, 0.0])
    np.testing.assert_allclose(r[:, 0], [1, 0, 0])
    np.testing.assert_allclose(r[:, 2], [0, 0, -1])
    np.testing.assert_allclose(r[:, 1], np.cross(r[:, 2], r[:, 0]))  # normal = axis x feed
    assert np.linalg.det(r) == pytest.approx(1.0)
    # counter-clockwise spindles mirror the normal
    rc = feed_frame([1.0, 0.0, 0.0], rotation="ccw")
    np.testing.assert_allclose(rc[:, 1], -r[:, 1])


def test_feed_frame_batched_and_projected() -> None:
    rng = np.random.default_rng(4)
    feed = rng.normal(size=(10, 3))
    axis = rng.normal(size=(10, 3))
    r = feed_frame(feed, axis)
    np.testing.assert_allclose(
        np.einsum("nji,njk->nik", r, r), np.broadcast_to(np.eye(3), (10, 3, 3)), atol=1e-12
    )
    # feed keeps its direction across the axis
    fx = feed - np.sum(feed * r[..., 2], axis=-1, keepdims=True) * r[..., 2]
    np.testing.assert_allclose(r[..., 0], fx / np.linalg.norm(fx, axis=-1, keepdims=True))


def test_plunge_is_rejected() -> None:
    with pytest.raises(InputError, match="plung"):
        feed_frame([0.0, 0.0, 1.0])


def test_tool_point_model_equals_rotated_frf() -> None:
    rng = np.random.default_rng(5)
    wr = 2 * math.pi * rng.uniform(5, 40, (3, 5))
    robot = ModalModel.from_shapes(wr, np.full((3, 5), 0.03), rng.normal(size=(3, 5, 3)) * 0.05)
    tool = ModalModel.from_directional([900.0, 950.0], [0.03, 0.03], [2e7, 3e7], ["xx", "yy"])
    ang = rng.uniform(0, 2 * math.pi, 3)
    r = feed_frame(np.stack([np.cos(ang), np.sin(ang), 0 * ang], -1))
    tp = tool_point_model(r, robot, tool)
    assert tp.dim == 2
    assert tp.batch_shape == (3,)
    assert tp.n_modes == 7
    w = np.linspace(2, 8000, 300)
    tool3 = np.zeros((2, 3, 3))
    tool3[:, :2, :2] = tool.residues
    h_tcp = robot.frf(w) + ModalModel(tool.omega, tool.zeta, tool3).frf(w)
    np.testing.assert_allclose(tp.frf(w), rotate_frf(h_tcp, r), rtol=1e-10, atol=1e-18)


def test_isotropic_spindle_is_rotation_invariant() -> None:
    tool = ModalModel.isotropic([1500.0], [0.02], [4e7])
    w = np.linspace(5000, 12000, 40)
    feeds = [[1, 0, 0], [0, 1, 0], [1, 1, 0], [-0.3, 0.8, 0.0]]
    frfs = [tool_point_model(feed_frame(f), tool=tool).frf(w) for f in feeds]
    for h in frfs[1:]:
        np.testing.assert_allclose(h, frfs[0], atol=1e-18)


def test_rotation_moves_robot_compliance_between_feed_and_normal() -> None:
    # a robot soft only along TCP x: feeding along x puts it in the feed FRF,
    # feeding along y puts it in the normal FRF
    robot = ModalModel.from_directional([12.0], [0.03], [5e5], ["xx"], dim=3)
    w = np.array([2 * math.pi * 12.0])
    along = tool_point_model(feed_frame([1, 0, 0]), robot).frf(w)[0]
    across = tool_point_model(feed_frame([0, 1, 0]), robot).frf(w)[0]
    assert abs(along[0, 0]) > 1e3 * abs(along[1, 1])
    assert abs(across[1, 1]) > 1e3 * abs(across[0, 0])
    np.testing.assert_allclose(along[0, 0], across[1, 1])


def test_tool_point_input_errors() -> None:
    r = feed_frame([1, 0, 0])
    with pytest.raises(InputError, match="give robot"):
        tool_point_model(r)
    with pytest.raises(InputError, match="3-D"):
        tool_point_model(r, ModalModel.isotropic([10.0], [0.02], [1e6]))
