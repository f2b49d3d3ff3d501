"""FRF quality checks: each problem is reported for its posture and direction."""

from __future__ import annotations

import numpy as np

from robolobe.modal.quality import check_campaign_grids, check_posture_frfs, usable_directions

from ._systems import make_system


def _frf():  # type: ignore[no-untyped-def]
    f = np.arange(0, 161) * 0.25
    return f, make_system(0).H(f)


def test_clean_data_has_no_findings() -> None:
    f, H = _frf()
    assert check_posture_frfs("p", f, H, band_hz=(4, 40)) == []


def test_partial_nan_is_an_error_for_that_direction_only() -> None:
    f, H = _frf()
    H[50:53, 1, 2] = np.nan
    issues = check_posture_frfs("p7", f, H, band_hz=(4, 40))
    (iss,) = issues
    assert (iss.posture_id, iss.dir, iss.check, iss.severity) == ("p7", "yz", "nan", "error")
    assert "3 of 161 lines" in iss.message
    ok = usable_directions(H, issues)
    assert not ok[1, 2]
    assert ok[2, 1]
    assert ok.sum() == 8


def test_reciprocity_passivity_coherence_grid() -> None:
    f, H = _frf()
    R = np.array([[np.cos(0.5), -np.sin(0.5), 0], [np.sin(0.5), np.cos(0.5), 0], [0, 0, 1]])
    Hr = np.einsum("ij,fjk->fik", R, H)  # sensor axes rotated by 29 deg
    checks = {(i.dir, i.check) for i in check_posture_frfs("p", f, Hr, band_hz=(4, 40))}
    assert ("xy", "reciprocity") in checks
    neg = H.copy()
    neg[:, 0, 0] *= -1  # sign error
    checks = {(i.dir, i.check) for i in check_posture_frfs("p", f, neg, band_hz=(4, 40))}
    assert ("xx", "passivity") in checks
    coh = np.ones(H.shape)
    coh[:, 2, 2] = 0.5
    iss = check_posture_frfs("p", f, H, band_hz=(4, 40), coherence=coh)
    assert [(i.dir, i.check) for i in iss] == [("zz", "coherence")]
    iss = check_posture_frfs("p", f[:100], H[:100], band_hz=(4, 40))
    assert [(i.check, i.severity) for i in iss] == [("grid", "warning")]  # ends at 24.75 Hz
    bad = f.copy()
    bad[10] = bad[9]
    iss = check_posture_frfs("p", bad, H, band_hz=(4, 40))
    assert [(i.check, i.severity) for i in iss] == [("grid", "error")]


def test_campaign_grid_consistency() -> None:
    g = np.arange(161) * 0.25
    iss = check_campaign_grids(["a", "b", "c"], [g, g, g[:120]])
    assert [(i.posture_id, i.check) for i in iss] == [("c", "grid")]
