"""Engagement per move against closed forms written for the test (not the production code).

Geometry of the references: a flat end mill of radius R moving along x with
a straight wall of material on one side at radial width a_e engages
``acos(1 - 2 a_e / D)`` from the side of the material (up milling: from 0,
material on the left of the feed; down milling: up to pi, material on the
right). On a circular arc of tool-centre radius rho about O with the
material outside a circle of radius r_b about O, the edge meets that circle
where ``r_b^2 = rho^2 + R^2 + 2 rho R cos(theta)`` (law of cosines), so the
engaged arc spans ``theta0 = acos((r_b^2 - rho^2 - R^2) / (2 rho R))`` from
the outward normal.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.stock import Stock, check_stock_contains, compute_engagement, default_stock

R = 0.010  # tool radius [m]
D = 2 * R
DEG = math.pi / 180


def _line(p0: tuple[float, float, float], p1: tuple[float, float, float], n: int) -> np.ndarray:
    """``n`` equal moves from p0 to p1 (end points), in mm -> m."""
    t = np.linspace(0.0, 1.0, n + 1)[1:, None]
    return (np.array(p0) + t * (np.array(p1) - np.array(p0))) * 1e-3


def _path(*pieces: np.ndarray, start: tuple[float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    pts = np.vstack([np.array(start)[None] * 1e-3, *pieces])
    cut = np.ones(len(pts), dtype=bool)
    cut[0] = False
    return pts, cut


def _wall_angle(ae: float) -> float:
    return math.acos(1.0 - 2.0 * ae / D)


def test_straight_slot_is_180_deg_at_the_depth() -> None:
    stock = Stock.box((0.0, -0.03, -0.01), (0.1, 0.03, 0.0))
    xyz, cut = _path(
        _line((-15, 0, 5), (-15, 0, -3), 1),
        _line((-15, 0, -3), (115, 0, -3), 26),
        start=(-15, 0, 5),
    )
    e = compute_engagement(xyz, cut, D, stock)
    inside = (xyz[:, 0] > 0.012) & (xyz[:, 0] < 0.1) & cut
    inside[1] = False
    assert inside.sum() >= 15
    np.testing.assert_allclose(e.phi_entry[inside], 0.0, atol=1e-9)
    np.testing.assert_allclose(e.phi_exit[inside], math.pi, atol=1e-9)
    np.testing.assert_allclose(e.depth_m[inside], 0.003, atol=2e-6)
    assert set(e.milling()[inside]) == {"slot"}
    # the plunge outside the stock and the moves beyond it cut air
    assert e.air[1]
    assert e.air[xyz[:, 0] > 0.111].all()


@pytest.mark.parametrize("res_mm", [None, 0.25, 1.0])
def test_pocket_first_pass_then_step_overs(res_mm: float | None) -> None:
    """Slot at y = 0, then +x at y = 7 (up milling), -x at y = 14 (down), +x at y = 16."""
    stock = Stock.box((0.0, -0.03, -0.01), (0.1, 0.05, 0.0))
    xyz, cut = _path(
        _line((-15, 0, 5), (-15, 0, -2), 1),
        _line((-15, 0, -2), (115, 0, -2), 13),
        _line((115, 0, -2), (115, 7, -2), 1),
        _line((115, 7, -2), (-15, 7, -2), 13),
        _line((-15, 7, -2), (-15, 14, -2), 1),
        _line((-15, 14, -2), (115, 14, -2), 13),
        start=(-15, 0, 5),
    )
    res = None if res_mm is None else res_mm * 1e-3
    e = compute_engagement(xyz, cut, D, stock, resolution_m=res)
    mid = (xyz[:, 0] > 0.035) & (xyz[:, 0] < 0.085)
    y = np.round(xyz[:, 1] * 1e3)
    slot = mid & (y == 0)
    up = mid & (y == 7) & (np.diff(xyz[:, 0], prepend=0) < 0)
    down = mid & (y == 14)
    tol = 0.5 * DEG if res_mm != 1.0 else 1.0 * DEG
    np.testing.assert_allclose(e.phi_entry[slot], 0.0, atol=1e-9)
    np.testing.assert_allclose(e.phi_exit[slot], math.pi, atol=1e-9)
    # -x at y = 7: material at y > 10 is to the right of the feed: down milling, a_e = 7
    assert up.sum() >= 3
    np.testing.assert_allclose(e.phi_entry[up], math.pi - _wall_angle(0.007), atol=tol)
    np.testing.assert_allclose(e.phi_exit[up], math.pi, atol=1e-9)
    # +x at y = 14: material at y > 17 is to the left: up milling, a_e = 7
    assert down.sum() >= 3
    np.testing.assert_allclose(e.phi_entry[down], 0.0, atol=1e-9)
    np.testing.assert_allclose(e.phi_exit[down], _wall_angle(0.007), atol=tol)
    np.testing.assert_allclose(e.immersion[down], 0.35, atol=0.01)
    assert e.milling()[down][0] == "up"
    assert e.milling()[up][0] == "down"


def _arc(rho: float, n: int, z: float) -> np.ndarray:
    """Quarter arc about O, CCW from -90 deg to 0 deg, tool-centre radius rho [mm]."""
    a = np.linspace(-math.pi / 2, 0.0, n + 1)[1:]
    return np.column_stack([rho * np.cos(a), rho * np.sin(a), np.full(n, z)]) * 1e-3


def _corner_pass(rho: float, z: float) -> list[np.ndarray]:
    return [
        _line((-40, -rho, z), (0, -rho, z), 8),
        _arc(rho, 90, z),
        _line((rho, 0, z), (rho, 40, z), 8),
    ]


def test_inside_corner_of_known_radius() -> None:
    """Two concentric corner passes; the second's engagement on its arc has a closed form."""
    rho_a, ae, z = 6.0, 5.0, -2.0
    rho_b = rho_a + ae
    stock = Stock.box((-0.05, -0.05, -0.01), (0.05, 0.05, 0.0))
    pass_a = _corner_pass(rho_a, z)
    pass_b = _corner_pass(rho_b, z)
    up = _line((rho_a, 40, z), (rho_a, 40, 5), 1)
    xyz, cut = _path(
        _line((-40, -rho_a, 5), (-40, -rho_a, z), 1),
        *pass_a,
        up,
        np.array([[-40e-3, -rho_b * 1e-3, 5e-3]]),
        _line((-40, -rho_b, 5), (-40, -rho_b, z), 1),
        *pass_b,
        start=(-40, -rho_a, 5),
    )
    cut[len(xyz) - sum(len(p) for p in pass_b) - 2] = False  # the rapid to pass B
    e = compute_engagement(xyz, cut, D, stock)
    nb = sum(len(p) for p in pass_b)
    b = np.arange(len(xyz) - nb, len(xyz))
    arc = b[8:98]
    # steady (concentric) engagement: the crossing point lies 38 deg ahead of the tool
    # (law of sines), on pass A's arc while the tool is before -40 deg
    mid = arc[20:50]
    rb = (rho_a + R * 1e3) * 1e-3
    rho = rho_b * 1e-3
    theta0 = math.acos((rb**2 - rho**2 - R**2) / (2 * rho * R))
    # the crossing point: theta0 ahead of the outward normal at the move's end ...
    c = xyz[mid, :2]
    u_out = c / np.linalg.norm(c, axis=1)[:, None]
    ahead = np.column_stack([-u_out[:, 1], u_out[:, 0]])  # CCW motion
    q = c + R * (math.cos(theta0) * u_out + math.sin(theta0) * ahead)
    # ... as an angle in the move's own feed frame (the chord: 0.5 deg behind the tangent)
    f = xyz[mid, :2] - xyz[mid - 1, :2]
    f /= np.linalg.norm(f, axis=1)[:, None]
    left = np.column_stack([-f[:, 1], f[:, 0]])
    rel = q - c
    ref_entry = np.arctan2(np.sum(rel * f, axis=1), np.sum(rel * left, axis=1))
    np.testing.assert_allclose(e.phi_exit[mid], math.pi, atol=1e-9)
    np.testing.assert_allclose(e.phi_entry[mid], ref_entry, atol=0.1 * DEG)
    # the straight part before the corner: a wall at a_e = 5 (down milling)
    straight = b[2:6]  # ends at x = -25 .. -10: the wall ahead is still straight
    np.testing.assert_allclose(e.phi_entry[straight], math.pi - _wall_angle(0.005), atol=0.5 * DEG)
    # the corner raises the engagement (80.8 deg against 60 deg)
    assert theta0 > _wall_angle(0.005) + 15 * DEG
    assert np.all(np.pi - e.phi_entry[arc] <= theta0 + 1.0 * DEG)


