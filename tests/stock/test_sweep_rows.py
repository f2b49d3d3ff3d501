"""The numpy sweep of the Python path equals the scalar sweep (what numba compiles), bit for bit.

The Z-maps are random (heights, clearances, remembered sweeps, levels never
set, signed zeros), the moves every kind the path has: flat lines in any
direction, lines along x or y only (the branches for a zero component),
ramps, plunges, tiny moves (the scalar fallback) and long ones reaching past
the map, each with and without the skipped start disc.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robolobe.stock import _kernels
from robolobe.stock._sweep_rows import sweep as rows

RES = 0.5e-3  # Z-map cell [m]
TOL = 1e-6  # level tolerance [m]


def _scalar() -> object:
    # the scalar function whichever path this process took first
    return _kernels._SCALAR.get("sweep", _kernels._sweep)


def _move(rng: np.random.Generator, kind: int, p0: np.ndarray) -> np.ndarray:
    n = rng.normal
    steps = {
        0: [n(0, 5e-3), n(0, 5e-3), 0.0],  # flat, any direction
        1: [0.0, 0.0, -1e-3],  # plunge
        2: [n(0, 5e-3), 0.0, n(0, 1e-3)],  # along x, ramp
        3: [0.0, n(0, 5e-3), n(0, 1e-3)],  # along y, ramp
        4: [n(0, 1e-4), n(0, 1e-4), -1e-5],  # tiny
        5: [n(0, 2e-2), n(0, 2e-2), n(0, 2e-3)],  # long, past the map
    }
    return p0 + np.array(steps[kind])


@pytest.mark.parametrize("seed", range(4))
def test_numpy_sweep_equals_the_scalar_sweep(seed: int) -> None:
    rng = np.random.default_rng(seed)
    scalar = _scalar()
    for trial in range(120):
        ny, nx = (int(v) for v in rng.integers(5, 60, 2))
        w = np.empty((ny, nx, 3))
        w[..., 0] = rng.choice([0.0, -1e-3, -2e-3, -0.0], (ny, nx))
        w[..., 1] = rng.normal(0.0, 1e-3, (ny, nx))
        w[..., 2] = rng.choice([np.inf, 0.0, -0.0, -1e-3, -1e-3 + 0.5 * TOL], (ny, nx))
        ids = rng.integers(0, 5, (ny, nx, 2))
        expected_w, expected_ids = w.copy(), ids.copy()
        x0, y0 = -0.3e-3 * rng.random(), -0.3e-3 * rng.random()
        radius = float(rng.choice([1e-3, 3e-3, 5e-3, 10e-3]))
        band = 1.5 * RES
        p0 = np.array(
            [
                rng.uniform(x0, x0 + nx * RES),
                rng.uniform(y0, y0 + ny * RES),
                rng.choice([0.0, -1e-3, -2e-3]),
            ]
        )
        p1 = _move(rng, trial % 6, p0)
        skip = bool(rng.integers(0, 2))
        args = (7, x0, y0, RES, radius, band, p0, p1, skip, TOL)
        scalar(expected_w, expected_ids, *args)  # type: ignore[operator]
        rows(w, ids, *args, scalar)
        # bit for bit: signed zeros and infinities included
        assert np.array_equal(w.view(np.int64), expected_w.view(np.int64)), (seed, trial)
        assert np.array_equal(ids, expected_ids), (seed, trial)


def test_python_path_sweeps_with_numpy_and_compiles_the_scalar() -> None:
    """Below the compile size the kernels' sweep is the numpy one (what ``_remove`` calls);
    the scalar one is kept for numba (in a fresh process: no kernel compiled yet)."""
    code = (
        "from robolobe.stock import _kernels as k\n"
        "from robolobe.stock._sweep_rows import sweep\n"
        "scalar = k._sweep\n"
        "run, sw = k.kernels(0.0)\n"
        "assert run is k._run and sw is k._sweep and sw is not scalar\n"
        "assert k._SCALAR['sweep'] is scalar\n"
        "cells = [c.cell_contents for c in sw.__closure__]\n"
        "assert sweep in cells and scalar in cells  # the numpy sweep, its scalar fallback\n"
        "assert k.kernels(0.0)[1] is sw  # once\n"
        "print('ok')\n"
    )
    env = {**os.environ, "PYTHONPATH": str(Path(_kernels.__file__).parents[2])}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "ok"
