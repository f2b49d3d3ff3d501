"""Modes of a long path exact at every few postures, interpolated where checked
(:func:`robolobe.plan.modes.interpolated_modes`), against every posture's exact modes."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.plan.job import load_job
from robolobe.plan.lobes import DynamicsTolerance
from robolobe.plan.modes import MODE_INTERP_FRACTION, TwinSource, interpolated_modes
from robolobe.plan.pipeline import _tool_model, cut_lobes, material_from_job
from robolobe.robots.io import load_robot

from .conftest import example

N = 320
STRIDE = 8
JUMP = 131  # a step in posture (a rapid between two cuts): inside the interval 128..136


@pytest.fixture(scope="module")
def job():
    return load_job(example("job_A_pocket.toml")).replace(model="twin")


@pytest.fixture(scope="module")
def source(job):
    return TwinSource(load_robot(job.robot))


def _postures() -> np.ndarray:
    """A smooth joint-space curve of robot A with one step (radians, (N, 6))."""
    t = np.linspace(0.0, 1.0, N)[:, None]
    q0 = np.array([0.1, -0.5, 1.1, 0.0, 0.8, 0.0])
    amp = np.array([0.03, 0.02, -0.015, 0.04, 0.02, 0.05])
    q = q0 + amp * np.c_[t, np.sin(2 * t), t, t**2, np.cos(3 * t), t]
    q[JUMP:, 1] += 0.25
    return q


class Counting:
    """A mode source that counts the postures it predicts."""

    def __init__(self, inner: TwinSource) -> None:
        self.inner, self.name, self.seen = inner, inner.name, []

    def predict(self, q_rad):
        self.seen.append(np.asarray(q_rad).copy())
        return self.inner.predict(q_rad)


def test_interpolated_modes_within_the_stated_tolerance(source):
    """Every posture's f, zeta (relative), compliance per direction (against the mode's
    largest) and residue entries (against the mode's trace) within the stated fraction
    of the grouping tolerance; far fewer postures predicted; the step refined."""
    q = _postures()
    counting = Counting(source)
    got = interpolated_modes(counting, q, None, STRIDE)
    ref = source.predict(q)
    tol, fr = DynamicsTolerance(), MODE_INTERP_FRACTION
    rel = lambda a, b: np.abs(a / b - 1.0)  # noqa: E731
    assert rel(got.f_hz, ref.f_hz).max() <= fr * tol.freq
    assert rel(got.zeta, ref.zeta).max() <= fr * tol.damping
    c_got, c_ref = 1.0 / got.k_N_per_m, 1.0 / ref.k_N_per_m
    scale = np.abs(c_ref).max(axis=1, keepdims=True)
    assert (np.abs(c_got - c_ref) / scale).max() <= fr * tol.residue
    tr = np.abs(np.trace(ref.model.residues, axis1=-2, axis2=-1))[..., None, None]
    assert (np.abs(got.model.residues - ref.model.residues) / tr).max() <= fr * tol.residue / 4
    # the interval with the step was predicted posture by posture, exactly
    done = np.concatenate(counting.seen)
    for i in range(128, 137):
        assert np.any(np.all(done == q[i], axis=1)), i
    np.testing.assert_allclose(got.f_hz[128:137], ref.f_hz[128:137], rtol=1e-12)
    # interpolation elsewhere: not much more than the knots and one check per interval
    assert done.shape[0] <= 2 * N // STRIDE + STRIDE + 2
    # without the interpolation the step's error would be far beyond the tolerance
    lin = ref.f_hz[128] + (ref.f_hz[136] - ref.f_hz[128]) * 0.5
    assert rel(lin, ref.f_hz[132]).max() > 10 * fr * tol.freq


def test_limits_from_interpolated_modes_within_half_a_percent(job, source):
    """Each posture's own lobes (no sharing) from the interpolated modes: a_lim at
    every speed of the grid within 0.5 % of those from its exact modes (the converged
    lobes' promise); in practice far closer."""
    q = _postures()
    got, ref = interpolated_modes(source, q, None, STRIDE), source.predict(q)
    ang = np.linspace(0.0, 2.0, N)
    f_tcp = np.c_[np.cos(ang), np.sin(ang), np.zeros(N)]
    material, tool = material_from_job(job), _tool_model(job)
    rpm = np.linspace(8000.0, 24000.0, 60)

    def a_lim(modes):
        table = cut_lobes(job, modes, f_tcp, material, tool, rpm, dynamics_tol=0.0)[2].table
        return table.a_lim[table.group]

    a, b = a_lim(got), a_lim(ref)
    assert np.all(np.isfinite(b))
    assert b.shape == (N, rpm.size)
    assert np.max(np.abs(a / b - 1.0)) <= 0.005
    assert np.max(np.abs(a / b - 1.0)) <= 1e-3  # what the stated tolerance gives here


def test_exact_where_asked(source):
    """stride 1, a short path or an exact grouping tolerance: every posture predicted."""
    q = _postures()
    ref = source.predict(q)
    for got in (
        interpolated_modes(source, q, None, 1),
        interpolated_modes(source, q[: 4 * STRIDE - 1], None, STRIDE),
        interpolated_modes(source, q, DynamicsTolerance(0.0, 0.0, 0.0, 0.0, 0.0), STRIDE),
    ):
        n = got.f_hz.shape[0]
        np.testing.assert_array_equal(got.f_hz, ref.f_hz[:n])
        np.testing.assert_array_equal(got.model.residues, ref.model.residues[:n])
