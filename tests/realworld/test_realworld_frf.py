"""Measured FRF files from public repositories (``../shared/realworld/frf``), read as a user would.

Facts from ``realworld/README.md`` (not from robolobe): pyuff's
``meas_point_*.txt`` are transfer accelerances of a free-free beam, 0-1000 Hz
at 1 Hz, whose residues alternate in sign; its modes are published at 51.5,
142.2, 278.7, 460.4, 687.2 and 958.5 Hz. ``Sample_UFF58*`` are pyuff's
samples of dataset 58 written by other tools; ``non_ascii_header.uff`` has a
Latin-1 ``\u00b2`` in its unit label and direction codes 0.

The user's path for the beam is pyuff's showcase: the text files written
into one UFF file (dataset 58, accelerance, the response at node 1 and the
hammer at nodes 1, 2, 3), then ``robolobe identify beam.uff``. The checks are
independent of the code under test: the published frequencies, peak picking
on the raw data written here, sdypy-EMA's LSCF poles and the sign of the
measured imaginary part at each peak.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robolobe.campaign.uff import read_uff_frf, read_uff_frfs
from robolobe.cli import main as cli_main
from robolobe.errors import InputError

pyuff = pytest.importorskip("pyuff")

REALWORLD = Path(__file__).resolve().parents[2] / ".." / "shared" / "realworld" / "frf"
if not REALWORLD.is_dir():
    pytest.skip(f"realworld FRF files not found at {REALWORLD}", allow_module_level=True)

PUBLISHED_HZ = np.array([51.5, 142.2, 278.7, 460.4, 687.2, 958.5])


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as exc:
        cli_main.main(args)
    out = capsys.readouterr()
    return int(exc.value.code or 0), out.out, out.err


def _accelerances(sign: float = 1.0) -> list[np.ndarray]:
    return [
        sign * np.genfromtxt(REALWORLD / f"meas_point_{i}.txt", dtype=complex) for i in (1, 2, 3)
    ]


def _showcase_uff(path: Path, sign: float = 1.0) -> Path:
    """pyuff's showcase: the three accelerances as dataset 58 records, 0 Hz set to NaN."""
    sets = []
    for i, a in enumerate(_accelerances(sign)):
        a = a.copy()
        a[0] = np.nan * (1 + 1j)
        sets.append(
            pyuff.prepare_58(
                func_type=4,
                rsp_node=1,
                rsp_dir=1,
                ref_node=i + 1,
                ref_dir=1,
                data=a,
                x=np.arange(a.size, dtype=float),
                id1="id1",
                rsp_ent_name="TestCase",
                ref_ent_name="TestCase",
                abscissa_spacing=1,
                abscissa_spec_data_type=18,
                ordinate_spec_data_type=12,
                orddenom_spec_data_type=13,
            )
        )
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


def _peaks(a: np.ndarray) -> np.ndarray:
    """Independent peak picking: the six most prominent maxima of |A| above 20 Hz (1 Hz lines)."""
    from scipy.signal import find_peaks

    mag = np.abs(a)
    idx, props = find_peaks(np.log(mag), prominence=1.0)
    prom = props["prominences"]
    sel = idx >= 20
    top = np.sort(idx[sel][np.argsort(-prom[sel])[:6]])
    return top.astype(float)


def test_published_peaks_match_the_raw_data() -> None:
    # the facts used below, checked on the raw lines by peak picking
    for a in _accelerances():
        assert np.all(np.abs(_peaks(a) - PUBLISHED_HZ) <= 1.0)


