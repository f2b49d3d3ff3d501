"""ABB RAPID reader: robtargets, Offs, speeddata, MoveC, statements over lines."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths import read_toolpath
from robolobe.plan.paths.rapid import parse_rapid, quaternion_to_rotation


def test_face_module(data_dir):
    df = read_toolpath(data_dir / "face.mod")
    assert df["line"].iloc[0] == 18  # MoveAbsJ on line 17 is a joint target: left out
    assert df["motion"].iloc[0] == "rapid"
    assert df["feed_mm_per_min"].iloc[1] == pytest.approx(20 * 60.0)  # v20
    assert df["feed_mm_per_min"].iloc[2] == pytest.approx(40 * 60.0)  # vCut = [40, ...]
    # Offs(p20, 0, 40, 0)
    assert df[["x_m", "y_m", "z_m"]].iloc[3].tolist() == pytest.approx([0.2, 0.04, -0.002])
    # statement over three lines with \V:=50 overriding v40
    row = df[df["line"] == 22].iloc[0]
    assert row["feed_mm_per_min"] == pytest.approx(50 * 60.0)
    # quaternion [0, 0, 1, 0] (180 deg about y): tool z points down, tool axis up
    assert np.allclose(df[["i", "j", "k"]].to_numpy(), [0, 0, 1], atol=1e-12)
    assert np.allclose(df[["ox", "oy", "oz"]].to_numpy(), [-1, 0, 0], atol=1e-12)
    # MoveC through (-20, 60) to (0, 80) from (0, 40): centre (0, 60), r = 20
    arc = df[df["line"] == 25][["x_m", "y_m"]].to_numpy() * 1e3
    assert np.allclose(np.hypot(arc[:, 0], arc[:, 1] - 60.0), 20.0, atol=1e-6)
    assert arc[:, 0].min() == pytest.approx(-20.0, abs=0.05)
    assert df["motion"].iloc[-1] == "rapid"  # MoveJ with vmax


def test_quaternion_rotation_is_scalar_first():
    r = quaternion_to_rotation(np.array([np.cos(np.pi / 8), 0.0, 0.0, np.sin(np.pi / 8)]))
    c = np.cos(np.pi / 4)
    assert r == pytest.approx(np.array([[c, -c, 0], [c, c, 0], [0, 0, 1]]))


@pytest.mark.parametrize(
    ("body", "line", "what"),
    [
        ("MoveL RelTool(p1, 0, 0, 10), v100, z1, tool0;", 4, "RelTool"),
        ("IF x > 1 THEN", 4, "control flow"),
        ("MoveL pNope, v100, z1, tool0;", 4, "unknown robtarget"),
        (
            "MoveL [[1,2,3],[1,1,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z1, tool0;",
            4,
            "normalised",
        ),
        ("MoveL p1, v100, z1, tool0", 4, "not terminated"),
    ],
)
def test_errors(body, line, what):
    text = (
        "MODULE M\n"
        "  CONST robtarget p1:=[[0,0,0],[1,0,0,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\n"
        "  PROC main()\n"
        f"    {body}\n"
        "  ENDPROC\n"
        "ENDMODULE\n"
    )
    with pytest.raises(InputError, match=rf"^m\.mod:{line}: .*{what}"):
        parse_rapid(text, "m.mod")
