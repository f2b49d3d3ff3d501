"""The calibration's eigen-sensitivities (ParametrizedTwin.log_jacobian) against finite
differences of the values, for f, zeta and k and every parameter group (issue 27: the
Jacobian was rewritten as batched products for the transfer's speed)."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.robots import load_robot
from robolobe.tl.graybox import DEFAULT_PARAMS
from robolobe.twin.params import K_MAX, ParametrizedTwin, parameter_names


@pytest.mark.parametrize("loaded", [False, True])
def test_log_jacobian_matches_finite_differences_for_every_group(loaded: bool) -> None:
    """Every group, at no load stiffening and at some (the springs then depend on the
    posture and on the masses through the gravity torques)."""
    robot = load_robot("C")
    q = np.radians(
        [[0, -60, 90, 0, 30, 0], [40, -30, 60, 20, -40, 10], [-20, -80, 110, -30, 50, 0]]
    )
    assert "load" in DEFAULT_PARAMS
    pt = ParametrizedTwin(robot, q, DEFAULT_PARAMS, directions=("xx", "yy", "zz"), n_modes=6)
    names = parameter_names(DEFAULT_PARAMS)
    rng = np.random.default_rng(0)
    theta = rng.normal(0.0, 0.1, len(names))
    load = np.array([n.startswith("l") for n in names])
    theta[load] = np.abs(theta[load]) + 0.5 if loaded else 0.0
    jac = pt.log_jacobian(theta)  # (n, n_dir, n_modes, 3, p)
    v0 = pt.values(theta)
    seen = v0[..., 2] < K_MAX
    h = 1e-6
    fd = np.empty_like(jac)
    for i in range(len(names)):
        d = np.zeros_like(theta)
        d[i] = h
        fd[..., i] = (np.log(pt.values(theta + d)) - np.log(pt.values(theta - d))) / (2 * h)
    # f and zeta of the damped modes to first order in the damping (the docstring);
    # k exact: compared with the largest sensitivity of each quantity
    for c, rtol in ((0, 0.01), (1, 0.05), (2, 0.01)):
        ok = seen if c == 2 else np.ones_like(seen)
        size = float(np.max(np.abs(fd[..., c, :][ok])))
        err = np.max(np.abs(fd[..., c, :] - jac[..., c, :])[ok], axis=0)  # per parameter
        assert np.all(err < rtol * size), [names[k] for k in np.nonzero(err >= rtol * size)[0]]