def test_face_pass_over_a_stock_edge() -> None:
    """Tool centre 5 mm inside the edge y = 50: material from the right side up to 60 deg."""
    stock = Stock.box((0.0, 0.0, -0.005), (0.1, 0.05, 0.0))
    xyz, cut = _path(
        _line((-20, 45, 5), (-20, 45, -1), 1),
        _line((-20, 45, -1), (120, 45, -1), 14),
        start=(-20, 45, 5),
    )
    e = compute_engagement(xyz, cut, D, stock)
    mid = (xyz[:, 0] > 0.015) & (xyz[:, 0] < 0.095)
    assert mid.sum() >= 6
    np.testing.assert_allclose(e.phi_entry[mid], 60 * DEG, atol=0.3 * DEG)
    np.testing.assert_allclose(e.phi_exit[mid], math.pi, atol=1e-9)
    np.testing.assert_allclose(e.immersion[mid], 0.75, atol=0.005)
    np.testing.assert_allclose(e.depth_m[mid], 0.001, atol=2e-6)
    # entering the stock edge x = 0: the move that ends there cuts less than a full width
    assert e.air[1]


def test_air_moves_above_the_stock_and_in_cleared_material() -> None:
    stock = Stock.box((0.0, -0.03, -0.01), (0.1, 0.03, 0.0))
    xyz, cut = _path(
        _line((-15, 0, 5), (-15, 0, 2), 1),
        _line((-15, 0, 2), (115, 0, 2), 5),  # above the top
        _line((115, 0, 2), (115, 0, -3), 1),
        _line((115, 0, -3), (-15, 0, -3), 5),  # a slot
        _line((-15, 0, -3), (115, 0, -3), 5),  # the same slot again: air
        start=(-15, 0, 5),
    )
    e = compute_engagement(xyz, cut, D, stock)
    assert e.air[1:7].all()
    assert e.engaged[8:12].all()
    assert e.air[13:].all()
    assert np.isnan(e.phi_entry[13:]).all()
    assert (e.depth_m[13:] == 0).all()
    assert any("cut no material (air)" in n for n in e.notes)


