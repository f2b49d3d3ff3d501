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


# A stiff spindle mode (5e7 N/m at 1500 Hz, 0.563 kg) typed in N/mm: 5e4 "N/m",
# 0.563 g, which a modes file alone cannot tell from a 3 mm end mill's bending mode.
STIFF_N_PER_MM = "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,1500,0.02,5e4\nyy,1,1600,0.02,6e4\n"


def _cli(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Run the CLI as a user does (errors as one line, exit codes); (code, output words)."""
    from robolobe.cli.main import main

    try:
        main(args)
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out = capsys.readouterr()
    return code, " ".join((out.out + out.err).split())


def _run_stiff(tmp_path: Path, capsys, text: str, *extra: str) -> tuple[int, str, Path, Path]:
    modes = tmp_path / "modes.csv"
    modes.write_text(text)
    out, png = tmp_path / "lobes.csv", tmp_path / "lobes.png"
    args = _args(modes, out, "--plot", str(png), *extra)
    args[args.index("--rpm") + 1] = "5000:20000:400"
    code, msg = _cli(args, capsys)
    return code, msg, out, png


def test_stiff_modes_in_n_per_mm_refused_by_their_lobes(tmp_path: Path, capsys) -> None:
    code, msg, out, png = _run_stiff(tmp_path, capsys, STIFF_N_PER_MM)
    assert code == 2, msg
    assert f"{tmp_path / 'modes.csv'}:2: k_N_per_m: expected lobes no shallower than 0.01 mm" in msg
    assert "50000 N/m at 1500 Hz" in msg
    assert "N/mm?" in msg
    assert not out.exists()
    assert not png.exists()
    # the same modes in N/m: lobes 1000 times deeper, no word
    code, msg, out, _ = _run_stiff(tmp_path, capsys, STIFF_N_PER_MM.replace("e4\n", "e7\n"))
    assert code == 0, msg
    assert "warning" not in msg
    assert out.exists()


def test_stiff_modes_in_n_per_mm_refused_on_the_tool(tmp_path: Path, capsys) -> None:
    """On a 20 mm tool at 60 mm no mode is lighter than 1/8 of the 16 mm steel bar that
    stands for it: 7850 kg/m^3 * pi * (8 mm)^2 * 60 mm / 8 = 11.8 g (by hand)."""
    code, msg, out, _ = _run_stiff(
        tmp_path, capsys, STIFF_N_PER_MM, "--tool-diameter", "20", "--stickout", "60"
    )
    assert code == 2, msg
    assert f"{tmp_path / 'modes.csv'}:2: k_N_per_m (xx mode 1): expected at least" in msg
    assert "11.8 g" in msg
    assert "In N/m it is 5e+07" in msg
    assert not out.exists()


def test_soft_modes_that_fit_their_tool_are_only_warned(tmp_path: Path, capsys) -> None:
    """The same numbers as a 3 mm end mill at 34 mm (1.74/L^2 kHz: 1.5 kHz; 2.6e4 N/m)."""
    code, msg, out, png = _run_stiff(
        tmp_path, capsys, STIFF_N_PER_MM, "--tool-diameter", "3", "--stickout", "34"
    )
    assert code == 0, msg
    assert "lobes shallower than any practical cut" in msg
    assert out.exists()
    assert png.exists()


def test_borderline_depth_warned_reference_depth_not(tmp_path: Path, modes: Path, capsys) -> None:
    # REFERENCES.md section 3 (48 um minimum): no warning
    code, msg = _cli(_args(modes, tmp_path / "a.csv"), capsys)
    assert code == 0
    assert "warning" not in msg
    # the same mode 0.4 times as stiff: 19 um, between 10 and 30 um: warned, written
    soft = tmp_path / "soft.csv"
    soft.write_text(modes.read_text().replace(repr(K), repr(0.4 * K)))
    code, msg = _cli(_args(soft, tmp_path / "b.csv"), capsys)
    assert code == 0, msg
    assert "shallower than any practical cut" in msg
    assert (tmp_path / "b.csv").exists()


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (("--tool-diameter", "20"), "expected both (mm) or neither, found only --tool-diameter"),
        (("--stickout", "60"), "found only --stickout"),
        (("--tool-diameter", "20", "--stickout", "2"), "--stickout: expected 5 to 1000 mm"),
        (("--tool-diameter", "0", "--stickout", "2"), "--tool-diameter: expected a diameter"),
        (("--tool-diameter", "nan", "--stickout", "2"), "--tool-diameter: expected a diameter"),
    ],
)
def test_tool_size_options_checked(tmp_path: Path, modes: Path, extra, message, capsys) -> None:
    out = tmp_path / "lobes.csv"
    code, msg = _cli(_args(modes, out, *extra), capsys)
    assert code == 2, msg
    assert message in msg
    assert not out.exists()
