"""Directional factors against closed forms and an independent force derivation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from robolobe.sld import (
    directional_factors,
    directional_matrix,
    engagement_angles,
    interval_directional_average,
)
from robolobe.sld.directional import directional_antiderivative

PI = math.pi


@pytest.mark.parametrize("kr", [0.0, 0.212, 1 / 3, 0.5])
def test_slot_closed_form(kr: float) -> None:
    # REFERENCES.md section 3: slot alphas [-Kr pi, -pi, pi, -Kr pi]
    got = directional_factors(0.0, PI, kr)
    want = np.array([[-kr * PI, -PI], [PI, -kr * PI]])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)


@pytest.mark.parametrize("kr", [0.0, 0.212, 1 / 3, 0.5])
def test_half_immersion_down_closed_form(kr: float) -> None:
    # REFERENCES.md section 3: [1 - Kr pi/2, -pi/2 + Kr, pi/2 + Kr, -1 - Kr pi/2]
    st, ex = engagement_angles(0.5, "down")
    got = directional_factors(st, ex, kr)
    want = np.array([[1 - kr * PI / 2, -PI / 2 + kr], [PI / 2 + kr, -1 - kr * PI / 2]])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)


@pytest.mark.parametrize("kr", [0.212, 1 / 3])
def test_half_immersion_up_closed_form(kr: float) -> None:
    # integrating the same formulas from 0 to pi/2 by hand
    got = directional_factors(*engagement_angles(0.5, "up"), kr)
    want = np.array([[-1 - kr * PI / 2, -PI / 2 - kr], [PI / 2 - kr, 1 - kr * PI / 2]])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-13)


def _force_matrix(phi: float, kr: float) -> np.ndarray:
    """d F / d dq of one tooth from the force geometry (Altintas' frame), per a Kt / 2."""
    # chip h = dq_x sin(phi) + dq_y cos(phi); F_t = h, F_r = Kr h (per a Kt)
    dh = np.array([math.sin(phi), math.cos(phi)])
    # force on the tool: F_x = -F_t cos - F_r sin, F_y = F_t sin - F_r cos
    direction = np.array([-math.cos(phi) - kr * math.sin(phi), math.sin(phi) - kr * math.cos(phi)])
    return 2.0 * np.outer(direction, dh)


@pytest.mark.parametrize("phi", [0.0, 0.3, 1.2, PI / 2, 2.5, 3.0])
def test_directional_matrix_matches_force_geometry(phi: float) -> None:
    np.testing.assert_allclose(directional_matrix(phi, 0.3), _force_matrix(phi, 0.3), atol=1e-14)


def test_factors_are_integrals_of_the_matrix() -> None:
    rng = np.random.default_rng(3)
    for _ in range(5):
        st, ex = np.sort(rng.uniform(0, PI, 2))
        kr = rng.uniform(0, 0.6)
        want = np.array(
            [
                [
                    quad(lambda p, i=i, j=j, kr=kr: directional_matrix(p, kr)[i, j], st, ex)[0]
                    for j in range(2)
                ]
                for i in range(2)
            ]
        )
        np.testing.assert_allclose(directional_factors(st, ex, kr), want, atol=1e-12)


def test_antiderivative_derivative() -> None:
    phi = np.linspace(0.1, 3.0, 7)
    h = 1e-6
    num = (directional_antiderivative(phi + h, 0.4) - directional_antiderivative(phi - h, 0.4)) / (
        2 * h
    )
    np.testing.assert_allclose(num, directional_matrix(phi, 0.4), atol=1e-8)


def test_vectorised_equals_one_at_a_time() -> None:
    st = np.array([[0.0], [0.2], [0.7]])
    ex = np.linspace(0.9, PI, 4)
    kr = 0.3
    out = directional_factors(st, ex, kr)
    assert out.shape == (3, 4, 2, 2)
    for i in range(3):
        for j in range(4):
            one = directional_factors(st[i, 0], ex[j], kr)
            np.testing.assert_array_equal(out[i, j], one)
    # and each equals the integral of the directional matrix over the engagement
    phi = np.linspace(st[1, 0], ex[2], 20001)
    quad = np.trapezoid(directional_matrix(phi, kr), phi, axis=0)
    np.testing.assert_allclose(out[1, 2], quad, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize(("teeth", "m"), [(2, 10), (3, 17), (4, 40)])
@pytest.mark.parametrize("immersion", [1.0, 0.5, 0.1])
def test_interval_average_sums_to_zero_order(teeth: int, m: int, immersion: float) -> None:
    # the mean of A(t) over a tooth period is N alpha / (2 pi)
    st, ex = engagement_angles(immersion, "down")
    dphi = 2 * PI / (teeth * m)
    avg = interval_directional_average(np.arange(m) * dphi, dphi, st, ex, 0.3, teeth)
    np.testing.assert_allclose(
        avg.mean(axis=0), teeth * directional_factors(st, ex, 0.3) / (2 * PI), atol=1e-12
    )


def test_interval_average_is_zero_outside_the_cut() -> None:
    st, ex = engagement_angles(0.1, "down")  # cut in [2.50, pi]
    got = interval_directional_average(np.array([0.2, 1.0]), 0.1, st, ex, 0.3, 1)
    np.testing.assert_array_equal(got, 0.0)
