"""``robolobe identify`` end to end: a campaign folder -> modal.csv, plots, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robolobe.campaign import Campaign, write_campaign
from robolobe.cli import main as cli_main
from robolobe.modal.modal_csv import MODAL_COLUMNS, read_modal_csv
from robolobe.robots import load_robot
from robolobe.twin.designs import design_arrays, load_seed_design
from robolobe.twin.model import Twin


def _run(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as exc:
        cli_main.main(args)
    out = capsys.readouterr()
    return int(exc.value.code or 0), out.out, out.err


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Robot B, 4 seed postures, exact twin receptance + 0.5 % noise, xx/yy/zz, 0-40 Hz."""
    ids, q, _ = design_arrays(load_seed_design("B"))
    ids, q = ids[:4], q[:4]
    f = np.arange(0, 161) * 0.25
    H = Twin(load_robot("B")).receptance(q, f, method="modal")
    rng = np.random.default_rng(0)
    H = H * (1 + 0.005 * (rng.normal(size=H.shape) + 1j * rng.normal(size=H.shape)))
    camp = Campaign.from_arrays("B", ids, q, f, H, dirs=("xx", "yy", "zz"))
    return write_campaign(tmp_path_factory.mktemp("camp") / "B", camp)


@pytest.mark.slow
def test_identify_writes_modal_csv_and_plots(
    campaign_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "modal.csv"
    plots = tmp_path / "plots"
    fit = tmp_path / "fit.csv"
    code, stdout, stderr = _run(
        [
            "identify",
            str(campaign_dir),
            "-o",
            str(out),
            "--plots",
            str(plots),
            "--fit-report",
            str(fit),
        ],
        capsys,
    )
    assert code == 0, stderr
    df = read_modal_csv(out)
    assert list(df.columns[:12]) == list(MODAL_COLUMNS)
    assert set(df["posture_id"]) == {"P01", "P02", "P03", "P04"}
    # every visible mode (no fixed count since issue 27), at most the six-joint twin's
    # six per posture and direction, numbered by rising frequency
    assert df.groupby(["posture_id", "dir"]).size().max() <= 6
    for _, g in df.groupby(["posture_id", "dir"]):
        assert (g["mode"].diff().dropna() > 0).all()
        assert (g["f_hz"].diff().dropna() > 0).all()
    rep = pd.read_csv(fit)
    assert len(rep) == 12
    assert rep["frac"].min() > 0.95
    assert rep["nrmse"].max() < 0.15
    assert "fit quality" in stdout
    assert "FRAC" in stdout
    pngs = sorted(p.name for p in plots.glob("*.png"))
    assert pngs[:2] == ["frf_P01.png", "frf_P02.png"]
    assert len(pngs) == 8
    assert all(p.stat().st_size > 10_000 for p in plots.glob("*.png"))


def test_identify_options(
    campaign_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "m.csv"
    code, stdout, err = _run(
        [
            "identify",
            str(campaign_dir),
            "-o",
            str(out),
            "--modes",
            "2",
            "--fmax",
            "20",
            "--numbering",
            "track",
            "--no-recover",
        ],
        capsys,
    )
    assert code == 0, err
    # quiet: the sign convention only with -v (no negative driving-point residue here)
    assert "sign convention" not in stdout + err
    assert "4 postures," in stdout
    df = read_modal_csv(out)
    assert df.groupby(["posture_id", "dir"]).size().max() <= 2
    assert df["f_hz"].max() <= 20
    code, stdout, err = _run(
        ["identify", str(campaign_dir), "-o", str(out), "--modes", "2", "--fmax", "20", "-v"],
        capsys,
    )
    assert code == 0, err
    assert "sign convention" in stdout
    for args, needle in (
        (["--modes", "0"], "--modes"),
        (["--fmin", "50"], "--fmin"),
        (["--window-end", "0.05"], "--window-end"),  # no record length in this campaign
        (["--numbering", "x"], "--numbering"),
    ):
        code, _, err = _run(
            ["identify", str(campaign_dir), "-o", str(tmp_path / "x.csv"), *args], capsys
        )
        assert code == 2
        assert needle in err
        assert "Traceback" not in err
        assert not (tmp_path / "x.csv").exists()


def _corrupt(src: Path, dst: Path, fname: str, edit) -> Path:  # type: ignore[no-untyped-def]
    import shutil

    shutil.copytree(src, dst)
    p = dst / fname
    lines = p.read_text().splitlines()
    lines = edit(lines)
    p.write_text("\n".join(lines) + "\n")
    return dst


def _set_field(line: str, col: int, value: str) -> str:
    parts = line.split(",")
    parts[col] = value
    return ",".join(parts)


@pytest.mark.parametrize(
    ("fname", "edit", "needles"),
    [
        ("frf.csv", lambda ls: [ls[0].replace(",re,", ",real,"), *ls[1:]], ["frf.csv"]),
        ("frf.csv", lambda ls: [*ls[:7], _set_field(ls[7], 3, "nan"), *ls[8:]], ["frf.csv:8"]),
        ("frf.csv", lambda ls: [*ls[:5], ls[6], ls[5], *ls[7:]], ["frf.csv:"]),
        ("postures.csv", lambda ls: [*ls, "P99,0,0,-60,0,0,0"], ["P99"]),
    ],
    ids=["wrong-column", "nan", "non-monotonic", "posture-missing"],
)
def test_bad_campaign_one_clear_error_no_output(
    campaign_dir: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    fname: str,
    edit,
    needles: list[str],  # type: ignore[no-untyped-def]
) -> None:
    bad = _corrupt(campaign_dir, tmp_path / "bad", fname, edit)
    out = tmp_path / "modal.csv"
    code, _stdout, err = _run(["identify", str(bad), "-o", str(out)], capsys)
    assert code == 2
    assert "Traceback" not in err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1, err
    for n in needles:
        assert n in err
    assert not out.exists()
    assert not list(tmp_path.glob(".modal.csv*"))


def test_uff_acceleration_campaign_gives_the_same_modes(
    campaign_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The same campaign stored as UFF 58 accelerance (converted on reading) -> same table."""
    from robolobe.campaign import read_campaign

    uff = write_campaign(
        tmp_path / "uff", read_campaign(campaign_dir), fmt="uff", uff_quantity="acceleration"
    )
    assert len(list((uff / "frf").glob("*.uff"))) == 4
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert _run(["identify", str(campaign_dir), "-o", str(a)], capsys)[0] == 0
    assert _run(["identify", str(uff), "-o", str(b)], capsys)[0] == 0
    ta, tb = read_modal_csv(a), read_modal_csv(b)
    assert len(ta) == len(tb)
    np.testing.assert_allclose(tb["f_hz"], ta["f_hz"], rtol=1e-6)
    np.testing.assert_allclose(tb["k_N_per_m"], ta["k_N_per_m"], rtol=1e-4)
