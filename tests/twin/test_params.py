"""Tests of robolobe.twin.params and the vectorized mode matching of the calibration."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.tl.dataset import ModalDataset
from robolobe.tl.graybox import TwinCalibration
from robolobe.twin import Twin
from robolobe.twin.designs import design_arrays, seed_design
from robolobe.twin.params import (
    COM_UNIT_M,
    PARAMETER_GROUPS,
    ParametrizedTwin,
    apply_parameters,
    modal_values,
    parameter_names,
)

ALL = tuple(PARAMETER_GROUPS)


@pytest.mark.parametrize("key", ["A", "B", "C"])
def test_fast_modes_equal_rebuilt_robot(key):
    robot = load_robot(key)
    _, q, _ = design_arrays(seed_design(key))
    q = q[:12]
    theta = np.random.default_rng(1).normal(0.0, 0.2, sum(PARAMETER_GROUPS.values()))
    theta[-6:] = 3.0 * np.abs(theta[-6:])  # load stiffening: >= 0, up to ~2x at 1e4 N m
    fast = ParametrizedTwin(robot, q, ALL).values(theta)
    slow = modal_values(Twin(apply_parameters(robot, ALL, theta)).modes(q), ("xx", "yy"), 5)
    np.testing.assert_allclose(fast, slow, rtol=1e-9)
    # theta = 0 is the robot file
    np.testing.assert_allclose(
        ParametrizedTwin(robot, q, ALL).values(np.zeros(len(theta))),
        modal_values(Twin(robot).modes(q), ("xx", "yy"), 5),
        rtol=1e-9,
    )


def test_load_group_stiffens_each_joint_spring_with_its_gravity_torque():
    """``load``: theta per 1e4 N m of |gravity torque| (the robot file's law), added to the
    file's own stiffening; the fast twin of a file that already stiffens starts there."""
    from robolobe.twin.dynamics import gravity_torques
    from robolobe.twin.system import nominal_system

    base = load_robot("B")
    theta = np.array([0.0, 1.5, 0.5, 0.0, 0.0, 0.0])
    r = apply_parameters(base, ("load",), theta)
    np.testing.assert_allclose(r.load_stiffening, theta / 1e4)
    q = np.radians([[0.0, -60.0, 100.0, 0.0, 30.0, 0.0], [20.0, -20.0, 60.0, 0.0, 0.0, 0.0]])
    sm = nominal_system(r, q)
    tau = np.abs(gravity_torques(r, q, sm.bodies))
    k_diag = np.diagonal(sm.K, axis1=-2, axis2=-1)[:, :6]
    np.testing.assert_allclose(k_diag, base.stiffness * (1.0 + theta / 1e4 * tau), rtol=1e-12)
    assert tau[0, 1] > 1e3  # the test means something: axis 2 holds the arm
    # a file that stiffens already: theta = 0 is it, and theta adds to it
    fast = ParametrizedTwin(r, q, ("load",)).values(np.full(6, 0.3))
    slow = modal_values(
        Twin(apply_parameters(r, ("load",), np.full(6, 0.3))).modes(q), ("xx", "yy"), 5
    )
    np.testing.assert_allclose(fast, slow, rtol=1e-9)
    with pytest.raises(InputError):
        apply_parameters(base, ("load",), -theta - 1.0)


def test_apply_parameters_meaning():
    base = load_robot("B")
    groups = ("link_mass", "link_com", "stiffness")
    theta = np.zeros(30)
    theta[1] = np.log(1.2)  # link 2 mass x 1.2
    theta[6 + 3 * 2 + 1] = 0.5  # link 3 COM + 0.05 m along its y
    theta[24 + 0] = np.log(2.0)  # joint 1 stiffness x 2
    r = apply_parameters(base, groups, theta)
    assert r.joints[1].body.mass_kg == pytest.approx(1.2 * base.joints[1].body.mass_kg)
    np.testing.assert_allclose(
        r.joints[1].body.inertia_kgm2, 1.2 * base.joints[1].body.inertia_kgm2
    )
    d = r.joints[2].body.com_m - base.joints[2].body.com_m
    np.testing.assert_allclose(d, [0.0, 0.5 * COM_UNIT_M, 0.0], atol=1e-15)
    assert r.stiffness[0] == pytest.approx(2 * base.stiffness[0])
    np.testing.assert_array_equal(r.stiffness[1:], base.stiffness[1:])
    assert parameter_names(groups)[:2] == ("m1", "m2")
    assert parameter_names(groups)[6:9] == ("c1x", "c1y", "c1z")
    with pytest.raises(InputError, match=r"theta: expected shape \(30,\)"):
        apply_parameters(base, groups, np.zeros(3))
    with pytest.raises(InputError, match="groups"):
        parameter_names(("mass",))


def test_matching_equals_linear_sum_assignment():
    rng = np.random.default_rng(5)
    n, nd, nm, nt = 30, 2, 5, 6
    model = np.empty((n, nd, nt, 3))
    model[..., 0] = np.sort(rng.uniform(5, 40, (n, nd, nt)), axis=-1)
    model[..., 1] = 0.03
    model[..., 2] = 10 ** rng.uniform(6, 9, (n, nd, nt))
    pick = np.sort(np.argsort(rng.random((n, nd, nt)), axis=-1)[..., :nm], axis=-1)
    y = np.take_along_axis(model, pick[..., None], axis=2) * np.exp(
        rng.normal(0, 0.05, (n, nd, nm, 3))
    )
    y[rng.random((n, nd, nm)) < 0.2] = np.nan  # modes not seen
    ds = ModalDataset(tuple(f"p{i}" for i in range(n)), np.zeros((n, 6)), ("xx", "yy"), y)
    cal = TwinCalibration(robot="B", match_k_weight=0.1)
    (ii, jj, mm, tt), unmatched = cal._match(ds, model, tol=0.08)
    got = {(a, b, c): d for a, b, c, d in zip(ii, jj, mm, tt, strict=True)}
    want, n_un = {}, 0
    for i in range(n):
        for j in range(nd):
            meas = np.flatnonzero(np.isfinite(y[i, j, :, 0]))
            df = np.abs(np.log(y[i, j, meas, 0][:, None] / model[i, j, None, :, 0]))
            dk = np.minimum(np.abs(np.log(y[i, j, meas, 2][:, None] / model[i, j, None, :, 2])), 3)
            r, c = linear_sum_assignment(df + 0.1 * dk)
            for a, b in zip(r, c, strict=True):
                if df[a, b] <= 0.08:
                    want[(i, j, int(meas[a]))] = int(b)
                else:
                    n_un += 1
    assert got == want
    assert unmatched == n_un
