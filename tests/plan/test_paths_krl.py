"""KUKA KRL reader: .src with .dat, aggregates, variables, CIRC, speeds."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths import read_toolpath
from robolobe.plan.paths.krl import parse_krl


def test_src_with_dat(data_dir):
    # the fixture is taught the KUKA way: tool x = working direction
    df = read_toolpath(data_dir / "contour.src", tool_direction="x")
    # PTP XHOME (axis target) is left out; the first move is the PTP on line 26
    assert df["line"].iloc[0] == 26
    assert df["motion"].iloc[0] == "rapid"
    # partial aggregate LIN {Z -5} keeps X, Y, A, B, C
    assert df[["x_m", "y_m", "z_m"]].iloc[1].tolist() == pytest.approx([0.0, -0.02, -0.005])
    assert df["feed_mm_per_min"].iloc[1] == pytest.approx(1200.0)  # $VEL.CP = 0.02 m/s
    # A 0, B 90, C 0 with the KUKA convention (tool x = working direction): tool points down
    assert np.allclose(df[["i", "j", "k"]].to_numpy(), [0.0, 0.0, 1.0], atol=1e-12)
    assert np.allclose(df[["ox", "oy", "oz"]].to_numpy(), [0.0, 1.0, 0.0], atol=1e-12)
    # CIRC through (114.142, -14.142) to (120, 0): centre (100, 0), r = 20
    arc = df[df["line"] == 31][["x_m", "y_m"]].to_numpy() * 1e3
    assert np.allclose(np.hypot(arc[:, 0] - 100.0, arc[:, 1]), 20.0, atol=2e-3)
    # LIN XP3 from the .dat; feed from BAS(#CP_PARAMS, 0.04)
    row = df[df["line"] == 37].iloc[0]
    assert [row["x_m"], row["y_m"]] == pytest.approx([0.12, 0.08])
    assert row["feed_mm_per_min"] == pytest.approx(2400.0)
    # LIN_REL {Y 20}
    assert df["y_m"].iloc[-2] == pytest.approx(0.1)
    assert df["z_m"].iloc[-1] == pytest.approx(0.05)


def test_tool_direction_z():
    text = "DEF t()\nLIN {X 0, Y 0, Z 0, A 0, B 0, C 180}\nEND\n"
    x = parse_krl(text, "t.src", tool_direction="x")
    z = parse_krl(text, "t.src")  # default: tool z = working direction
    # C 180 turns the tool z axis down: with tool_direction z the tool axis is +z (up)
    assert z[["i", "j", "k"]].iloc[0].tolist() == pytest.approx([0.0, 0.0, 1.0], abs=1e-12)
    assert x[["i", "j", "k"]].iloc[0].tolist() == pytest.approx([-1.0, 0.0, 0.0], abs=1e-12)


def test_abc_is_zyx_euler():
    a, b, c = 30.0, 20.0, 10.0
    text = f"DEF t()\nLIN {{X 1, Y 2, Z 3, A {a}, B {b}, C {c}}}\nEND\n"
    df = parse_krl(text, "t.src", tool_direction="x")
    ar, br = math.radians(a), math.radians(b)
    # tool x axis = first column of Rz(A) Ry(B) Rx(C)
    x_tool = np.array([math.cos(ar) * math.cos(br), math.sin(ar) * math.cos(br), -math.sin(br)])
    assert df[["i", "j", "k"]].iloc[0].to_numpy() == pytest.approx(-x_tool)


@pytest.mark.parametrize(
    ("body", "what"),
    [
        ("LIN P7", "unknown position variable"),
        ("FOR I=1 TO 3", "control flow"),
        ("LIN {X 1, Y 2, Z 3, A 0, B $POS_ACT.B, C 0}", "expression"),
        ("LIN {X 1, Y 2}", "must give X, Y, Z, A, B, C"),
        ("FOO BAR BAZ", "unsupported KRL statement"),
        ("LIN {A1 0, A2 -90, A3 90, A4 0, A5 0, A6 0}", "axis-specific"),
        ("$VEL.CP = $VEL_MA.CP * 0.5", "expression"),
    ],
)
def test_errors_name_the_line(body, what):
    text = f"DEF t()\n  ; comment\n  {body}\nEND\n"
    with pytest.raises(InputError, match=rf"^t\.src:3: .*{what}"):
        parse_krl(text, "t.src")
