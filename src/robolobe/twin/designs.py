"""Posture designs for hammer campaigns, mirroring the seed paper.

docs/references.md: seed paper in numbers: robot A was tested in ~254 postures over its tested
joint ranges; robot B in 25 (20 for training, the 5 of the paper's Table 3
for testing); robot C in 20 one-sided training postures (mostly negative
q1), then 4 added on the other side (Table 5), and tested in the 5 of
Table 6.

Training postures are space-filling: a scrambled Sobol sequence scaled to the
tested ranges (clipped to the robot's joint limits), rounded to whole degrees
like the paper's postures, with every posture outside the robot's limits or
constraints skipped (the first ``n`` valid points of a low-discrepancy
sequence stay evenly spread over the valid region).

A design is a :class:`pandas.DataFrame` with columns ``posture_id``,
``q1_deg`` .. ``q6_deg`` and ``role`` ("train", "added", "test"): written
with ``to_csv(index=False)`` it is a valid ``postures.csv`` (the extra
``role`` column is allowed). The designs for the built-in robots made with
:data:`DEFAULT_SEED` ship in ``robolobe/data/designs/{A,B,C}.csv``
(:func:`load_seed_design`); ``python -m robolobe.twin.designs DIR`` writes
them again.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray
from scipy.stats import qmc

from robolobe.errors import InputError

__all__ = [
    "B_TEST_DEG",
    "C_ADDED_DEG",
    "C_ONE_SIDED_Q1_DEG",
    "C_TEST_DEG",
    "DEFAULT_SEED",
    "DESIGN_COLUMNS",
    "SEED_SIZES",
    "TESTED_RANGES_DEG",
    "design_arrays",
    "load_seed_design",
    "random_design",
    "seed_design",
    "space_filling_design",
    "write_seed_designs",
]

DEFAULT_SEED = 20250611
"""Seed of the shipped designs (changing it changes ``data/designs``)."""

DESIGN_COLUMNS: tuple[str, ...] = ("posture_id", *(f"q{i}_deg" for i in range(1, 7)), "role")

Ranges = tuple[tuple[float, float], ...]

TESTED_RANGES_DEG: dict[str, Ranges] = {
    "A": ((-50, 50), (-90, -50), (70, 150), (-300, 300), (-90, 90), (-300, 300)),
    "B": ((-60, 87), (-28, 56), (-127, -16), (-158, 232), (-93, 124), (-283, 201)),
    "C": ((-59, 47), (-10, 48), (-30, 79), (-184, 190), (-116, 114), (-360, 296)),
}
"""Tested joint ranges of the seed paper (Table 2) [deg]."""

B_TEST_DEG: tuple[tuple[float, ...], ...] = (
    (-2, 21, -27, 5, 1, -29),
    (-60, 50, -120, 115, -66, -197),
    (23, -28, -101, -82, 124, 168),
    (59, 51, -83, 180, 112, 7),
    (30, 30, -102, -145, 106, -11),
)
"""Robot B test postures, seed paper Table 3 [deg]."""

C_ADDED_DEG: tuple[tuple[float, ...], ...] = (
    (12, 26, 9, 50, -116, -286),
    (23, 6, -21, -117, -26, -37),
    (32, 36, 35, 143, 46, -18),
    (38, 5, 11, -92, 114, 152),
)
"""Robot C postures added to the training set, seed paper Table 5 (targets 21-24) [deg]."""

C_TEST_DEG: tuple[tuple[float, ...], ...] = (
    (39, 8, 8, 98, -18, -30),
    (47, -10, 36, 74, -89, -13),
    (-3, 48, 20, -129, -57, -2),
    (-2, 20, -21, -167, -66, 180),
    (-6, -6, 36, 83, 100, 29),
)
"""Robot C test postures, seed paper Table 6 [deg]."""

C_ONE_SIDED_Q1_DEG: tuple[float, float] = (-59.0, 0.0)
"""q1 range of robot C's 20 initial (one-sided, "left side") training postures [deg]."""

SEED_SIZES: dict[str, dict[str, int]] = {
    "A": {"train": 254},
    "B": {"train": 20, "test": 5},
    "C": {"train": 20, "added": 4, "test": 5},
}
"""Postures per role in the seed designs."""


