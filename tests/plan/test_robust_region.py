"""The robust bound's joint (frequency, peak compliance) error region (issue 27).

A robust plan took the 2-sigma speed window and the 2-sigma compliance
lowering at once: the corner (2, 2) of a box, 2.8 sigma from the prediction.
It now takes the worst over the disk of radius ``k_sigma`` in standardized
errors, as a few corners each planned in its own speed window.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
import pytest

import robolobe.plan.modes
from robolobe._modal_parameters import ModalParameters
from robolobe.errors import InputError
from robolobe.plan.lobes import waypoint_lobes
from robolobe.plan.modes import (
    REGION_CORNERS,
    RobotModes,
    region_confidence,
    region_corners,
    region_cover,
    region_probability,
)
from robolobe.sld.conditions import engagement_angles
from robolobe.sld.frf import ModalModel


def test_corners_hold_the_disk_for_every_linear_limit():
    """The worst of ``a t + b u`` over the corners is at least its worst over the disk
    (``hypot(a, b)``), and the one-quantity worst cases are the corners' extremes."""
    c = region_corners()
    assert c.shape == (REGION_CORNERS, 2)
    assert c[0, 0] == pytest.approx(1.0)  # the whole window with the least lowering
    assert c[-1, 1] == pytest.approx(1.0)  # the whole lowering in the narrowest window
    assert np.all(np.diff(c[:, 0]) < 0)
    assert np.all(np.diff(c[:, 1]) > 0)
    ang = np.linspace(0.0, 0.5 * math.pi, 721)
    a, b = np.cos(ang), np.sin(ang)
    support = np.max(a[:, None] * c[None, :, 0] + b[:, None] * c[None, :, 1], axis=1)
    assert np.all(support >= 1.0 - 1e-12)
    # and not far outside it: the old box corner (1, 1) gave sqrt(2) along the diagonal
    assert support.max() <= 1.0 / math.cos(0.25 * math.pi / REGION_CORNERS) + 1e-12
    for n in (1, 2, 5):
        assert np.max(np.hypot(*region_corners(n).T)) == pytest.approx(
            1.0 / math.cos(0.25 * math.pi / n)
        )


def test_region_probabilities_against_sampled_normal_errors():
    """Stated probabilities checked on sampled standard normal errors (independent of
    the formulas): the region's mass, and the limit's for limits linear in |t| and u."""
    rng = np.random.default_rng(5)
    t, u = rng.standard_normal((2, 400_000))
    k = 2.0
    inside = region_cover(k, t, u)
    assert np.mean(inside) == pytest.approx(region_probability(k), abs=0.002)
    assert region_probability(k) == pytest.approx(0.909, abs=0.001)
    assert region_confidence(k) == pytest.approx(0.9545, abs=1e-4)
    c = k * region_corners()
    for a in (0.0, 0.3, 1.0, 3.0):
        # log limit falls by a |t| + u; the bound takes the worst over the corners
        worst = np.max(a * c[:, 0] + c[:, 1])
        held = np.mean(a * np.abs(t) + u <= worst)
        assert held >= region_confidence(k) - 0.002
    # a limit with no frequency term: the one-sided k-sigma bound
    assert np.mean(u <= np.max(c[:, 1])) == pytest.approx(0.5 * (1 + math.erf(k / 2**0.5)), 2e-3)


def _one_mode_modes(s_f, s_z, s_k):
    f = np.array([[[30.0], [30.0], [np.nan]]])
    z = np.full_like(f, 0.04)
    k = np.array([[[2e6], [3e6], [np.nan]]])
    std = np.zeros((1, 3, 1, 3))
    std[..., 0], std[..., 1], std[..., 2] = s_f, s_z, s_k
    p = ModalParameters(f, z, k, ("xx", "yy", "zz"), log_std=std)
    return RobotModes(p, ModalModel.from_parameters(p), None, "test", spread_calibrated=True)


def test_bound_corners_lower_and_window_by_their_share_of_k_sigma(monkeypatch):
    # each mode lowered by k_sigma of its own spread (the lowering together:
    # test_mode_lowering.py)
    monkeypatch.setattr(robolobe.plan.modes, "MODE_LOWERING", "each")
    modes = _one_mode_modes(0.03, 0.06, 0.08)
    b = modes.robust(2.0)
    assert b is not None
    assert len(b.corners()) == REGION_CORNERS
    assert b.confidence == pytest.approx(region_confidence(2.0))
    c = region_corners()
    s_c = math.hypot(0.06, 0.08)
    for (m, w), (c_t, c_u) in zip(b.corners(), c, strict=True):
        assert w[0] == pytest.approx(2.0 * c_t * 0.03)
        # peak compliance 1 / (k zeta) of mode 1 along x raised by exp(2 c_u s_c)
        peak = m.residues[0, 0, 0, 0] / m.zeta[0, 0]
        peak0 = modes.model.residues[0, 0, 0, 0] / modes.model.zeta[0, 0]
        assert peak / peak0 == pytest.approx(math.exp(2.0 * c_u * s_c))
    assert b.window[0] == pytest.approx(2.0 * 0.03)  # the nominal's window: all of it
    assert "not both at once" in b.describe()["statement"]


