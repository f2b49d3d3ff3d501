"""Residue signs: modes kept whatever their sign, the sign convention, transfer FRFs, polarity.

Truth from analytic systems (:mod:`tests.modal._systems`): the residue of
mode ``r`` in ``H_ij`` is ``u_ri u_rj / (2 i w_d)``, so its sign (and that of
``k``) is the sign of ``u_ri u_rj``, known before any identification.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.modal.identify import identify_frfs
from robolobe.modal.measurement import MEASUREMENT_COLUMNS, identify_measurement
from robolobe.modal.posture import IdentifySettings

from ._systems import ModalSystem, add_noise
from .test_identify import _campaign


def test_reversed_polarity_at_one_posture_is_reported_and_numbering_kept() -> None:
    n = 6
    q, f, Hs, _ = _campaign(n, seed=5)
    ids = [f"p{i}" for i in range(n)]
    ref = identify_frfs(ids, q, [f] * n, Hs)
    flipped = [h.copy() for h in Hs]
    flipped[2][:, 0, 0] *= -1  # accelerometer x upside down at p2
    cm = identify_frfs(ids, q, [f] * n, flipped)
    sign = [i for i in cm.issues if i.check == "sign"]
    assert [(i.posture_id, i.dir) for i in sign] == [("p2", "xx")]
    assert "all" in sign[0].message
    assert "reversed polarity" in sign[0].message
    # the x modes of p2 are identified (numbered as before) but not written with k < 0
    ref_p2 = ref.table[(ref.table.posture_id == "p2") & (ref.table.dir == "xx")]
    neg = cm.negative
    assert set(neg["posture_id"]) == {"p2"}
    assert list(neg["mode"]) == list(ref_p2["mode"])
    # (the flipped FRF no longer fits the others' shapes exactly: the poles move a little)
    np.testing.assert_allclose(neg["f_hz"], ref_p2["f_hz"], rtol=5e-3)
    np.testing.assert_allclose(-neg["k_N_per_m"], ref_p2["k_N_per_m"], rtol=0.1)
    assert not ((cm.table.posture_id == "p2") & (cm.table.dir == "xx")).any()
    # everything else is unchanged, numbers included
    keep = ~((ref.table.posture_id == "p2") & (ref.table.dir == "xx"))
    a = ref.table[keep].reset_index(drop=True)
    b = cm.table.reset_index(drop=True)
    assert list(a["mode"]) == list(b["mode"])
    np.testing.assert_allclose(a["f_hz"], b["f_hz"], rtol=5e-3)


def test_transfer_frf_declared_as_driving_point_keeps_all_modes() -> None:
    f = np.arange(0.25, 50.01, 0.25)
    u = np.array([[1.0, 1.0, 0.3], [1.0, -0.8, 0.3], [0.6, 0.9, 0.3], [0.7, -1.0, 0.3]]) / 20
    sysm = ModalSystem(np.array([7.0, 13.0, 21.0, 30.0]), np.full(4, 0.02), u)
    H = add_noise(sysm.H(f), 0.002, np.random.default_rng(1), proportional=True)
    H[:, 0, 0] = H[:, 0, 1]  # "xx" holds the transfer FRF x <- y: signs of u_x u_y
    H[:, :, 1:] = np.nan
    H[:, 1:, :] = np.nan
    cm = identify_frfs(["p"], np.zeros((1, 6)), [f], [H], numbering="track")
    pm = cm.postures[0]
    vis = pm.modes_for_direction(0)
    np.testing.assert_allclose(pm.f_hz[vis], sysm.f_hz, rtol=2e-3)
    np.testing.assert_array_equal(np.sign(pm.k_N_per_m[0, vis]), np.sign(u[:, 0] * u[:, 1]))
    (iss,) = [i for i in cm.issues if i.check == "sign"]
    assert "both signs" in iss.message
    assert "2 of 4 negative" in iss.message
    assert sorted(cm.table["f_hz"].round(0)) == [7.0, 21.0]
    assert sorted(cm.negative["f_hz"].round(0)) == [13.0, 30.0]
    # the stabilization diagram says the same: two written, two with a negative residue
    from robolobe.modal.plots import not_written

    nw = not_written(pm, cm.table)
    assert sorted(round(f) for f, why in nw if why.startswith("negative")) == [13, 30]
    assert pm.n_modes - len(nw) == len(cm.table)


def test_measurement_roving_hammer_signs_and_transfer_flag() -> None:
    f = np.arange(0.5, 120.01, 0.5)
    # a beam-like set: 4 modes, shapes at 4 points along x (1-D: direction +X everywhere)
    phi = np.array(
        [
            [1.0, 0.5, -0.4, -1.0],
            [1.0, -0.9, -0.7, 1.0],
            [1.0, -0.6, 0.9, -0.8],
            [0.7, 1.0, -1.0, 0.6],
        ]
    )
    fn = np.array([11.0, 30.0, 58.0, 95.0])
    zeta = np.array([0.01, 0.008, 0.006, 0.005])
    rng = np.random.default_rng(2)
    nodes, cols, truth = [], [], []
    for ref in range(4):  # roving hammer, accelerometer at node 1
        u = np.zeros((4, 3))
        u[:, 0] = phi[:, 0] / 30
        u[:, 1] = phi[:, ref] / 30
        H = ModalSystem(fn, zeta, u).H(f)[:, 0, 1]
        cols.append(add_noise(H[:, None, None], 0.002, rng, proportional=True)[:, 0, 0])
        nodes.append((1, 1, ref + 1, 1))
        truth.append(np.sign(phi[:, 0] * phi[:, ref]))
    s = IdentifySettings(fmin_hz=5.0, fmax_hz=110.0)
    mm = identify_measurement(f, np.stack(cols, 1), nodes, settings=s, name="beam")
    np.testing.assert_allclose(mm.f_hz, fn, rtol=1e-3)
    np.testing.assert_allclose(mm.zeta, zeta, rtol=0.1)
    # mode 4 is stiff at node 1 (k 75x mode 1's): below the visibility threshold there
    assert mm.visible[1:3].all()
    assert mm.visible.sum() >= 14
    got = np.where(mm.visible, np.sign(mm.k_N_per_m), 0)
    np.testing.assert_array_equal(got, np.where(mm.visible, np.array(truth), 0))
    # exact stiffness at the driving point (u = phi / 30 at node 1)
    k_true = (2 * np.pi * fn) ** 2 / (phi[:, 0] / 30) ** 2
    np.testing.assert_allclose(mm.k_N_per_m[0, :3], k_true[:3], rtol=0.03)
    checks = {i.check: i for i in mm.issues}
    assert "transfer" in checks
    assert "3 of 4 FRFs are transfer FRFs" in checks["transfer"].message
    assert "sign" not in checks  # the driving point has only positive residues
    assert tuple(mm.table.columns) == MEASUREMENT_COLUMNS
    # no driving point: said so
    mm2 = identify_measurement(f, np.stack(cols[1:], 1), nodes[1:], settings=s)
    assert "no driving point" in {i.check: i for i in mm2.issues}["transfer"].message


def test_identify_refuses_absurd_values_without_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from robolobe.campaign import Campaign, write_campaign
    from robolobe.cli import main as cli_main

    q, f, Hs, _ = _campaign(2, seed=1)
    q = np.radians([[-2, 21, -27, 5, 1, -29], [-60, 50, -120, 115, -66, -197]])
    camp = write_campaign(tmp_path / "c", Campaign.from_arrays("B", ["a", "b"], q, f, np.stack(Hs)))
    lines = (camp / "frf.csv").read_text().splitlines()
    parts = lines[40].split(",")
    parts[3] = "1e300"
    lines[40] = ",".join(parts)
    (camp / "frf.csv").write_text("\n".join(lines) + "\n")
    out = tmp_path / "modal.csv"
    with pytest.raises(SystemExit) as exc:
        cli_main.main(["identify", str(camp), "-o", str(out), "--plots", str(tmp_path / "pl")])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert "frf.csv:41" in err
    assert "implausible receptance" in err
    assert "Traceback" not in err
    assert not out.exists()
    assert not (tmp_path / "pl").exists()
    # the library, given such a value directly, refuses it by name too (no LinAlgError)
    bad = Hs[0].copy()
    bad[40, 0, 0] = 1e300
    with pytest.raises(InputError, match=r"posture 'a' xx: line \d+: implausible receptance"):
        identify_frfs(["a"], q[:1], [f], [bad])


def test_a_negative_mode_of_a_close_pair_is_named_as_such() -> None:
    from robolobe.modal.posture import sign_issues

    f = np.array([14.11, 14.29, 23.3])
    z = np.array([0.02, 0.036, 0.02])
    k = np.array([[-3.3e5, 1.3e6, np.nan]])
    (close,) = sign_issues("D02", ["yy"], f, k, z)
    assert "0.18 Hz from the mode at 14.29 Hz" in close.message
    assert "close pair" in close.message
    # far apart (more than three half-power bandwidths): the wiring is suspected
    (far,) = sign_issues("D02", ["yy"], np.array([14.11, 23.3, 30.0]), k, z)
    assert "close pair" not in far.message
    assert "transfer FRF" in far.message
    # without damping ratios no pair is claimed
    (plain,) = sign_issues("D02", ["yy"], f, k)
    assert "close pair" not in plain.message
