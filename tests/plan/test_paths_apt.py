"""APT/CL reader on a CATIA-like file and small snippets."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths import read_toolpath
from robolobe.plan.paths.apt import parse_apt


def test_catia_fixture(data_dir):
    # the fixture's arcs run counter-clockwise about their axis: the NX sense
    # forced on them warns; the default (auto) reads them ccw from tangency
    nx = read_toolpath(data_dir / "contour_catia_ok.apt", circle_axis="cw")
    assert any("circle_axis = 'ccw'" in w for w in nx.attrs["warnings"])
    df = read_toolpath(data_dir / "contour_catia_ok.apt", circle_axis="ccw")
    assert not any("circle_axis" in w for w in df.attrs["warnings"])
    auto = read_toolpath(data_dir / "contour_catia_ok.apt")
    assert auto.attrs["warnings"] == df.attrs["warnings"]
    np.testing.assert_array_equal(auto[["x_m", "y_m", "z_m"]], df[["x_m", "y_m", "z_m"]])
    # RAPID applies to the next GOTO only
    assert df["motion"].tolist()[:3] == ["rapid", "rapid", "cut"]
    assert df["rpm_programmed"].iloc[0] == 12000.0
    assert df["rpm_programmed"].iloc[-1] == 12000.0  # SPINDL/OFF comes after the last move
    assert df["feed_mm_per_min"].iloc[2] == 1000.0
    assert df["feed_mm_per_min"].iloc[3] == 2400.0
    # CIRCLE/100,0,-5, 0,0,1, 20 then GOTO/120,0,-5: a quarter arc about +z
    arc = df[df["line"] == 33][["x_m", "y_m"]].to_numpy() * 1e3
    assert np.allclose(np.hypot(arc[:, 0] - 100.0, arc[:, 1]), 20.0, atol=1e-9)
    assert arc[-1] == pytest.approx([120.0, 0.0])
    assert np.all(arc[:, 1] <= 1e-9)  # counter-clockwise from (100,-20): through y < 0
    # continuation line CUTTER/...$ and comment lines did not upset line numbers
    assert df["line"].iloc[0] == 25


def test_unsupported_surface_motion_names_the_line(data_dir):
    with pytest.raises(InputError, match=r"contour_catia\.apt:31: .*INDIRV"):
        read_toolpath(data_dir / "contour_catia.apt")


def test_units_msys_godlta_and_feed_forms():
    text = "\n".join(
        [
            "UNITS/INCHES",
            "MSYS/1.0,2.0,0.0, 0.0,1.0,0.0, -1.0,0.0,0.0",
            "FEDRAT/IPM,20",
            "SPINDL/RPM,8000,CLW",
            "FROM/0,0,1",
            "GOTO/1,0,0,$",
            "  0,0,1",
            "GODLTA/0.5",
            "TLAXIS/0,1,1",
            "GOTO/1,1,0",
            "FINI",
        ]
    )
    df = parse_apt(text, "in.cls", coordinates="machine")
    # MSYS: x' = y, y' = -x; origin (1, 2, 0) inch
    p = df[["x_m", "y_m", "z_m"]].to_numpy() / 0.0254
    assert p[0] == pytest.approx([1.0, 2.0, 1.0])
    assert p[1] == pytest.approx([1.0, 3.0, 0.0])  # (1,0,0) -> (0,1,0) + origin
    assert p[2] == pytest.approx([1.0, 3.0, 0.5])  # GODLTA along the tool axis
    assert df["motion"].iloc[0] == "rapid"
    assert df["feed_mm_per_min"].iloc[1] == pytest.approx(20 * 25.4)
    ax = df[["i", "j", "k"]].to_numpy()
    assert ax[-1] == pytest.approx(np.array([-1.0, 0.0, 1.0]) / np.sqrt(2))  # TLAXIS through MSYS
    assert df["line"].iloc[1] == 6


@pytest.mark.parametrize(
    ("text", "what"),
    [
        ("GOTO/1,2\n", "x,y,z"),
        ("GOTO/1,2,a\n", "number"),
        ("CUTCOM/LEFT\n", "CUTCOM"),
        ("CYCLE/DRILL,5\n", "CYCLE"),
        ("WIBBLE/1\n", "WIBBLE"),
        ("UNITS/FURLONG\n", "UNITS"),
        ("CALSUB/3\n", "CALSUB"),
    ],
)
def test_errors(text, what):
    with pytest.raises(InputError, match=rf"^x\.apt:1: .*{what}"):
        parse_apt(text, "x.apt")


def test_circle_sense_that_cannot_be_checked_is_said(tmp_path):
    # the only arc follows a plunge: no lateral move to check tangency against
    f = tmp_path / "plunge_arc.apt"
    f.write_text(
        "UNITS/MM\nFEDRAT/MMPM,1000\nGOTO/0,-20,5\nGOTO/0,-20,-5\n"
        "CIRCLE/0,0,-5,0,0,1,20\nGOTO/20,0,-5\nFINI\n"
    )
    df = read_toolpath(f)
    assert any("could not be checked" in w and "taken as cw" in w for w in df.attrs["warnings"])
    cw = read_toolpath(f, circle_axis="cw")
    np.testing.assert_array_equal(df[["x_m", "y_m"]], cw[["x_m", "y_m"]])
