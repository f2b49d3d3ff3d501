"""Shared fixtures of the robolobe.tl tests: a smooth synthetic posture -> modal map."""

from __future__ import annotations

import numpy as np
import pytest
import torch

LO = np.radians([-50.0, -90.0, 70.0, -300.0, -90.0, -300.0])
HI = np.radians([50.0, -50.0, 150.0, 300.0, 90.0, 300.0])


def smooth_modal(q: np.ndarray, variant: float = 0.0) -> np.ndarray:
    """Toy map q (n, 6) rad -> (n, 2, 5, 3): positive, smooth, robot-like ranges."""
    n = len(q)
    base = np.array([7.0, 11.0, 15.0, 21.0, 30.0]) * (1.0 + 0.3 * variant)
    y = np.empty((n, 2, 5, 3))
    s2, c3, c5 = np.sin(q[:, 1:2]), np.cos(q[:, 2:3]), np.cos(q[:, 4:5])
    for d in range(2):
        y[:, d, :, 0] = base * (1 + 0.15 * s2 * c3 + 0.05 * c5)
        y[:, d, :, 1] = 0.02 * (1 + 0.3 * np.cos(q[:, 2:3] + np.arange(5)))
        y[:, d, :, 2] = (
            1e6
            * (1 + 0.5 * variant)
            * np.exp(0.4 * np.cos(q[:, 4:5] + d + np.arange(5)) + 0.2 * c3)
        )
    return y


@pytest.fixture(autouse=True)
def _torch_threads():
    torch.set_num_threads(1)


@pytest.fixture
def toy_data():
    rng = np.random.default_rng(0)
    q = rng.uniform(LO, HI, size=(60, 6))
    return q, smooth_modal(q)