def test_beam_all_six_modes_within_0p05_percent(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    uff = _showcase_uff(tmp_path / "beam.uff")
    out = tmp_path / "modes.csv"
    code, stdout, stderr = _run(["identify", str(uff), "-o", str(out)], capsys)
    assert code == 0, stderr
    df = pd.read_csv(out)
    modes = df.groupby("mode")["f_hz"].first().to_numpy()
    assert modes.size == 6
    np.testing.assert_allclose(modes, PUBLISHED_HZ, rtol=5e-4)
    # every FRF shows every mode (one mode numbering for all of them)
    assert df.groupby("frf")["mode"].apply(lambda m: sorted(m) == [1, 2, 3, 4, 5, 6]).all()
    # flagged as transfer FRFs; never "no problems found"
    text = " ".join((stdout + stderr).split())
    assert "transfer FRFs" in text
    assert "residues of both signs" in text
    assert "no problems found" not in text
    assert "sign convention" in text


def test_beam_signs_follow_the_measured_imaginary_part(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    uff = _showcase_uff(tmp_path / "beam.uff")
    out = tmp_path / "modes.csv"
    assert _run(["identify", str(uff), "-o", str(out)], capsys)[0] == 0
    df = pd.read_csv(out)
    f = np.arange(1001, dtype=float)
    for i, a in enumerate(_accelerances()):
        g = df[df["ref_node"] == i + 1].sort_values("mode")
        # receptance H = A / -w^2 near a lightly damped mode ~ (w_r^2 / k) / (w_r^2 - w^2):
        # Re H jumps from +big to -big across the resonance when k > 0
        h = a / -((2 * np.pi * f) ** 2 + 1e-300)
        fr = g["f_hz"].to_numpy()
        lo, hi = np.floor(fr).astype(int), np.ceil(fr).astype(int)
        np.testing.assert_array_equal(
            np.sign(g["k_N_per_m"].to_numpy()), np.sign(h[lo].real - h[hi].real)
        )
    # the residues alternate: both signs in every FRF (README: transfer accelerances)
    assert df.groupby("frf")["k_N_per_m"].apply(lambda k: (k > 0).any() and (k < 0).any()).all()


def test_beam_upside_down_accelerometer_keeps_the_same_modes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a = tmp_path / "a.csv"
    b = tmp_path / "b.csv"
    assert _run(["identify", str(_showcase_uff(tmp_path / "a.uff")), "-o", str(a)], capsys)[0] == 0
    assert (
        _run(["identify", str(_showcase_uff(tmp_path / "b.uff", -1.0)), "-o", str(b)], capsys)[0]
        == 0
    )
    da, db = pd.read_csv(a), pd.read_csv(b)
    assert len(da) == len(db) == 18
    np.testing.assert_allclose(db["f_hz"], da["f_hz"], rtol=1e-9)
    np.testing.assert_allclose(db["k_N_per_m"], -da["k_N_per_m"], rtol=1e-6)


def test_beam_frequencies_agree_with_sdypy_ema(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    EMA = pytest.importorskip("sdypy.EMA")
    out = tmp_path / "modes.csv"
    assert (
        _run(["identify", str(_showcase_uff(tmp_path / "b.uff")), "-o", str(out)], capsys)[0] == 0
    )
    ours = pd.read_csv(out).groupby("mode")["f_hz"].first().to_numpy()
    frf = np.stack(_accelerances())[:, 1:]
    freq = np.arange(1, 1001, dtype=float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = EMA.Model(
            frf=frf, freq=freq, lower=20, upper=1000, pol_order_high=60, frf_form="accelerance"
        )
        model.get_poles(show_progress=False)
        model.select_closest_poles(list(PUBLISHED_HZ), f_window=5)
    capsys.readouterr()
    theirs = np.sort(np.asarray(model.nat_freq, dtype=float))
    np.testing.assert_allclose(ours, theirs, rtol=1e-4)


def test_beam_as_a_campaign_of_driving_points_reports_the_sign_problem(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The same data declared as driving points (dir xx) of a 3-posture campaign."""
    from robolobe.campaign import Campaign, write_campaign
    from robolobe.modal.modal_csv import read_modal_csv

    f = np.arange(1, 1001, dtype=float)
    H = np.full((3, f.size, 3, 3), np.nan + 0j)
    for i, a in enumerate(_accelerances()):
        H[i, :, 0, 0] = a[1:] / -((2 * np.pi * f) ** 2)
    q = np.radians(
        [[-2, 21, -27, 5, 1, -29], [-60, 50, -120, 115, -66, -197], [23, -28, -101, -82, 124, 168]]
    )
    camp = write_campaign(tmp_path / "beam", Campaign.from_arrays("B", ["p1", "p2", "p3"], q, f, H))
    out = tmp_path / "modal.csv"
    code, stdout, stderr = _run(
        ["identify", str(camp), "-o", str(out), "--fmin", "20", "--fmax", "990", "--modes", "6"],
        capsys,
    )
    assert code == 0, stderr
    text = " ".join((stdout + stderr).split())
    assert "negative driving-point residue" in text
    assert "residues of both signs" in text
    assert "no problems found" not in text
    df = read_modal_csv(out)
    assert (df["k_N_per_m"] > 0).all()
    # one numbering for all postures: a mode number names one frequency everywhere
    spread = df.groupby("mode")["f_hz"].agg(lambda x: x.max() / x.min() - 1)
    assert (spread < 1e-3).all()
    for m, fm in df.groupby("mode")["f_hz"].median().items():
        assert abs(fm - PUBLISHED_HZ[int(m) - 1]) / PUBLISHED_HZ[int(m) - 1] < 5e-4


@pytest.mark.parametrize("name", ["Sample_UFF58_ascii.uff", "Sample_UFF58b_bin.uff"])
def test_time_records_are_refused_by_name(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(InputError, match=r":1: record 1 \(dataset 58\).*function type 4.*time"):
        read_uff_frfs(REALWORLD / name, source=name)
    code, _, err = _run(["identify", str(REALWORLD / name), "-o", str(tmp_path / "m.csv")], capsys)
    assert code == 2
    assert "function type 4" in err
    assert "Traceback" not in err
    assert not (tmp_path / "m.csv").exists()


def test_non_ascii_header_direction_0_refused_and_label_read(tmp_path: Path) -> None:
    src = REALWORLD / "non_ascii_header.uff"
    with pytest.raises(InputError, match=r":1: record 1.*response direction 0"):
        read_uff_frfs(src)
    with pytest.raises(InputError, match="direction 0"):
        read_uff_frf(src)
    # with its directions set (response node 2 +X, reference node 1 +X), the Latin-1 label
    # "(1/N)*(m/s\xb2)" on a "general" data type (1) is read as accelerance
    raw = src.read_bytes()
    assert b"(m/s\xb2)" in raw  # the fact the test relies on
    dof = b"    4         0    0         0 NONE               0   0 NONE               0   0"
    assert raw.count(dof) == 1
    fixed = tmp_path / "fixed.uff"
    fixed.write_bytes(
        raw.replace(
            dof, b"    4         0    0         0 NONE               2   1 NONE               1   1"
        )
    )
    (rec,) = read_uff_frfs(fixed)
    assert rec.quantity == "acceleration"
    assert rec.label == "2+X/1+X"
    assert not rec.driving_point
    # independent: the numbers as printed in the file, divided by -w^2 (0 Hz dropped)
    nums = [float(x) for x in raw.split(b"\n")[13].split() + raw.split(b"\n")[14].split()]
    a = np.array(nums[0::2]) + 1j * np.array(nums[1::2])
    f = 0.195313 * np.arange(6)
    np.testing.assert_allclose(rec.freq_hz, f[1:])
    np.testing.assert_allclose(rec.H, a[1:] / -((2 * np.pi * f[1:]) ** 2), rtol=1e-12)


def test_meas_point_text_is_not_taken_for_a_campaign(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = _run(
        ["identify", str(REALWORLD / "meas_point_1.txt"), "-o", str(tmp_path / "m.csv")], capsys
    )
    assert code == 2
    assert "UFF file" in err
    assert not (tmp_path / "m.csv").exists()