def _limits_deg(robot: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    return np.degrees(np.asarray(robot.q_min, dtype=float)), np.degrees(
        np.asarray(robot.q_max, dtype=float)
    )


def _valid(robot: Any, q_rad: NDArray[np.float64]) -> NDArray[np.bool_]:
    from robolobe.robots.limits import within_limits

    return np.asarray(within_limits(robot, q_rad), dtype=bool).reshape(q_rad.shape[0])


def _frame(ids: Sequence[str], q_deg: NDArray[np.float64], roles: Sequence[str]) -> pd.DataFrame:
    data: dict[str, Any] = {"posture_id": list(ids)}
    for i in range(6):
        data[f"q{i + 1}_deg"] = np.asarray(q_deg, dtype=float)[:, i]
    data["role"] = list(roles)
    return pd.DataFrame(data, columns=list(DESIGN_COLUMNS))


def space_filling_design(
    robot: Any,
    n: int,
    rng: np.random.Generator,
    *,
    ranges_deg: Sequence[tuple[float, float]] | None = None,
    id_prefix: str = "P",
    first_number: int = 1,
    role: str = "train",
    round_deg: float | None = 1.0,
) -> pd.DataFrame:
    """``n`` space-filling postures within the robot's limits.

    Parameters
    ----------
    robot : Robot
        Joint limits (``q_min``, ``q_max``) and constraints are respected.
    n : int
        Number of postures (>= 1).
    rng : numpy.random.Generator
        Scrambles the Sobol sequence.
    ranges_deg : sequence of 6 (low, high), optional
        Ranges to cover [deg] (default: the joint limits); clipped to the
        limits.
    id_prefix : str
        Posture ids are ``id_prefix`` plus a zero-padded number.
    first_number : int
        Number of the first posture id.
    role : str
        Value of the ``role`` column.
    round_deg : float or None
        Round angles to multiples of this [deg] (None: no rounding).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`DESIGN_COLUMNS`, ``n`` rows.

    Raises
    ------
    InputError
        Bad ranges, or fewer than ``n`` valid postures among 2^20 candidates.
    """
    if not (isinstance(n, int | np.integer) and n >= 1):
        raise InputError(f"expected n >= 1, found {n!r}", source="space_filling_design(n)")
    lo_lim, hi_lim = _limits_deg(robot)
    if ranges_deg is None:
        lo, hi = lo_lim.copy(), hi_lim.copy()
    else:
        r = np.asarray(ranges_deg, dtype=float)
        if r.shape != (6, 2) or not np.all(np.isfinite(r)) or np.any(r[:, 0] > r[:, 1]):
            raise InputError(
                "expected 6 ranges (low, high) in degrees, found "
                f"{np.asarray(ranges_deg).tolist()}",
                source="space_filling_design(ranges_deg)",
            )
        lo, hi = np.maximum(r[:, 0], lo_lim), np.minimum(r[:, 1], hi_lim)
        if np.any(lo > hi):
            j = int(np.argmax(lo > hi))
            raise InputError(
                f"range of q{j + 1} {r[j].tolist()} deg lies outside the joint limits "
                f"[{lo_lim[j]:g}, {hi_lim[j]:g}] deg",
                source="space_filling_design(ranges_deg)",
            )
    sampler = qmc.Sobol(d=6, scramble=True, rng=rng)
    chosen: list[NDArray[np.float64]] = []
    count = 0
    m = max(6, math.ceil(math.log2(4 * n)))
    total = 0
    while count < n:
        u = sampler.random_base2(m) if total == 0 else sampler.random(2**m)
        total += u.shape[0]
        q = lo + u * (hi - lo)
        if round_deg:
            q = np.clip(np.round(q / round_deg) * round_deg, lo, hi)
        ok = _valid(robot, np.radians(q))
        chosen.append(q[ok])
        count += int(ok.sum())
        if count < n and total >= 2**20:
            raise InputError(
                f"found only {count} valid postures among {total} candidates in the ranges "
                f"{np.c_[lo, hi].tolist()} deg; expected {n}",
                source="space_filling_design",
            )
    q_deg = np.concatenate(chosen)[:n]
    width = max(2, len(str(first_number + n - 1)))
    ids = [f"{id_prefix}{k:0{width}d}" for k in range(first_number, first_number + n)]
    return _frame(ids, q_deg, [role] * n)


def random_design(
    robot: Any,
    n: int,
    rng: np.random.Generator,
    *,
    ranges_deg: Sequence[tuple[float, float]] | None = None,
    id_prefix: str = "R",
) -> pd.DataFrame:
    """``n`` uniformly random valid postures (``robolobe.robots.limits.sample_postures``).

    Parameters
    ----------
    robot : Robot
    n : int
    rng : numpy.random.Generator
    ranges_deg : sequence of 6 (low, high), optional
        Ranges to sample [deg] (default: the joint limits).
    id_prefix : str

    Returns
    -------
    pandas.DataFrame
        Columns :data:`DESIGN_COLUMNS`, role "train".
    """
    from robolobe.robots.limits import sample_postures

    if not (isinstance(n, int | np.integer) and n >= 1):
        raise InputError(f"expected n >= 1, found {n!r}", source="random_design(n)")
    q = np.asarray(sample_postures(robot, int(n), rng, ranges_deg=ranges_deg), dtype=float)
    width = max(3, len(str(n)))
    ids = [f"{id_prefix}{k:0{width}d}" for k in range(1, n + 1)]
    return _frame(ids, np.degrees(q), ["train"] * n)


def _fixed(
    robot: Any, rows: Sequence[Sequence[float]], ids: Sequence[str], role: str, key: str
) -> pd.DataFrame:
    from robolobe.robots.limits import check_posture

    q_deg = np.asarray(rows, dtype=float)
    for pid, q in zip(ids, q_deg, strict=True):
        check_posture(
            robot, np.radians(q), posture_id=pid, source=f"seed paper posture of robot {key}"
        )
    return _frame(ids, q_deg, [role] * len(ids))


def seed_design(robot_key: str, rng: np.random.Generator | None = None) -> pd.DataFrame:
    """The seed paper's posture design for robot A, B or C.

    Parameters
    ----------
    robot_key : {"A", "B", "C"}
        Built-in robot (its file gives the limits).
    rng : numpy.random.Generator, optional
        Scrambling of the space-filling part (default:
        ``numpy.random.default_rng(DEFAULT_SEED)``, the shipped designs).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`DESIGN_COLUMNS`. A: 254 "train" (P001..P254). B: 20
        "train" (P01..P20) and the 5 "test" postures of Table 3 (T1..T5).
        C: 20 one-sided "train" (P01..P20, q1 in :data:`C_ONE_SIDED_Q1_DEG`),
        the 4 "added" of Table 5 (P21..P24) and the 5 "test" of Table 6
        (T1..T5).
    """
    from robolobe.robots import load_robot

    key = str(robot_key).upper()
    if key not in TESTED_RANGES_DEG:
        raise InputError(
            f"expected robot A, B or C (the seed paper's robots), found {robot_key!r}",
            source="seed_design(robot_key)",
        )
    g = rng if rng is not None else np.random.default_rng(DEFAULT_SEED)
    robot = load_robot(key)
    ranges = TESTED_RANGES_DEG[key]
    if key == "A":
        return space_filling_design(robot, 254, g, ranges_deg=ranges)
    if key == "B":
        train = space_filling_design(robot, 20, g, ranges_deg=ranges)
        test = _fixed(robot, B_TEST_DEG, [f"T{i}" for i in range(1, 6)], "test", key)
        return pd.concat([train, test], ignore_index=True)
    one_sided = (C_ONE_SIDED_Q1_DEG, *ranges[1:])
    train = space_filling_design(robot, 20, g, ranges_deg=one_sided)
    added = _fixed(robot, C_ADDED_DEG, [f"P{i}" for i in range(21, 25)], "added", key)
    test = _fixed(robot, C_TEST_DEG, [f"T{i}" for i in range(1, 6)], "test", key)
    return pd.concat([train, added, test], ignore_index=True)


def load_seed_design(robot_key: str) -> pd.DataFrame:
    """The shipped seed design of robot A, B or C (``robolobe/data/designs``).

    Returns
    -------
    pandas.DataFrame
        As :func:`seed_design` with the default seed.
    """
    key = str(robot_key).upper()
    if key not in TESTED_RANGES_DEG:
        raise InputError(
            f"expected robot A, B or C (the seed paper's robots), found {robot_key!r}",
            source="load_seed_design(robot_key)",
        )
    ref = resources.files("robolobe.data").joinpath("designs", f"{key}.csv")
    with resources.as_file(ref) as path:
        if not path.is_file():
            raise InputError(
                "shipped design file missing", source=f"robolobe/data/designs/{key}.csv"
            )
        df = pd.read_csv(path, dtype={"posture_id": str, "role": str}, keep_default_na=False)
    return df[list(DESIGN_COLUMNS)]


def design_arrays(
    design: pd.DataFrame,
) -> tuple[tuple[str, ...], NDArray[np.float64], tuple[str, ...]]:
    """Posture ids, joint angles [rad] (n, 6) and roles of a design frame."""
    ids = tuple(str(p) for p in design["posture_id"])
    q = np.radians(design[[f"q{i}_deg" for i in range(1, 7)]].to_numpy(dtype=float))
    roles = tuple(str(r) for r in design["role"]) if "role" in design else ("train",) * len(ids)
    return ids, q, roles


def write_seed_designs(
    folder: str | os.PathLike[str], keys: Sequence[str] = ("A", "B", "C")
) -> None:
    """Write ``{key}.csv`` seed designs (default seed) into ``folder``, atomically."""
    from robolobe._atomic import atomic_path, safe_name

    out = Path(folder)
    for key in keys:
        if safe_name(key, "x") != key:
            raise InputError(f"design key {key!r} cannot be a file name", source="keys")
        with atomic_path(out / f"{key}.csv") as tmp:
            seed_design(key).to_csv(tmp, index=False, lineterminator="\n")


if __name__ == "__main__":  # pragma: no cover - maintenance entry point
    write_seed_designs(sys.argv[1] if len(sys.argv) > 1 else "src/robolobe/data/designs")
