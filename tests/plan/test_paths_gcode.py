"""G-code reader: modal state, arcs, units, 5-axis words, quirks and clear errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths import COLUMNS, read_toolpath
from robolobe.plan.paths.gcode import parse_gcode


def test_fanuc_pocket_fixture(data_dir):
    df = read_toolpath(data_dir / "pocket_fanuc.nc")
    assert tuple(df.columns) == COLUMNS
    # first move: G0 X-5. Y-5. on line 13 (the G28 on line 7 leaves the path)
    assert df["line"].iloc[0] == 13
    assert df[["x_m", "y_m"]].iloc[0].tolist() == pytest.approx([-0.005, -0.005])
    assert (df["motion"].iloc[:2] == "rapid").all()
    # modal feed: N65 F800 then N70 F5400. keeps for the following moves
    assert df.loc[df["line"] == 16, "feed_mm_per_min"].iloc[0] == 800.0
    assert df.loc[df["line"] == 18, "feed_mm_per_min"].iloc[0] == 5400.0
    assert (df["rpm_programmed"].dropna() == 18000.0).all()
    # block delete line 21 (/N90 M0) skipped, lower-case line 24 read
    assert 21 not in set(df["line"])
    assert df.loc[df["line"] == 24, "motion"].iloc[0] == "rapid"
    # arc N80: G3 X35. Y15. I-10. J0. from (45, 5): centre (35, 5), r = 10 mm, counter-clockwise
    arc = df[df["line"] == 19][["x_m", "y_m"]].to_numpy() * 1e3
    r = np.hypot(arc[:, 0] - 35.0, arc[:, 1] - 5.0)
    assert np.allclose(r, 10.0, atol=1e-9)
    ang = np.unwrap(np.arctan2(arc[:, 1] - 5.0, arc[:, 0] - 35.0))
    assert np.all(np.diff(ang) > 0)
    assert ang[-1] == pytest.approx(math.pi / 2)
    # chord error within the default 0.01 mm tolerance
    pts = np.vstack([[45.0, 5.0], arc])
    mid = 0.5 * (pts[1:] + pts[:-1])
    sag = 10.0 - np.hypot(mid[:, 0] - 35.0, mid[:, 1] - 5.0)
    assert sag.max() <= 0.01 + 1e-12
    # R-form arc N85: G2 X25 Y25 R10. from (35, 15): clockwise short arc, centre (35, 25)
    arc2 = df[df["line"] == 20][["x_m", "y_m"]].to_numpy() * 1e3
    assert np.allclose(np.hypot(arc2[:, 0] - 35.0, arc2[:, 1] - 25.0), 10.0, atol=1e-9)
    # feed directions are unit vectors of the moves
    f = df[["fx", "fy", "fz"]].to_numpy()
    assert np.allclose(np.linalg.norm(f, axis=1), 1.0)
    assert df.loc[df["line"] == 17, ["fx", "fy", "fz"]].iloc[0].tolist() == pytest.approx([1, 0, 0])
    assert np.allclose(df[["i", "j", "k"]].to_numpy(), [0, 0, 1])


def test_block_delete_switch_off(data_dir):
    text = "G0 X0 Y0 Z5\n/G1 X10. F100\nG1 Y10.\n"
    on = parse_gcode(text, "a.nc")
    off = parse_gcode(text, "a.nc", block_delete=False)
    assert len(on) == 2
    assert len(off) == 3
    assert off["x_m"].iloc[1] == pytest.approx(0.01)


def test_units_incremental_and_quirks():
    text = "\n".join(
        [
            "%",
            "O0001 (INCH PROGRAM)",
            "N1 G20 G90 G17",
            "N2 G0 X0. Y0. Z.1",
            "N3 G1 X1.0 F10. ; inch per minute",
            "N4 G91 X+.5 Y-0.25",
            "N5 G90 G21 X50 Y0",
            "N6 M30",
            "N7 G1 X999",
        ]
    )
    df = parse_gcode(text, "inch.nc")
    assert len(df) == 4  # stops at M30
    assert df["x_m"].tolist() == pytest.approx([0.0, 0.0254, 0.0381, 0.05])
    assert df["y_m"].iloc[2] == pytest.approx(-0.00635)
    assert df["z_m"].iloc[0] == pytest.approx(0.00254)
    assert df["feed_mm_per_min"].iloc[1] == pytest.approx(254.0)


def test_classic_fanuc_integer_scale():
    df = parse_gcode("G0 X1000 Y2.5\n", "f.nc", no_decimal_scale=0.001)
    assert df[["x_m", "y_m"]].iloc[0].tolist() == pytest.approx([0.001, 0.0025])


def test_full_circle_and_helix():
    text = "G0 X10 Y0 Z0\nG17 G3 X10 Y0 Z-2 I-10 J0 F500\n"
    df = parse_gcode(text, "c.nc", arc_tol_mm=0.001)
    pts = df.iloc[1:][["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), 10.0)
    assert pts[-1] == pytest.approx([10.0, 0.0, -2.0])
    assert np.all(np.diff(pts[:, 2]) < 0)  # helical descent
    ang = np.unwrap(np.arctan2(pts[:, 1], pts[:, 0]))
    assert ang[-1] == pytest.approx(2 * math.pi, abs=1e-9)


def test_g18_plane_arc_sense():
    # ISO 6983: G2/G3 are seen from the positive end of the plane normal (+Y for G18,
    # whose plane runs Z -> X). From (Z10) to (X10) about the origin, counter-clockwise
    # seen from +Y is the quarter turn; G2 is the other way round, 270 deg through -X.
    g2 = parse_gcode("G0 X0 Y0 Z10\nG18 G2 X10 Z0 I0 K-10 F100\n", "g18.nc")
    g3 = parse_gcode("G0 X0 Y0 Z10\nG18 G3 X10 Z0 I0 K-10 F100\n", "g18.nc")
    for df in (g2, g3):
        pts = df.iloc[1:][["x_m", "z_m"]].to_numpy() * 1e3
        assert np.allclose(np.hypot(pts[:, 0], pts[:, 1]), 10.0)
    assert g3["x_m"].min() >= -1e-12
    assert g2["x_m"].min() * 1e3 == pytest.approx(-10.0, abs=0.01)
    assert len(g2) > 2 * len(g3)


def test_five_axis_tool_vectors_and_rotary_words(data_dir):
    df = read_toolpath(data_dir / "face_5axis_ijk.nc")
    ax = df[["i", "j", "k"]].to_numpy()
    assert np.allclose(np.linalg.norm(ax, axis=1), 1.0)
    assert ax[2] == pytest.approx([0.0, 0.2588, 0.9659], abs=1e-4)
    assert ax[-1] == pytest.approx(ax[-2])  # modal tool vector
    # without TCP control, A/B/C words are ambiguous (head or table): refused by default
    with pytest.raises(InputError, match="rotary_axes"):
        read_toolpath(data_dir / "head_abc.nc")
    abc = read_toolpath(data_dir / "head_abc.nc", rotary_axes="head")
    # documented convention: axis = Rz(C) Ry(B) Rx(A) ez
    assert abc[["i", "j", "k"]].iloc[2].tolist() == pytest.approx([0.5, 0.0, math.sqrt(3) / 2])
    assert abc[["i", "j", "k"]].iloc[3].tolist() == pytest.approx(
        [0.0, 0.5, math.sqrt(3) / 2], abs=1e-12
    )


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        ("G0 X0\nG41 D1 G1 X10\n", 2, "G41"),
        ("G0 X0\n#100=5\n", 2, "macro"),
        ("G0 X0\nG81 X1 Y1 Z-5 R1\n", 2, "canned cycle"),
        ("G0 X0\nIF [#1 GT 0] GOTO 10\n", 2, "unsupported"),
        ("G0 X0\nM98 P1000\n", 2, "subprogram"),
        ("G0 X0 (open comment\n", 1, "comment"),
        ("G0 X0\nG1 X5 X6\n", 2, "twice"),
        ("G0 X0\nG1 X1 Q&\n", 2, "address words"),
        ("X5 Y5\n", 1, "motion mode"),
        ("G0 X0 Y0\nG2 X10 Y0 R2\n", 2, "too small"),
        ("G0 X0 Y0\nG2 X10 Y0 I3 J0\n", 2, "not on the circle"),
        ("G0 X0\nG93 G1 X5 F2\n", 2, "inverse-time"),
        ("BEGIN PGM 1 MM\n", 1, "Heidenhain"),
        ("G0 X0\nG1 U5\n", 2, "U"),
        ("G0 X0\nG1 X5 A10 I0 J0 K1\n", 2, "A/B/C"),
    ],
)
def test_unsupported_and_malformed_are_errors_with_file_and_line(text, line, what):
    with pytest.raises(InputError) as ei:
        parse_gcode(text, "prog.nc")
    msg = str(ei.value)
    assert msg.startswith(f"prog.nc:{line}:")
    assert what.lower() in msg.lower()


def test_empty_program_is_an_error():
    with pytest.raises(InputError, match="at least one move"):
        parse_gcode("%\n(ONLY A COMMENT)\nM30\n", "empty.nc")
