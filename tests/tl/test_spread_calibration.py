"""The planning spread calibrated on held-out tests (robolobe.tl.residual.calibrate_spread).

References are written here: an explicit leave-one-out loop, and the scale that
uniform or normal errors need in closed form.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.tl.residual import SPREAD_CONFIDENCE, calibrate_spread

TWO_SIDED_2SIGMA = math.erf(2.0 / math.sqrt(2.0))  # 0.9545


def _reference(held, var_p):
    """Scale per quantity: the 95.45 % quantile of what each test needs, by explicit loops."""
    n, nd, nm, _ = held.shape
    out = []
    for c in range(3):
        need = []
        for j in range(nd):
            for m in range(nm):
                col = held[:, j, m, c]
                idx = [i for i in range(n) if np.isfinite(col[i])]
                if len(idx) < 3:
                    continue
                for i in idx:
                    others = [col[k] for k in idx if k != i]
                    s = math.sqrt(sum(v * v for v in others) / len(others))
                    req = col[i] ** 2 / 4.0 - var_p[i, j, m, c]
                    need.append(math.sqrt(max(req, 0.0)) / s)
        need.sort()
        # numpy's default (linear) quantile, written out
        pos = TWO_SIDED_2SIGMA * (len(need) - 1)
        lo = math.floor(pos)
        frac = pos - lo
        q = need[lo] + frac * (need[min(lo + 1, len(need) - 1)] - need[lo])
        out.append(min(max(q, 0.25), 10.0))
    return np.array(out)


def test_scale_is_the_held_out_quantile_written_out():
    rng = np.random.default_rng(0)
    held = rng.standard_t(3, size=(12, 2, 3, 3)) * np.array([0.01, 0.05, 0.2])
    held[0, 0, 0] = np.nan  # a mode not seen at a posture
    held[:, 1, 2, :] = np.nan
    held[:2, 1, 2, :] = 0.1  # an output with 2 tests: no held-out spread of its own
    var_p = rng.uniform(0.0, 1e-4, held.shape)
    scale, cover, raw = calibrate_spread(held, var_p)
    np.testing.assert_allclose(scale, _reference(held, var_p), rtol=1e-12)
    assert pytest.approx(TWO_SIDED_2SIGMA) == SPREAD_CONFIDENCE
    assert np.all((cover >= 0) & (cover <= 1))
    assert np.all((raw >= 0) & (raw <= 1))


def test_uniform_errors_need_a_narrower_spread_normal_ones_none():
    # uniform errors on [-a, a] have RMS a / sqrt(3): two RMS cover all of them, and
    # the calibrated two spreads reach the 95.45 % quantile 0.9545 a: scale
    # 0.9545 / (2 / sqrt(3)) = 0.827; normal errors: scale 1
    rng = np.random.default_rng(1)
    n, nd, nm = 40, 3, 20
    a = rng.uniform(0.01, 0.3, (1, nd, nm, 1))
    held = np.concatenate(
        [
            rng.uniform(-1, 1, (n, nd, nm, 1)) * a,
            rng.normal(0, 1, (n, nd, nm, 1)) * a,
            rng.laplace(0, 1, (n, nd, nm, 1)) * a,
        ],
        axis=-1,
    )
    scale, cover, raw = calibrate_spread(held, np.zeros_like(held))
    assert scale[0] == pytest.approx(TWO_SIDED_2SIGMA * math.sqrt(3) / 2, rel=0.03)
    assert raw[0] > 0.99  # before calibration: far too wide
    assert scale[1] == pytest.approx(1.0, abs=0.04)
    # Laplace: P(|x| <= 2 RMS) = 1 - exp(-2 sqrt 2) = 0.941 < 0.9545: wider
    assert raw[2] == pytest.approx(1 - math.exp(-2 * math.sqrt(2)), abs=0.015)
    assert scale[2] > 1.0
    # cross-validated coverage after calibration: the stated confidence
    np.testing.assert_allclose(cover, TWO_SIDED_2SIGMA, atol=0.01)


def test_parameter_variance_counts_and_few_tests_leave_the_scale_at_one():
    rng = np.random.default_rng(2)
    held = rng.normal(0, 0.1, (30, 1, 10, 3))
    # the parameters' spread alone covers every test: the model-form term is not needed
    big = np.full_like(held, 1.0)
    scale, _, _ = calibrate_spread(held, big)
    np.testing.assert_allclose(scale, 0.25)  # the least scale
    few = np.full((30, 1, 1, 3), np.nan)
    few[:3] = 0.1
    scale, cover, raw = calibrate_spread(few, np.zeros_like(few))
    np.testing.assert_array_equal(scale, 1.0)
    assert np.all(np.isnan(cover))
    assert np.all(np.isnan(raw))


def test_compliance_share_and_the_error_per_share_class():
    from robolobe.tl.residual import compliance_share, share_factor

    # one posture, one direction, three modes: 1 / (k zeta) = 1/(1e6*0.02), 1/(4e6*0.05),
    # and a mode not seen (k = inf): shares 50/(50+5) and 5/(50+5), 0
    v = np.array([[[[10.0, 0.02, 1e6], [20.0, 0.05, 4e6], [30.0, 0.03, np.inf]]]])
    share = compliance_share(v)
    np.testing.assert_allclose(share[0, 0], [50 / 55, 5 / 55, 0.0], rtol=1e-12)
    # held-out residuals 0.3 where a mode has under 5 % of the compliance, 0.1 above half:
    # relative sizes 0.3 / rms and 0.1 / rms, rms over all tests
    rng = np.random.default_rng(3)
    n = 40
    sh = np.where(rng.uniform(size=(n, 1, 2)) < 0.5, 0.01, 0.9)
    held = np.where(sh[..., None] < 0.05, 0.3, 0.1) * rng.choice([-1.0, 1.0], (n, 1, 2, 3))
    h = share_factor(held, sh)
    rms = np.sqrt(np.mean(held[..., 0] ** 2))
    np.testing.assert_allclose(h[:, 0], 0.3 / rms, rtol=1e-12)
    np.testing.assert_allclose(h[:, 3], 0.1 / rms, rtol=1e-12)
    np.testing.assert_array_equal(h[:, 1:3], 1.0)  # no tests in those classes


def test_standardized_residuals_are_the_leverage_corrected_ones_of_a_linear_fit():
    """Issue 27: the model-form spread from in-sample and held-out residuals together.

    Reference, written here: an ordinary least-squares fit, its hat matrix, and
    each test's residual from an explicit refit without it. The standardized
    residual ``r_i / sqrt(1 - h_ii)`` has the noise's variance; the held-out one
    the noise's plus that of the parameters fitted without the test.
    """
    from robolobe.tl.residual import standardized_residuals

    rng = np.random.default_rng(5)
    n, p, sigma = 16, 7, 0.1
    t_all, held_all = [], []
    for _ in range(150):
        x = rng.normal(size=(n, p))
        y = x @ rng.normal(size=p) + sigma * rng.normal(size=n)
        beta = np.linalg.lstsq(x, y, rcond=None)[0]
        inner = y - x @ beta
        held = np.empty(n)
        for i in range(n):
            keep = np.arange(n) != i
            b_i = np.linalg.lstsq(x[keep], y[keep], rcond=None)[0]
            held[i] = y[i] - x[i] @ b_i
        hat = np.einsum("ij,jk,ik->i", x, np.linalg.inv(x.T @ x), x)
        t = standardized_residuals(inner, held)
        np.testing.assert_allclose(t, inner / np.sqrt(1.0 - hat), rtol=1e-9, atol=1e-12)
        t_all.append(t)
        held_all.append(held)
    t_rms = float(np.sqrt(np.mean(np.square(t_all))))
    held_rms = float(np.sqrt(np.mean(np.square(held_all))))
    assert t_rms == pytest.approx(sigma, rel=0.05)
    # leverage p / n = 0.44 on average: held-out residuals ~ sigma / sqrt(1 - 0.44)
    assert held_rms > 1.25 * sigma
    nan = standardized_residuals(np.array([np.nan, 0.1]), np.array([0.2, np.nan]))
    assert np.all(np.isnan(nan))


def test_each_share_class_is_covered_at_the_confidence_not_only_all_pooled():
    """Issue 27: lead modes were under-covered, weak modes over-covered by one pooled scale.

    Needed scales drawn per class from distributions of different widths: the
    pooled scale covers the wide class below the confidence and the narrow
    one above; with the class factors each class is covered at its own
    95.45 % quantile (written here with numpy's quantile per class). A class
    with fewer than ``min_count`` tests keeps factor 1; the cross-validated
    coverage is an explicit leave-posture-out loop.
    """
    from robolobe.tl.residual import _SCALE_BOUNDS, class_cover_factor

    rng = np.random.default_rng(11)
    n, nd, nm = 30, 2, 4
    # shares per (posture, direction, mode): class 3 (lead) for mode 0, class 0 for the
    # rest, and class 2 at only 5 tests
    share = np.full((n, nd, nm), 0.01)
    share[:, :, 0] = 0.9
    share[:5, 0, 1] = 0.3
    width = np.where(share >= 0.5, 2.0, 0.6)[..., None]  # lead modes need wider spreads
    need = np.abs(rng.normal(size=(n, nd, nm, 3))) * width
    need[0, 0, 3, :] = np.nan  # no test there
    _, factor, cover, _ = class_cover_factor(need, share, min_count=20)
    for c in range(3):
        v = need[..., c]
        ok = np.isfinite(v)
        pooled = np.clip(np.quantile(v[ok], SPREAD_CONFIDENCE), *_SCALE_BOUNDS)
        for cls, sel in ((3, share >= 0.5), (0, share < 0.05)):
            own = np.quantile(v[ok & sel], SPREAD_CONFIDENCE)
            assert factor[c, cls] == pytest.approx(own / pooled, rel=1e-12)
            # pooled alone: the wide class under-covered, the narrow one over-covered
            if cls == 3:
                assert np.mean(v[ok & sel] <= pooled) < SPREAD_CONFIDENCE - 0.02
            else:
                assert np.mean(v[ok & sel] <= pooled) > SPREAD_CONFIDENCE + 0.02
            hit = np.mean(v[ok & sel] <= pooled * factor[c, cls])
            assert hit == pytest.approx(SPREAD_CONFIDENCE, abs=0.01)
        assert factor[c, 2] == 1.0  # 5 tests: too few for a factor of its own
        assert factor[c, 1] == 1.0  # no tests
        # cross-validated: each posture at the factors found without it
        cls_all = np.searchsorted([0.05, 0.2, 0.5], share, side="right")
        hits = []
        for i in range(n):
            rest = np.arange(n) != i
            vr, kr = v[rest], cls_all[rest]
            okr = np.isfinite(vr)
            p = np.clip(np.quantile(vr[okr], SPREAD_CONFIDENCE), *_SCALE_BOUNDS)
            f = np.ones(4)
            for b in range(4):
                s = okr & (kr == b)
                if s.sum() >= 20:
                    f[b] = np.clip(np.quantile(vr[s], SPREAD_CONFIDENCE), *_SCALE_BOUNDS) / p
            here = np.isfinite(v[i])
            hits.extend(v[i][here] <= p * f[cls_all[i][here]])
        assert cover[c] == pytest.approx(np.mean(hits), abs=1e-12)
