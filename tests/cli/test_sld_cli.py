"""End-to-end: ``robolobe sld`` (the CLI contract of issue 4)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from robolobe.cli.main import app
from robolobe.sld import CuttingConditions, Material, ModalModel, stability_lobes

F_N, ZETA = 922.0, 0.011
K = 0.03993 * (2 * math.pi * F_N) ** 2  # REFERENCES.md section 3 system
runner = CliRunner()


@pytest.fixture
def modes(tmp_path: Path) -> Path:
    p = tmp_path / "modes.csv"
    p.write_text(
        f"dir,mode,f_hz,zeta,k_N_per_m\nxx,1,{F_N},{ZETA},{K!r}\nyy,1,{F_N},{ZETA},{K!r}\n"
    )
    return p


def _args(modes: Path, out: Path, *extra: str) -> list[str]:
    return [
        "sld",
        "--modes",
        str(modes),
        "--teeth",
        "2",
        "--kt",
        "6e8",
        "--kr",
        str(1 / 3),
        "--immersion",
        "1",
        "--milling",
        "down",
        "--rpm",
        "5000:60000",
        "-o",
        str(out),
        *extra,
    ]


def test_zoa_contract(tmp_path: Path, modes: Path) -> None:
    out = tmp_path / "lobes.csv"
    png = tmp_path / "lobes.png"
    res = runner.invoke(app, _args(modes, out, "--plot", str(png)))
    assert res.exit_code == 0, res.output
    assert out.read_text().splitlines()[0] == "rpm,a_lim_mm"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (1000, 2)
    np.testing.assert_allclose(data[:, 0], np.linspace(5000, 60000, 1000))
    model = ModalModel.isotropic([F_N], [ZETA], [K])
    want = stability_lobes(
        model,
        cutter=2,
        material=Material("m", 6e8, 1 / 3),
        conditions=CuttingConditions.from_immersion(1.0, "down"),
        rpm=np.linspace(5000, 60000, 1000),
        max_lobe=None,
    )
    np.testing.assert_allclose(data[:, 1], want.a_lim * 1e3, rtol=1e-8)
    # REFERENCES.md: 2-DOF slot minimum 0.047925 mm (the grid minimum lies just above it)
    assert 0.047925 <= data[:, 1].min() < 0.0482
    assert "minimum a_lim" in res.output
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_low_immersion_message(tmp_path: Path, modes: Path) -> None:
    out = tmp_path / "lobes.csv"
    args = _args(modes, out)
    args[args.index("--immersion") + 1] = "0.1"
    res = runner.invoke(app, args)
    assert res.exit_code == 0
    assert "unreliable" in res.output
    assert "a/D = 0.1" in res.output


def test_sdm_method(tmp_path: Path, modes: Path) -> None:
    out = tmp_path / "lobes.csv"
    args = _args(modes, out, "--method", "sdm", "--intervals", "20")
    args[args.index("--rpm") + 1] = "17000:19000:5"
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape == (5, 2)
    # SDM and ZOA agree within ~1 % near the slot lobe bottom
    assert data[:, 1].min() == pytest.approx(0.047925, rel=0.01)


def test_material_option(tmp_path: Path, modes: Path) -> None:
    out = tmp_path / "lobes.csv"
    args = [a for a in _args(modes, out) if a not in ("--kt", "6e8", "--kr", str(1 / 3))]
    res = runner.invoke(app, [*args, "--material", "Al7075-T6"])
    assert res.exit_code == 0, res.output
    assert "Kt=7.67e+08" in res.output


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("--rpm", "60000:5000"), "--rpm"),
        (("--milling", "climb"), "--milling"),
        (("--immersion", "1.5"), "immersion"),
        (("--teeth", "0"), "--teeth"),
        (("--method", "fem"), "--method"),
    ],
)
def test_bad_input_exit_2(
    tmp_path: Path, modes: Path, change: tuple[str, str], message: str
) -> None:
    out = tmp_path / "lobes.csv"
    args = _args(modes, out, "--method", "zoa")
    args[args.index(change[0]) + 1] = change[1]
    proc = subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", *args],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2, proc.stderr
    assert message in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_bad_modes_file_names_line(tmp_path: Path) -> None:
    bad = tmp_path / "modes.csv"
    bad.write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,922,0.011,1e6\nyy,1,922,zero,1e6\n")
    out = tmp_path / "lobes.csv"
    proc = subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", *_args(bad, out)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert "modes.csv:3" in proc.stderr
    assert "zeta" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not out.exists()


def test_missing_kt_without_material(tmp_path: Path, modes: Path) -> None:
    out = tmp_path / "lobes.csv"
    args = [a for a in _args(modes, out) if a not in ("--kt", "6e8")]
    proc = subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", *args],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert "--kt" in proc.stderr