def _lobes(models, window):
    st, ex = engagement_angles(0.5, "down")
    kw = dict(teeth=3, kt=767e6, kr=0.3, phi_entry=st, phi_exit=ex, immersion=0.5)
    rpm = np.linspace(3000.0, 9000.0, 400)
    return waypoint_lobes(models, rpm=rpm, window=window, **kw), rpm


def test_each_scenario_in_its_own_window_is_the_min_of_each_alone():
    """Per-scenario windows: the grid and the exact limit are the smallest of each
    scenario planned alone in its own window (the single-scenario path)."""
    modes = _one_mode_modes(0.03, 0.06, 0.08)
    feed = ModalModel(modes.model.omega, modes.model.zeta, modes.model.residues[..., :2, :2])
    soft = ModalModel(feed.omega, feed.zeta * 0.8, feed.residues * 1.3)
    w_a, w_b = np.array([0.06]), np.array([0.01])
    both, _rpm = _lobes([feed, soft], [w_a, w_b])
    alone_a, _ = _lobes([feed], w_a)
    alone_b, _ = _lobes([soft], w_b)
    ref = np.minimum(alone_a.table.a_lim[0], alone_b.table.a_lim[0])
    np.testing.assert_allclose(both.table.a_lim[0], ref, rtol=1e-12)
    rows = np.linspace(3100.0, 8900.0, 57)[None]
    g = np.zeros(1, np.int64)
    ex_ref = np.minimum(alone_a.table.exact(rows, g), alone_b.table.exact(rows, g))
    np.testing.assert_allclose(both.table.exact(rows, g), ex_ref, rtol=1e-12)
    # the same window for both: the shared path, the same answer as a one-row window
    same, _ = _lobes([feed, soft], [w_a, w_a])
    shared, _ = _lobes([feed, soft], w_a)
    np.testing.assert_allclose(same.table.a_lim, shared.table.a_lim, rtol=0)
    # the joint region is never below the old box (both worst cases at once)
    assert np.all(both.table.a_lim[0] >= _lobes([soft], w_a)[0].table.a_lim[0] - 1e-15)
    with pytest.raises(InputError, match="one window per model"):
        _lobes([feed, soft], [w_a])


def _two_mode_modes(s_f_weak, s_c=0.05, f_weak=45.0, k_weak=6e6):
    """A leading mode (30 Hz) and a weak one (45 Hz, a third of its peak compliance)."""
    f = np.array([[[30.0, f_weak], [np.nan, np.nan], [np.nan, np.nan]]])
    z = np.full_like(f, 0.04)
    k = np.array([[[2e6, k_weak], [np.nan, np.nan], [np.nan, np.nan]]])
    std = np.zeros((1, 3, 2, 3))
    std[0, 0, 0] = (0.01, s_c, s_c)
    std[0, 0, 1] = (s_f_weak, s_c, s_c)
    p = ModalParameters(f, z, k, ("xx", "yy", "zz"), log_std=std)
    return RobotModes(p, ModalModel.from_parameters(p), None, "test", spread_calibrated=True)


def test_mode_shifts_move_each_weak_mode_by_its_own_spread():
    """Each corner twice: the modes that lead stay (the window covers them), every other
    mode down and up by ``c_t k_sigma`` of its own frequency spread at its own stiffness."""
    modes = _two_mode_modes(0.06)
    plain = modes.robust(2.0, mode_shifts=False)
    b = modes.robust(2.0, mode_shifts=True)
    assert plain is not None
    assert b is not None
    assert len(plain.corners()) == REGION_CORNERS
    assert len(b.corners()) == 2 * REGION_CORNERS
    w0 = modes.model.omega[0]
    lead = int(np.argmin(np.abs(w0 - 2 * np.pi * 30.0)))
    weak = 1 - lead
    for i, (c_t, _c_u) in enumerate(region_corners()):
        ref_m, ref_w = plain.corners()[i]
        for j, sign in enumerate((-1.0, 1.0)):
            m, w = b.corners()[2 * i + j]
            np.testing.assert_allclose(w, ref_w)
            assert m.omega[0, lead] == pytest.approx(w0[lead])
            g = math.exp(sign * 2.0 * c_t * 0.06)
            assert m.omega[0, weak] / w0[weak] == pytest.approx(g)
            # the same modal stiffness (residue / omega^2) and damping as the corner's
            k_ref = ref_m.omega[0, weak] ** 2 / ref_m.residues[0, weak, 0, 0]
            assert m.omega[0, weak] ** 2 / m.residues[0, weak, 0, 0] == pytest.approx(k_ref)
            assert m.zeta[0, weak] == pytest.approx(ref_m.zeta[0, weak])


