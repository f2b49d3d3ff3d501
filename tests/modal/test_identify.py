"""Campaign-level identification: numbering, table, fit quality, validation against truth."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.modal.identify import identify_frfs, settings_from_test
from robolobe.modal.modal_csv import MODAL_COLUMNS
from robolobe.modal.validation import compare_with_truth, true_visibility

from ._systems import drifting_campaign as _campaign


def test_campaign_table_numbering_and_accuracy() -> None:
    n = 8
    q, f, Hs, systems = _campaign(n)
    ids = [f"p{i}" for i in range(n)]
    cm = identify_frfs(ids, q, [f] * n, Hs)
    tab = cm.table
    assert list(tab.columns[: len(MODAL_COLUMNS)]) == list(MODAL_COLUMNS)
    assert set(tab["dir"]) == {"xx", "yy", "zz"}
    # rank numbering: modes rise with frequency at every posture and direction
    for _, g in tab.groupby(["posture_id", "dir"]):
        assert np.all(np.diff(g["f_hz"].to_numpy()) > 0)
        assert np.all(np.diff(g["mode"].to_numpy()) > 0)
    np.testing.assert_allclose(
        np.degrees(q[3]),
        tab[tab.posture_id == "p3"].iloc[0][[f"q{i}_deg" for i in range(1, 7)]].to_numpy(float),
    )
    F = np.array([s.f_hz for s in systems])
    Z = np.array([s.zeta for s in systems])
    K = np.array([s.k for s in systems])
    vis = true_visibility(
        np.array([s.poles for s in systems]),
        np.array([s.residues for s in systems]),
        f,
        band_hz=(4, 40),
    )
    rep = compare_with_truth(tab, ids, F, Z, K, vis)
    assert len(rep.spurious) == 0
    assert len(rep.missed) <= 0.05 * rep.n_visible
    p90 = rep.percentile(90)
    assert p90["f"] < 0.005
    assert p90["zeta"] < 0.1
    assert p90["k"] < 0.1
    assert cm.fit["frac"].min() > 0.95
    assert cm.fit["nrmse"].max() < 0.15
    # "track" numbering gives the same rows, numbered by track
    cm2 = identify_frfs(ids, q, [f] * n, Hs, numbering="track")
    assert len(cm2.table) >= 0.9 * len(tab)
    with pytest.raises(InputError, match="rank"):
        identify_frfs(ids, q, [f] * n, Hs, numbering="nope")


@pytest.mark.slow
def test_parallel_equals_serial() -> None:
    n = 8
    q, f, Hs, _ = _campaign(n, seed=3)
    ids = [f"p{i}" for i in range(n)]
    a = identify_frfs(ids, q, [f] * n, Hs, n_jobs=1).table
    b = identify_frfs(ids, q, [f] * n, Hs, n_jobs=2).table
    np.testing.assert_array_equal(a["f_hz"].to_numpy(), b["f_hz"].to_numpy())
    np.testing.assert_array_equal(a["k_N_per_m"].to_numpy(), b["k_N_per_m"].to_numpy())


def test_settings_from_test_and_errors() -> None:
    s = settings_from_test({"duration_s": 4.0, "window_end": 0.05}, fmax_hz=30.0)
    assert s.window_decay_per_s == pytest.approx(-np.log(0.05) / 4.0)
    assert s.record_length_s == 4.0
    assert s.fmax_hz == 30.0
    assert settings_from_test({}).window_decay_per_s == 0.0
    with pytest.raises(InputError, match="window_end"):
        settings_from_test({"duration_s": 4.0, "window_end": 2.0})
    with pytest.raises(InputError, match="duration_s"):
        settings_from_test({"window_end": 0.05})
    with pytest.raises(InputError, match="postures"):
        identify_frfs(["a"], np.zeros((2, 6)), [np.arange(3.0)], [np.zeros((3, 3, 3))])
    f = np.arange(0.25, 40.01, 0.25)
    with pytest.raises(InputError, match="no modes"):
        identify_frfs(["a"], np.zeros((1, 6)), [f], [np.zeros((f.size, 3, 3), complex)])


def test_neighbour_recovery_finds_a_mode_one_posture_missed() -> None:
    """The seed's practice: a mode missing at one posture is found from its neighbours' pole."""
    from dataclasses import replace

    from robolobe.modal.identify import _recover
    from robolobe.modal.posture import refit_posture

    n = 8
    q, f, Hs, systems = _campaign(n, seed=5)
    ids = [f"p{i}" for i in range(n)]
    cm = identify_frfs(ids, q, [f] * n, Hs, recover=False)
    postures = list(cm.postures)
    labels = [lab.copy() for lab in cm.tracks.labels]
    p = 4
    pm = postures[p]
    j = int(np.argmin(np.abs(pm.f_hz - systems[p].f_hz[2])))  # drop the third mode
    keep = np.arange(pm.n_modes) != j
    postures[p] = refit_posture(replace(pm, poles_measured=pm.poles_measured[keep]), [])
    lost = int(labels[p][j])
    labels[p] = labels[p][keep]
    assert postures[p].n_modes == pm.n_modes - 1
    chosen = {"xx": (lost,), "yy": (lost,), "zz": (lost,)}
    got = _recover(postures, labels, chosen, q, 3, None)
    assert set(got) == {p}
    (i,) = got[p]
    assert labels[p][i] == lost
    assert postures[p].f_hz[i] == pytest.approx(pm.f_hz[j], rel=1e-3)
    assert postures[p].zeta[i] == pytest.approx(pm.zeta[j], rel=0.05)


def test_recovery_through_the_pool_equals_serial() -> None:
    from dataclasses import replace

    from robolobe.modal.identify import _recover
    from robolobe.modal.posture import refit_posture

    n = 8
    q, f, Hs, systems = _campaign(n, seed=5)
    ids = [f"p{i}" for i in range(n)]
    cm = identify_frfs(ids, q, [f] * n, Hs, recover=False)
    runs = []
    for jobs in (1, 2):
        postures = list(cm.postures)
        labels = [lab.copy() for lab in cm.tracks.labels]
        lost = set()
        for p in (1, 4, 6):  # one mode missing at three postures: three refits
            pm = postures[p]
            j = int(np.argmin(np.abs(pm.f_hz - systems[p].f_hz[2])))
            keep = np.arange(pm.n_modes) != j
            postures[p] = refit_posture(replace(pm, poles_measured=pm.poles_measured[keep]), [])
            lost.add(int(labels[p][j]))
            labels[p] = labels[p][keep]
        chosen = {d: tuple(sorted(lost)) for d in ("xx", "yy", "zz")}
        got = _recover(postures, labels, chosen, q, 3, None, n_jobs=jobs)
        runs.append((got, [pm.poles for pm in postures], labels))
    assert runs[0][0] == runs[1][0]
    assert len(runs[0][0]) >= 2  # refits ran and were accepted
    for a, b in zip(runs[0][1], runs[1][1], strict=True):
        np.testing.assert_array_equal(a, b)


def test_analytic_refinement_jacobian_gives_the_finite_difference_modes() -> None:
    """Issue 17: the faster refinement changes no written mode beyond the optimizer tolerance."""
    from dataclasses import replace

    n = 6
    q, f, Hs, _ = _campaign(n, seed=7)
    ids = [f"p{i}" for i in range(n)]
    s = settings_from_test({"duration_s": 4.0, "window_end": 0.5})
    a = identify_frfs(ids, q, [f] * n, Hs, settings=replace(s, refine_jacobian="fd")).table
    b = identify_frfs(ids, q, [f] * n, Hs, settings=s).table
    key = ["posture_id", "dir", "mode"]
    assert len(a) == len(b) > 0
    assert (a[key].to_numpy() == b[key].to_numpy()).all()
    np.testing.assert_allclose(b["f_hz"], a["f_hz"], rtol=1e-6)
    np.testing.assert_allclose(b["zeta"], a["zeta"], rtol=1e-4)
    np.testing.assert_allclose(b["k_N_per_m"], a["k_N_per_m"], rtol=1e-4)


def test_refit_that_keeps_no_extra_pole_returns_the_posture() -> None:
    """Neighbour recovery's refit: a start where the data hold no mode drifts out of its box
    and is dropped; the posture comes back as it was (its residues are not refitted)."""
    from robolobe.modal.posture import identify_posture, refit_posture
    from robolobe.modal.synthesis import modal_to_poles

    _, f, Hs, _ = _campaign(3, seed=11)
    pm = identify_posture(f, Hs[1])
    empty = refit_posture(pm, modal_to_poles(np.array([12.0]), np.array([0.01])))
    assert empty is pm
    found = refit_posture(pm, modal_to_poles(np.array([26.0]), np.array([0.01])))
    assert found is not pm
    assert found.n_modes == pm.n_modes + 1
