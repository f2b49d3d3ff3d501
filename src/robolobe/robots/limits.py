"""Joint limits, linear constraints (parallelograms) and posture sampling.

Postures ``q`` are controller axis angles [rad], shape ``(..., 6)``; bounds
are inclusive with a small tolerance (``TOL_RAD``) for round-off.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.robots.model import LinearConstraint, Robot

__all__ = [
    "TOL_RAD",
    "as_postures",
    "check_posture",
    "constraint_label",
    "posture_violations",
    "sample_postures",
    "within_constraints",
    "within_joint_limits",
    "within_limits",
]

FloatArray = NDArray[np.float64]

TOL_RAD = 1e-9
"""Tolerance [rad] on every bound (round-off of degree/radian conversions)."""


def as_postures(q_rad: ArrayLike, name: str = "q_rad") -> FloatArray:
    """Joint angles as an ``(n, 6)`` float array, or an InputError naming ``name``.

    The one validator of posture arrays given to the library (predictors,
    calibration, planning).

    Parameters
    ----------
    q_rad : array_like, shape (n, 6) or (6,)
        Joint angles [rad]; one posture may be given as shape (6,).
    name : str
        The argument's name in messages.

    Returns
    -------
    ndarray, shape (n, 6)

    Raises
    ------
    InputError
        Not numbers, a shape other than (n, 6) with n >= 1, or NaN/inf.

    Examples
    --------
    >>> as_postures([0.0, 0.5, -0.5, 0.0, 0.3, 0.0]).shape
    (1, 6)
    >>> as_postures([[0.0, 0.5, -0.5]], name="q_test")
    Traceback (most recent call last):
    ...
    robolobe.errors.InputError: q_test: expected joint angles in rad of shape (n, 6) ... (1, 3)
    """
    try:
        q = np.array(q_rad, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected joint angles in rad, found non-numbers") from None
    if q.ndim == 1:
        q = q[None, :]
    if q.ndim != 2 or q.shape[1] != 6 or len(q) == 0:
        raise InputError(
            f"{name}: expected joint angles in rad of shape (n, 6) with n >= 1, found shape "
            f"{q.shape}"
        )
    bad = ~np.isfinite(q).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(f"{name}: expected finite joint angles, found NaN or inf in posture {i}")
    return q


def _q(q: ArrayLike) -> FloatArray:
    arr = np.asarray(q, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 6:
        raise InputError(f"q: expected shape (..., 6), found {arr.shape}")
    return arr


def within_joint_limits(robot: Robot, q: ArrayLike) -> NDArray[np.bool_]:
    """Whether each posture is inside the joint limits; shape (...,)."""
    arr = _q(q)
    return np.all((arr >= robot.q_min - TOL_RAD) & (arr <= robot.q_max + TOL_RAD), axis=-1)


def within_constraints(robot: Robot, q: ArrayLike) -> NDArray[np.bool_]:
    """Whether each posture satisfies all linear constraints; shape (...,)."""
    arr = _q(q)
    ok = np.ones(arr.shape[:-1], dtype=bool)
    for c in robot.constraints:
        v = arr @ c.coeffs
        ok &= (v >= c.lo_rad - TOL_RAD) & (v <= c.hi_rad + TOL_RAD)
    return ok


def within_limits(robot: Robot, q: ArrayLike) -> NDArray[np.bool_]:
    """Whether each posture is inside the joint limits AND the constraints.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Axis angles [rad].

    Returns
    -------
    ndarray of bool, shape (...,)
    """
    return within_joint_limits(robot, q) & within_constraints(robot, q)


def _num(x: float) -> str:
    s = f"{x:.3f}".rstrip("0")
    return s + "0" if s.endswith(".") else s


def _bound(x: float) -> str:
    return f"{x:.6g}"


def constraint_label(c: LinearConstraint) -> str:
    """Human-readable left-hand side of a constraint, e.g. ``q3_deg - q2_deg``."""
    parts: list[str] = []
    for i, a in enumerate(c.coeffs):
        if a == 0:
            continue
        mag = abs(a)
        term = f"q{i + 1}_deg" if mag == 1 else f"{_bound(mag)}*q{i + 1}_deg"
        if not parts:
            parts.append(term if a > 0 else f"-{term}")
        else:
            parts.append(f"{'+' if a > 0 else '-'} {term}")
    return " ".join(parts)


def posture_violations(robot: Robot, q: ArrayLike) -> list[str]:
    """All limit/constraint violations of one posture, as readable strings.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (6,)
        Axis angles [rad].

    Returns
    -------
    list of str
        Empty if the posture is valid; else e.g. ``"q3_deg = 170.0 outside [-120, 168]"``.
    """
    arr = _q(q)
    if arr.shape != (6,):
        raise InputError(f"q: expected shape (6,), found {arr.shape}")
    out = []
    if not np.all(np.isfinite(arr)):
        out.append(f"expected finite angles, found {np.degrees(arr).tolist()}")
        return out
    for i in range(6):
        lo, hi = robot.q_min[i], robot.q_max[i]
        if not lo - TOL_RAD <= arr[i] <= hi + TOL_RAD:
            out.append(
                f"q{i + 1}_deg = {_num(math.degrees(arr[i]))} outside "
                f"[{_bound(math.degrees(lo))}, {_bound(math.degrees(hi))}]"
            )
    for k, c in enumerate(robot.constraints):
        v = float(arr @ c.coeffs)
        if not c.lo_rad - TOL_RAD <= v <= c.hi_rad + TOL_RAD:
            out.append(
                f"constraint {k + 1}: {constraint_label(c)} = {_num(math.degrees(v))} outside "
                f"[{_bound(math.degrees(c.lo_rad))}, {_bound(math.degrees(c.hi_rad))}]"
            )
    return out


def check_posture(
    robot: Robot,
    q: ArrayLike,
    *,
    posture_id: str | int | None = None,
    source: str | None = None,
) -> None:
    """Raise :class:`InputError` if a posture violates a limit or constraint.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (6,)
        Axis angles [rad].
    posture_id : str or int, optional
        Named in the message (``posture 'p05': ...``).
    source : str, optional
        File and line, e.g. ``"postures.csv:7"``; prefixes the message.

    Raises
    ------
    InputError
        e.g. ``postures.csv:7: posture 'p05': q3_deg = 170.0 outside [-120, 168]``
        (the first violation; the count of further ones is appended).
    """
    problems = posture_violations(robot, q)
    if not problems:
        return
    who = f"posture {posture_id!r}: " if posture_id is not None else "posture: "
    more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
    raise InputError(f"{who}{problems[0]}{more} for robot {robot.name!r}", source=source)


def sample_postures(
    robot: Robot,
    n: int,
    rng: np.random.Generator,
    ranges_deg: ArrayLike | None = None,
    *,
    max_batches: int = 200,
) -> FloatArray:
    """Uniform random postures in (joint limits ∩ ranges) satisfying the constraints.

    Rejection sampling from the box.

    Parameters
    ----------
    robot : Robot
    n : int
        Number of postures.
    rng : numpy.random.Generator
    ranges_deg : array_like, shape (6, 2), optional
        ``[min, max]`` per joint [deg], intersected with the joint limits
        (e.g. the seed paper's tested ranges).
    max_batches : int
        Give up after this many rejection batches.

    Returns
    -------
    ndarray, shape (n, 6)
        Axis angles [rad].

    Raises
    ------
    InputError
        When the ranges do not overlap the limits or the constraints leave
        (almost) nothing of the box.
    """
    if n < 0:
        raise InputError(f"n: expected a non-negative count, found {n}")
    lo, hi = robot.q_min.copy(), robot.q_max.copy()
    if ranges_deg is not None:
        r = np.radians(np.asarray(ranges_deg, dtype=np.float64))
        if r.shape != (6, 2):
            raise InputError(f"ranges_deg: expected shape (6, 2), found {r.shape}")
        lo, hi = np.maximum(lo, r[:, 0]), np.minimum(hi, r[:, 1])
        bad = np.flatnonzero(lo > hi)
        if bad.size:
            i = int(bad[0])
            raise InputError(
                f"ranges_deg: q{i + 1} range {np.degrees(r[i]).tolist()} does not overlap the "
                f"joint limits [{_bound(math.degrees(robot.q_min[i]))}, "
                f"{_bound(math.degrees(robot.q_max[i]))}] of robot {robot.name!r}"
            )
    out = np.empty((0, 6))
    batch = max(4 * n, 256)
    for _ in range(max_batches):
        if out.shape[0] >= n:
            break
        cand = rng.uniform(lo, hi, size=(batch, 6))
        out = np.concatenate([out, cand[within_constraints(robot, cand)]])
    if out.shape[0] < n:
        raise InputError(
            f"ranges_deg: the constraints of robot {robot.name!r} leave too little of the "
            f"sampling box (found {out.shape[0]} of {n} postures in {max_batches * batch} draws)"
        )
    return out[:n]
