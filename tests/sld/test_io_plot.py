"""Modes file reader, lobes writer, plots."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.sld import (
    CuttingConditions,
    Material,
    ModalModel,
    plot_lobes,
    save_lobe_plot,
    stability_lobes,
)
from robolobe.sld.io import read_modes_csv, write_lobes_csv

from .sld_reference import F_N, K_MODAL, KR, KT, ZETA


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "modes.csv"
    p.write_text(text)
    return p


def test_read_modes(tmp_path: Path) -> None:
    p = _write(
        tmp_path,
        "# comment\ndir,mode,f_hz,zeta,k_N_per_m,note\n"
        f"xx,1,{F_N},{ZETA},{K_MODAL},a\n\nyy,1,{F_N},{ZETA},{K_MODAL},b\nxy,1,950,0.02,-5e7,c\n",
    )
    m = read_modes_csv(p)
    assert m.n_modes == 3
    assert m.dim == 2
    w = np.array([2 * math.pi * 900.0])
    want = ModalModel.from_directional(
        [F_N, F_N, 950.0], [ZETA, ZETA, 0.02], [K_MODAL, K_MODAL, -5e7], ["xx", "yy", "xy"]
    ).frf(w)
    np.testing.assert_allclose(m.frf(w), want)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("dir,mode,f_hz,zeta\nxx,1,900,0.01\n", "missing k_N_per_m"),
        ("dir,mode,f_hz,zeta,k_N_per_m\nzz,1,900,0.01,1e6\n", r"modes.csv:2: dir"),
        (
            "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,0.01,1e6\nxx,0,900,0.01,1e6\n",
            r"modes.csv:3: mode",
        ),
        ("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,abc,0.01,1e6\n", r":2: f_hz: expected a number"),
        ("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,1.5,1e6\n", r":2: zeta"),
        ("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,0.01,-1e6\n", r":2: k_N_per_m"),
        (
            "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,0.01,1e6\nxx,1,950,0.01,1e6\n",
            r":3: duplicate.*line 2",
        ),
        (
            "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,0.01,1e6\nxy,1,9,0.01,1e6\nyx,1,9,0.01,1e6\n",
            r":4: duplicate cross term",
        ),
        ("dir,mode,f_hz,zeta,k_N_per_m\nxy,1,900,0.01,1e6\n", "at least one xx or yy"),
        ("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900\n", r":2: expected 5 columns"),
        ("", "empty file"),
        # plausibility: a file cut mid-number, kHz for Hz, k = 1e-300
        ("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,0.01,2.\n", r":2: k_N_per_m: .*found 2 "),
        ("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,0.9,0.01,1e6\n", r":2: f_hz: .*kHz\?"),
        ("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,0.01,1e-300\n", r":2: k_N_per_m"),
    ],
)
def test_read_modes_errors(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(InputError, match=match):
        read_modes_csv(_write(tmp_path, text))


def test_missing_modes_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such file"):
        read_modes_csv(tmp_path / "nope.csv")


@pytest.fixture(scope="module")
def lobes(iso_2dof: ModalModel):
    return stability_lobes(
        iso_2dof,
        cutter=2,
        material=Material("m", KT, KR),
        conditions=CuttingConditions.from_immersion(0.5, "down"),
        rpm=np.linspace(6000, 60000, 300),
    )


def test_write_lobes_csv(tmp_path: Path, lobes) -> None:
    out = tmp_path / "sub" / "lobes.csv"
    write_lobes_csv(out, lobes)
    lines = out.read_text().splitlines()
    assert lines[0] == "rpm,a_lim_mm"
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    np.testing.assert_allclose(data[:, 0], lobes.rpm)
    np.testing.assert_allclose(data[:, 1], lobes.a_lim * 1e3, rtol=1e-8)
    assert not list(out.parent.glob("*.tmp"))


def test_plot_lobes(tmp_path: Path, lobes) -> None:
    fig = plot_lobes(
        lobes,
        operating_points=([20000.0, 40000.0], [1e-5, 1e-2]),
        safety_factor=1.3,
        show_lobes=True,
        title="t",
    )
    ax = fig.axes[0]
    assert ax.get_xlabel().startswith("spindle speed")
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "stable point" in labels
    assert "unstable point" in labels
    assert "a_lim / 1.3" in labels
    out = tmp_path / "lobes.png"
    save_lobe_plot(lobes, out, safety_factor=1.2)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(InputError, match="safety_factor"):
        plot_lobes(lobes, safety_factor=0.5)
