"""Tool-point dynamics in the feed frame: robot modes plus spindle/tool modes, rotated.

The robot's receptance at the TCP (posture dependent) is a 3x3 matrix in the
TCP frame; the spindle/holder/tool adds its own modes in the tool's x/y
directions (here taken as the TCP x/y axes). For the stability solvers the
sum is expressed in the feed frame (docs/guide/physics.md, physics)::

    H_f = R^T H R,   R = [e_feed, e_normal, e_axis]   (columns in the TCP frame)

and the 2x2 (feed, normal) block is kept. The frame follows Altintas'
convention (:mod:`robolobe.sld.directional`): ``e_axis`` points from the tool
tip toward the spindle, ``e_normal = e_axis x e_feed`` for a cutter turning
clockwise seen from the spindle (M03); for a counter-clockwise cutter the
normal is flipped, which mirrors the geometry onto the clockwise case.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.sld.frf import ModalModel

__all__ = ["feed_frame", "rotate_frf", "tool_point_model"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


def feed_frame(
    feed: ArrayLike, axis: ArrayLike = (0.0, 0.0, -1.0), *, rotation: str = "cw"
) -> FloatArray:
    """Rotation from the TCP frame to the (feed, normal, axis) frame.

    Parameters
    ----------
    feed : array_like, shape (..., 3)
        Feed direction in the TCP frame (need not be unit, nor exactly
        perpendicular to the axis: its component along the axis is removed).
    axis : array_like, shape (..., 3), default (0, 0, -1)
        Tool axis in the TCP frame, pointing from the tool tip toward the
        spindle. The default assumes the TCP z axis points out of the tool
        (from the flange toward the tip), as for a tool defined by an offset
        along the flange z axis.
    rotation : {"cw", "ccw"}, default "cw"
        Spindle rotation seen from the spindle toward the tip.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``R`` with columns ``e_feed, e_normal, e_axis`` in TCP coordinates.

    Raises
    ------
    InputError
        When the feed is (nearly) parallel to the axis (a plunge) or zero.
    """
    f = np.asarray(feed, dtype=np.float64)
    z = np.asarray(axis, dtype=np.float64)
    if f.shape[-1:] != (3,) or z.shape[-1:] != (3,):
        raise InputError(f"feed/axis: expected 3-vectors, found shapes {f.shape}, {z.shape}")
    if rotation not in ("cw", "ccw"):
        raise InputError(f"rotation: expected 'cw' or 'ccw', found {rotation!r}")
    zn = np.linalg.norm(z, axis=-1, keepdims=True)
    if np.any(zn < 1e-12):
        raise InputError("axis: expected a non-zero tool axis")
    z = z / zn
    z, f = np.broadcast_arrays(z, f)
    fx = f - np.sum(f * z, axis=-1, keepdims=True) * z
    fn = np.linalg.norm(fx, axis=-1, keepdims=True)
    fmag = np.linalg.norm(f, axis=-1, keepdims=True)
    if np.any(fn <= 1e-6 * np.maximum(fmag, 1e-300)) or np.any(fmag == 0):
        raise InputError(
            "feed: expected a feed direction with a component across the tool axis, "
            "found one parallel to the axis (plunging) or zero"
        )
    x = fx / fn
    y = np.cross(z, x)
    if rotation == "ccw":
        y = -y
    return np.stack([x, y, z], axis=-1)


def tool_point_model(
    rotation: ArrayLike,
    robot: ModalModel | None = None,
    tool: ModalModel | None = None,
) -> ModalModel:
    """Tool-point modal model in the feed frame (2-D: feed x, normal y).

    Parameters
    ----------
    rotation : array_like, shape (..., 3, 3)
        From :func:`feed_frame` (batched over waypoints).
    robot : ModalModel, optional
        Robot modes at the TCP, ``dim == 3`` (TCP x, y, z), batch shape
        broadcasting with ``rotation`` (e.g. per waypoint).
    tool : ModalModel, optional
        Spindle/holder/tool modes in the TCP x/y directions, ``dim == 2`` (or
        3), usually unbatched.

    Returns
    -------
    ModalModel
        All modes, rotated, ``dim == 2``; batch shape the broadcast of the
        inputs.
    """
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape[-2:] != (3, 3):
        raise InputError(f"rotation: expected shape (..., 3, 3), found {r.shape}")
    parts = []
    if robot is not None:
        if robot.dim != 3:
            raise InputError(f"robot: expected TCP-frame (3-D) modes, found dim {robot.dim}")
        parts.append(robot)
    if tool is not None:
        if tool.dim == 2:
            res = np.zeros((*tool.residues.shape[:-2], 3, 3))
            res[..., :2, :2] = tool.residues
            tool = ModalModel(tool.omega, tool.zeta, res)
        elif tool.dim != 3:
            raise InputError(f"tool: expected 2-D or 3-D modes, found dim {tool.dim}")
        parts.append(tool)
    if not parts:
        raise InputError("tool_point_model: give robot modes, tool modes or both")
    model = parts[0].concat(*parts[1:]) if len(parts) > 1 else parts[0]
    return model.rotated(r[..., :, :2])


def rotate_frf(frf: ArrayLike, rotation: ArrayLike) -> ComplexArray:
    """Feed-frame 2x2 block of a TCP-frame receptance: ``(R^T H R)[:2, :2]``.

    Parameters
    ----------
    frf : array_like, shape (..., n_freq, 3, 3), complex
        Receptance in the TCP frame [m/N] (e.g. measured or from the twin).
    rotation : array_like, shape (..., 3, 3)
        From :func:`feed_frame`; batch shapes broadcast.

    Returns
    -------
    ndarray, shape (..., n_freq, 2, 2), complex
    """
    h = np.asarray(frf)
    r = np.asarray(rotation, dtype=np.float64)
    if h.shape[-2:] != (3, 3) or r.shape[-2:] != (3, 3):
        raise InputError(
            "frf/rotation: expected shapes (..., n_freq, 3, 3) and (..., 3, 3), "
            f"found {h.shape}, {r.shape}"
        )
    r2 = r[..., None, :, :2]
    return np.einsum("...ia,...ij,...jb->...ab", r2, h, r2)