def test_ramp_axial_depth_follows_the_tool_tip() -> None:
    stock = Stock.box((0.0, -0.03, -0.01), (0.1, 0.03, 0.0))
    xyz, cut = _path(
        _line((-15, 0, 5), (-15, 0, 0), 1), _line((-15, 0, 0), (85, 0, -4), 20), start=(-15, 0, 5)
    )
    e = compute_engagement(xyz, cut, D, stock)
    inside = np.flatnonzero(xyz[:, 0] > 0.012)
    np.testing.assert_allclose(e.depth_m[inside], -xyz[inside, 2], atol=2e-6)
    np.testing.assert_allclose(e.phi_entry[inside], 0.0, atol=1e-9)
    np.testing.assert_allclose(e.phi_exit[inside], math.pi, atol=1e-9)
    assert np.all(np.diff(e.depth_m[inside]) > 0)


def test_crossing_an_earlier_slot_meets_two_arcs() -> None:
    stock = Stock.box((-0.05, -0.05, -0.01), (0.05, 0.05, 0.0))
    xyz, cut = _path(
        _line((-60, 0, 5), (-60, 0, -2), 1),
        _line((-60, 0, -2), (60, 0, -2), 12),
        np.array([[60e-3, 0, 5e-3], [0.0, -60e-3, 5e-3]]),
        _line((0, -60, 5), (0, -60, -2), 1),
        _line((0, -60, -2), (0, 60, -2), 120),
        start=(-60, 0, 5),
    )
    cut[14:16] = False
    e = compute_engagement(xyz, cut, D, stock)
    y = xyz[:, 1] * 1e3
    second = np.arange(17, len(xyz))
    # reaching the first slot (its wall at y = -10 inside the tool's front half): material
    # on both flanks only, the middle of the edge is in the first slot
    crossing = second[(y[second] > -19.0) & (y[second] < -11.0)]
    assert crossing.size
    assert (e.n_arcs[crossing] == 2).all()
    np.testing.assert_allclose(e.phi_entry[crossing], 0.0, atol=1e-9)
    np.testing.assert_allclose(e.phi_exit[crossing], math.pi, atol=1e-9)
    # inside the first slot's width: one arc in the middle of the edge, sin(phi) > (10 - y) / 10
    inner = second[(y[second] > 1.0) & (y[second] < 9.0)]
    assert (e.n_arcs[inner] == 1).all()
    np.testing.assert_allclose(e.phi_entry[inner], np.arcsin((10 - y[inner]) / 10), atol=0.2 * DEG)
    assert set(e.milling()[inner]) == {"inner"}


def test_default_stock_from_the_program() -> None:
    xyz, cut = _path(
        _line((-20, 0, 15), (-20, 0, 1), 1),
        _line((-20, 0, 1), (-20, 0, -5), 1),
        _line((-20, 0, -5), (20, 0, -5), 4),
        start=(-20, 0, 15),
    )
    s = default_stock(xyz, cut, R)
    np.testing.assert_allclose(s.bounds(), (-0.03, -0.01, 0.03, 0.01), atol=1e-12)
    assert (s.z_bottom, s.z_top) == (-0.005, 0.0)
    assert "no [stock]" in s.note
    assert "Z = 0" in s.note


def test_refusals() -> None:
    stock = Stock.box((0.0, -0.03, -0.01), (0.1, 0.03, 0.0))
    xyz, cut = _path(
        _line((500, 0, 5), (500, 0, -3), 1), _line((500, 0, -3), (600, 0, -3), 3), start=(500, 0, 5)
    )
    with pytest.raises(InputError, match="stock: expected the stock to contain"):
        check_stock_contains(stock, xyz, cut, R)
    with pytest.raises(InputError, match=r"stock.resolution_mm: expected at most .* 2 mm"):
        compute_engagement(xyz, cut, D, stock, resolution_m=0.003)
    axis = np.tile([0.0, math.sin(0.1), math.cos(0.1)], (len(xyz), 1))
    with pytest.raises(InputError, match="tool axis along \\+z"):
        compute_engagement(xyz, cut, D, stock, axis=axis)
    with pytest.raises(ValueError, match="min < max"):
        Stock.box((0, 0, 0), (0.1, -0.1, 0.01))