def test_mode_shifts_cover_a_weak_mode_that_sets_the_limit():
    """A weak mode next to the leading one (33 vs 30 Hz, 0.44 of its peak compliance)
    whose truth lies 1.8 of its own frequency spreads low (inside its spread, outside the
    leading mode's window; the lobe flank above both modes then moves): the bound with
    mode shifts stays at or below the truth's limit at every speed, the joint region
    alone does not (its compliance lowering kept small, 1 % spreads, so that it does not
    hide the miss; limits computed independently for each model)."""
    modes = _two_mode_modes(0.06, s_c=0.01, f_weak=33.0, k_weak=4.5e6)
    m0 = modes.model
    weak = int(np.argmin(np.abs(m0.omega[0] - 2 * np.pi * 33.0)))
    g = np.ones_like(m0.omega)
    g[0, weak] = math.exp(-1.8 * 0.06)
    truth = ModalModel(m0.omega * g, m0.zeta, m0.residues * (g**2)[..., None, None])

    def feed(m):
        return ModalModel(m.omega, m.zeta, m.residues[..., :2, :2])

    st, ex = engagement_angles(0.5, "down")
    kw = dict(teeth=3, kt=767e6, kr=0.3, phi_entry=st, phi_exit=ex, immersion=0.5)
    rpm = np.linspace(200.0, 12000.0, 1500)
    a_true = waypoint_lobes([feed(truth)], rpm=rpm, **kw).table.a_lim[0]
    out = {}
    for shifts in (False, True):
        b = modes.robust(2.0, mode_shifts=shifts)
        assert b is not None
        cs = b.corners()
        lob = waypoint_lobes([feed(m) for m, _ in cs], rpm=rpm, window=[w for _, w in cs], **kw)
        out[shifts] = lob.table.a_lim[0]
    assert np.all(out[True] <= a_true * (1 + 1e-9))
    assert np.max(out[False] / a_true) > 1.2


def test_joint_sigma_holds_m_intervals_together_with_the_regions_confidence():
    """``m`` independent intervals of ``joint_sigma(k, m)`` sigmas hold together with
    ``2 Phi(k) - 1`` (checked with math.erf and on sampled normal errors)."""
    from robolobe.plan.modes import joint_sigma

    k = 2.0
    c = math.erf(k / math.sqrt(2.0))
    ms = np.arange(1, 7)
    km = joint_sigma(k, ms)
    assert km[0] == pytest.approx(k)
    assert np.all(np.diff(km) > 0)
    for m, w in zip(ms, km, strict=True):
        assert math.erf(w / math.sqrt(2.0)) ** m == pytest.approx(c, rel=1e-12)
    e = np.random.default_rng(3).standard_normal((200_000, 4))
    assert np.mean(np.all(np.abs(e) <= km[3], axis=1)) == pytest.approx(c, abs=0.002)


def _coupled_weak_mode(s_x, s_y):
    """A leading mode along x (30 Hz) and a weak one (40 Hz) whose shape is 1/3 in x and
    1 in y (residue shares 10 % and 90 % of its x/y plane), coupled shapes."""
    w = 2 * np.pi * np.array([[30.0, 40.0]])
    u = np.array([[[0.02, 0.002, 0.0], [0.002, 0.006, 0.0]]])  # (1, modes, xyz) [1/sqrt(kg)]
    model = ModalModel.from_shapes(w, np.full((1, 2), 0.04), u)
    with np.errstate(divide="ignore"):
        k = w[:, None, :] ** 2 / np.swapaxes(u, 1, 2) ** 2  # (1, 3, 2)
    f = np.broadcast_to((w / (2 * np.pi))[:, None, :], k.shape)
    std = np.zeros((1, 3, 2, 3))
    std[..., 1:] = 0.05
    std[0, :, 0, 0] = 0.01
    std[0, 0, 1, 0], std[0, 1, 1, 0] = s_x, s_y
    p = ModalParameters(f, np.full(k.shape, 0.04), k, ("xx", "yy", "zz"), log_std=std)
    return RobotModes(p, model, None, "test", shapes_coupled=True, spread_calibrated=True)


def test_cut_shift_spread_is_the_residue_weighted_spread_of_the_cut_plane(monkeypatch):
    """``MODE_SHIFT_SPREAD = "cut"``: a weak mode seen 90 % in y is shifted by its x and y
    spreads weighted by its residue there (in quadrature), widened for the shifted modes
    together (one here: k_sigma); ``"largest"``: by its largest spread (x, 20 %)."""
    import robolobe.plan.modes as pm

    modes = _coupled_weak_mode(0.20, 0.02)
    m0 = modes.model
    weak = int(np.argmax(m0.omega[0]))
    r = np.array([0.002**2, 0.006**2])
    ref = math.sqrt(np.sum(r / r.sum() * np.array([0.20, 0.02]) ** 2))  # per sigma
    for rule, per_sigma in (("cut", ref), ("largest", 0.20)):
        monkeypatch.setattr(pm, "MODE_SHIFT_SPREAD", rule)
        b = modes.robust(2.0, mode_shifts=True)
        assert b is not None
        for i, (c_t, _c_u) in enumerate(region_corners()):
            up, _ = b.corners()[2 * i + 1]
            g = up.omega[0, weak] / m0.omega[0, weak]
            assert g == pytest.approx(math.exp(min(2.0 * c_t * per_sigma, pm.MAX_WINDOW)))
    assert ref < 0.07
    monkeypatch.setattr(pm, "MODE_SHIFT_SPREAD", "widest")
    with pytest.raises(ValueError, match="MODE_SHIFT_SPREAD"):
        modes.robust(2.0, mode_shifts=True)


def _weak_mode_and_neighbour(f3_hz):
    """``_coupled_weak_mode``'s lead (30 Hz, x) and weak mode (40 Hz, spreads 20 % in x,
    2 % in y) and a third mode at ``f3_hz`` (shape (0.008, 0.006), 2 % spread in x and y)
    that matters (6-13 % of the lead's peak compliance) and does not lead."""
    w = 2 * np.pi * np.array([[30.0, 40.0, f3_hz]])
    u = np.array([[[0.02, 0.002, 0.0], [0.002, 0.006, 0.0], [0.008, 0.006, 0.0]]])
    model = ModalModel.from_shapes(w, np.full((1, 3), 0.04), u)
    with np.errstate(divide="ignore"):
        k = w[:, None, :] ** 2 / np.swapaxes(u, 1, 2) ** 2  # (1, 3, 3)
    f = np.broadcast_to((w / (2 * np.pi))[:, None, :], k.shape)
    std = np.zeros((1, 3, 3, 3))
    std[..., 1:] = 0.05
    std[0, :, 0, 0] = 0.01
    std[0, 0, 1, 0], std[0, 1, 1, 0] = 0.20, 0.02
    std[0, :2, 2, 0] = 0.02
    p = ModalParameters(f, np.full(k.shape, 0.04), k, ("xx", "yy", "zz"), log_std=std)
    return RobotModes(p, model, None, "test", shapes_coupled=True, spread_calibrated=True)


@pytest.mark.parametrize("f3_hz", [42.0, 60.0])
def test_pair_shift_takes_the_largest_spread_only_where_two_modes_can_meet(monkeypatch, f3_hz):
    """``MODE_SHIFT_SPREAD = "pairs"``: the weak 40 Hz mode is shifted by its cut-weighted
    spread (widened for the two shifted modes together) when no other mode that matters
    lies within their 2-sigma reach (60 Hz: log gap 0.41), and by its largest spread (x,
    20 %) when one does (42 Hz: log gap 0.049 against a reach of 2 x 6.6 %): the shapes of
    two modes that can meet mix, which driving-point tests do not pin down."""
    import robolobe.plan.modes as pm

    monkeypatch.setattr(pm, "MODE_SHIFT_SPREAD", "pairs")
    modes = _weak_mode_and_neighbour(f3_hz)
    m0 = modes.model
    weak = int(np.argsort(m0.omega[0])[1])
    assert m0.omega[0, weak] == pytest.approx(2 * np.pi * 40.0)
    r = np.array([0.002**2, 0.006**2])
    cut = math.sqrt(np.sum(r / r.sum() * np.array([0.20, 0.02]) ** 2))  # per sigma
    # two shifted modes held together (Sidak) at the region's 95.45 %
    c = math.erf(2.0 / math.sqrt(2.0))
    k2 = NormalDist().inv_cdf(0.5 * (1.0 + math.sqrt(c)))
    near = abs(math.log(f3_hz / 40.0)) <= 2.0 * math.hypot(cut, 0.02)
    assert near == (f3_hz == 42.0)
    per_corner = 2.0 * 0.20 if near else k2 * cut
    b = modes.robust(2.0, mode_shifts=True)
    assert b is not None
    for i, (c_t, _c_u) in enumerate(region_corners()):
        up, _ = b.corners()[2 * i + 1]
        g = up.omega[0, weak] / m0.omega[0, weak]
        assert g == pytest.approx(math.exp(min(c_t * per_corner, pm.MAX_WINDOW)))
