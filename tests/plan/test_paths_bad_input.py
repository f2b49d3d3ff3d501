"""Bad input for every toolpath reader: a clear ``file:line`` error or a correct read.

Never a traceback: empty, binary, BOM, mixed line endings, cut anywhere,
absurd numbers, non-positive feeds, negative spindle speeds.
"""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths import read_toolpath

GOOD = {
    ".nc": "%\nO1000\nG21 G90\nS10000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F600\nX10\nG2 X20 Y0 I5 J0\nM30\n%\n",
    ".cls": "UNITS/MM\nFEDRAT/MMPM,600\nRAPID\nGOTO/0,0,5\nGOTO/0,0,-1\nGOTO/10,0,-1\nFINI\n",
    ".src": "DEF t()\n$VEL.CP = 0.01\nPTP {X 0, Y 0, Z 5, A 0, B 0, C 180}\nLIN {Z -1}\n"
    "LIN {X 10}\nEND\n",
    ".mod": "MODULE M\nPROC main()\nMoveJ [[0,0,5],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],"
    "v100,z1,tool0;\nMoveL [[0,0,-1],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],v10,fine,"
    "tool0;\nMoveL [[10,0,-1],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],v10,fine,tool0;\n"
    "ENDPROC\nENDMODULE\n",
}
EXTS = sorted(GOOD)


def write(tmp_path: Path, ext: str, data: bytes | str) -> Path:
    p = tmp_path / f"prog{ext}"
    p.write_bytes(data.encode("utf-8") if isinstance(data, str) else data)
    return p


def cut_xyz(df) -> np.ndarray:
    return df[["x_m", "y_m", "z_m"]].to_numpy() * 1e3


@pytest.mark.parametrize("ext", EXTS)
def test_reference_programs_read(tmp_path, ext):
    df = read_toolpath(write(tmp_path, ext, GOOD[ext]))
    assert cut_xyz(df)[-1] == pytest.approx([20.0 if ext == ".nc" else 10.0, 0.0, -1.0])
    assert not any("truncated" in w for w in df.attrs["warnings"])


@pytest.mark.parametrize("ext", EXTS)
@pytest.mark.parametrize("data", [b"", b"   \n\n \r\n"])
def test_empty_file(tmp_path, ext, data):
    with pytest.raises(InputError, match=r"^prog\.\w+: .*empty"):
        read_toolpath(write(tmp_path, ext, data))


@pytest.mark.parametrize("ext", EXTS)
def test_binary_file(tmp_path, ext):
    rng = random.Random(3)
    data = bytes(rng.randrange(256) for _ in range(4000))
    with pytest.raises(InputError, match="binary"):
        read_toolpath(write(tmp_path, ext, data))


@pytest.mark.parametrize("ext", EXTS)
def test_bom_and_mixed_line_endings_read_the_same(tmp_path, ext):
    ref = read_toolpath(write(tmp_path, ext, GOOD[ext]))
    lines = GOOD[ext].split("\n")
    mixed = "".join(line + ("\r\n", "\n", "\r")[k % 3] for k, line in enumerate(lines[:-1]))
    df = read_toolpath(write(tmp_path, ext, b"\xef\xbb\xbf" + mixed.encode() + b"\x1a"))
    assert cut_xyz(df) == pytest.approx(cut_xyz(ref))
    assert df["line"].tolist() == ref["line"].tolist()  # same line numbers


@pytest.mark.parametrize(
    ("ext", "cut_at", "what"),
    [
        (".nc", "M30", "M30"),
        (".cls", "FINI", "FINI"),
        (".src", "END\n", "no END"),
        (".mod", "ENDPROC", "no ENDPROC"),
    ],
)
def test_truncated_file_is_warned(tmp_path, ext, cut_at, what):
    text = GOOD[ext]
    text = text[: text.rindex(cut_at)]
    df = read_toolpath(write(tmp_path, ext, text))
    assert any(what in w and "truncated" in w for w in df.attrs["warnings"])


@pytest.mark.slow
@pytest.mark.parametrize("ext", EXTS)
def test_cut_anywhere_never_tracebacks(tmp_path, ext):
    data = GOOD[ext].encode()
    unnamed = []
    for k in range(1, len(data)):
        p = write(tmp_path, ext, data[:k])
        try:
            read_toolpath(p)
        except InputError as exc:
            if not str(exc).startswith("prog"):
                unnamed.append(str(exc))
    assert unnamed == []


@pytest.mark.parametrize(
    ("ext", "text", "line", "what"),
    [
        (".nc", "G0 X0\nG1 X10 F-5400\n", 2, "positive feed"),
        (".nc", "G0 X0\nG1 X10 F0\n", 2, "positive feed"),
        (".nc", "G0 X0\nS-18000 M3\n", 2, "S >= 0"),
        (".nc", "G0 X0\nS0 M3\nG0 X5\nG1 X10 F100\n", 4, "found S0 (line 2)"),
        (".nc", "S18000 M3\nG0 X0\nG1 X5 F100 S0\n", 3, "found S0 (line 3)"),
        (".nc", "S0 M3\nG0 X0 Y0\nG2 X1 Y0 I0.5 J0 F100\n", 3, "S > 0 on a feed move"),
        (".nc", "G0 X0\nG1 X1E300\n", 2, "word E"),
        (".nc", "G0 X0\nG1 X99999999999 F100\n", 2, "magnitude"),
        (".nc", "G0 X0 Y0\nG2 X1 Y0 I0.5 J0 F100\nG2 X2 Y0 I0.3 F100\n", 3, "circle"),
        (".cls", "GOTO/0,0,0\nFEDRAT/-5\n", 2, "positive feed"),
        (".cls", "GOTO/0,0,0\nFEDRAT/0,MMPM\n", 2, "positive feed"),
        (".cls", "GOTO/0,0,0\nSPINDL/RPM,-18000\n", 2, "speed >= 0"),
        (".cls", "GOTO/nan,0,0\n", 1, "finite"),
        (".cls", "GOTO/1E300,0,0\n", 1, "finite"),
        (".cls", "GOTO/0,0,0\nCIRCLE/inf,0,0,0,0,1,5\n", 2, "finite"),
        (".src", "DEF t()\nLIN {X 1E300, Y 0, Z 0, A 0, B 0, C 0}\n"
         "CIRC {X 1, Y 1, Z 0}, {X 2, Y 0, Z 0}\nEND\n", 2, "finite"),
        (".src", "DEF t()\n$VEL.CP = -0.2\nEND\n", 2, "velocity"),
        (".src", "DEF t()\n$VEL.CP = 0\nEND\n", 2, "velocity"),
        (".src", "DEF t()\nBAS(#VEL_CP, -1)\nEND\n", 2, "velocity"),
        (".src", "DEF t()\nLIN {X nan, Y 0, Z 0, A 0, B 0, C 0}\nEND\n", 2, "finite"),
        (".mod", "MODULE M\nPROC main()\nMoveL [[1E300,0,0],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]],"
         "v10,fine,tool0;\nENDPROC\nENDMODULE\n", 3, "finite"),
        (".mod", "MODULE M\nPROC main()\nMoveL [[0,0,0],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]],"
         "v10\\V:=-5,fine,tool0;\nENDPROC\nENDMODULE\n", 3, "positive"),
        (".mod", "MODULE M\nPROC main()\nMoveL [[0,0,0],[1,0,0,0],[0,0,0,0],[0,0,0,0,0,0]]", 3,
         "not terminated"),
    ],
)  # fmt: skip
def test_absurd_numbers_feeds_and_speeds_refused(tmp_path, ext, text, line, what):
    with pytest.raises(InputError) as ei:
        read_toolpath(write(tmp_path, ext, text))
    assert str(ei.value).startswith(f"prog{ext}:{line}:"), str(ei.value)
    assert what.lower() in str(ei.value).lower()


def test_table_reader_bom_binary_and_empty(tmp_path):
    p = tmp_path / "t.csv"
    p.write_bytes(b"\xef\xbb\xbfx_m,y_m,z_m\r\n0,0,0\n0.01,0,0\r0.02,0,0\n")
    df = read_toolpath(p)
    assert df["x_m"].tolist() == pytest.approx([0.0, 0.01, 0.02])
    for data in (b"", b"\x00\x01\x02\xff" * 100):
        p.write_bytes(data)
        with pytest.raises(InputError, match=r"^t\.csv"):
            read_toolpath(p)


def test_a_million_lines_within_limits(tmp_path):
    """The reader's per-line work is small enough for a 1e6-line file (timed in benchmarks/)."""
    block = "".join(f"G1 X{k % 50}.5 Y{(k * 7) % 30}.25\n" for k in range(1000))
    p = write(tmp_path, ".nc", "G21 G90\nG0 X0 Y0 Z0\nF1000\n" + block * 20 + "M30\n")
    df = read_toolpath(p)
    assert len(df) == 20001


def test_spindle_speed_zero_is_refused_only_where_the_program_feeds(tmp_path):
    # S0 with rapids only (or with the spindle off) is read: NaN, none programmed
    wp = read_toolpath(write(tmp_path, ".nc", "G21 S0 M3\nG0 X0 Y0 Z5\nG0 X10\nM5\nG1 X20 F100\n"))
    assert np.isnan(wp["rpm_programmed"]).all()
    # a speed given again before the feed moves: they cut at it
    wp = read_toolpath(write(tmp_path, ".nc", "G21 S0 M3\nG0 X0 Z5\nS12000\nG1 X20 F100\n"))
    assert wp["rpm_programmed"].iloc[-1] == 12000.0


@pytest.mark.parametrize(
    ("text", "line", "found"),
    [
        ("UNITS/MM\nSPINDL/RPM,0,CLW\nRAPID\nGOTO/0,0,5\nFEDRAT/100\nGOTO/0,0,-1\n", 6,
         "found SPINDL/RPM,0,CLW (line 2)"),
        ("UNITS/MM\nSPINDL/0\nGOTO/0,0,5\n", 3, "found SPINDL/0 (line 2)"),
        # a speed, then 0: the feed move after the 0 is refused, the one before is read
        ("UNITS/MM\nFEDRAT/100\nSPINDL/12000,CLW\nGOTO/0,0,5\nSPINDL/0,CLW\nGOTO/1,0,5\n", 6,
         "found SPINDL/0,CLW (line 5)"),
        # OFF then ON again: still at 0 rpm
        ("UNITS/MM\nSPINDL/RPM,0\nSPINDL/OFF\nSPINDL/ON\nGOTO/0,0,5\n", 5, "(line 2)"),
        # an arc too
        ("UNITS/MM\nSPINDL/0\nRAPID\nGOTO/5,0,0\nFEDRAT/100\nCIRCLE/0,0,0,0,0,1,5\n"
         "GOTO/-5,0,0\n", 7, "(line 2)"),
    ],
)  # fmt: skip
def test_apt_feed_move_at_zero_spindle_speed_is_refused(tmp_path, text, line, found):
    with pytest.raises(InputError) as ei:
        read_toolpath(write(tmp_path, ".cls", text))
    msg = str(ei.value)
    assert msg.startswith(f"prog.cls:{line}: expected a spindle speed > 0 rpm on a feed move"), msg
    assert found in msg


def test_apt_zero_spindle_speed_over_rapids_or_with_the_spindle_off_is_read(tmp_path):
    wp = read_toolpath(
        write(tmp_path, ".cls", "UNITS/MM\nSPINDL/0\nRAPID\nGOTO/0,0,5\nSPINDL/OFF\n"
              "FEDRAT/100\nGOTO/10,0,5\nFINI\n")
    )  # fmt: skip
    assert np.isnan(wp["rpm_programmed"]).all()
    assert len(wp) == 2
    # a speed given again before the feed moves: they cut at it
    wp = read_toolpath(
        write(tmp_path, ".cls", "UNITS/MM\nSPINDL/0\nRAPID\nGOTO/0,0,5\nSPINDL/9000,CLW\n"
              "FEDRAT/100\nGOTO/10,0,5\nFINI\n")
    )  # fmt: skip
    assert wp["rpm_programmed"].tolist()[-1] == 9000.0


KRL_ZERO = (
    "DEF t()\n$VEL.CP = 0.01\n$ANOUT[2] = 0.5\nPTP {X 0, Y 0, Z 5, A 0, B 0, C 180}\n"
    "LIN {Z -1}\nLIN {X 10}\n$ANOUT[2] = 0\nLIN {Z 20}\nLIN {Z 30}\nPTP {Z 50}\nEND\n"
)
RAPID_POSE = "[[{x},0,{z}],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def _rapid_zero(off: str) -> str:
    return (
        "MODULE M\nPROC main()\nSetAO aoS, 0.5;\n"
        f"MoveJ {RAPID_POSE.format(x=0, z=5)},v100,z1,tool0;\n"
        f"MoveL {RAPID_POSE.format(x=10, z=-1)},v10,fine,tool0;\n"
        f"{off}\n"
        f"MoveL {RAPID_POSE.format(x=10, z=20)},v10,fine,tool0;\n"
        f"MoveL {RAPID_POSE.format(x=10, z=30)},v10,fine,{'tg1, ' if 'Trigg' in off else ''}"
        "tool0;\n"
        f"MoveJ {RAPID_POSE.format(x=10, z=50)},v100,z1,tool0;\nENDPROC\nENDMODULE\n"
    )


@pytest.mark.parametrize(
    ("ext", "text", "opts", "zero"),
    [
        (".src", KRL_ZERO, {"spindle_output": "2", "spindle_rpm_per_unit": 24000.0},
         "$ANOUT[2] = 0, line 7"),
        (".mod", _rapid_zero("SetAO aoS, 0;"),
         {"spindle_output": "aoS", "spindle_rpm_per_unit": 24000.0}, "SetAO aoS, 0, line 6"),
    ],
)  # fmt: skip
def test_robot_program_zero_spindle_output_reads_as_off_and_warns_its_feed_moves(
    tmp_path, ext, text, opts, zero
):
    """On a robot the analog output is the spindle's switch: 0 is off (M5), not "S0 on"."""
    wp = read_toolpath(write(tmp_path, ext, text), **opts)
    rpm = wp["rpm_programmed"].to_numpy()
    zero_line = int(zero.rsplit(" ", 1)[1])
    before = wp["line"].to_numpy() < zero_line
    assert rpm[before] == pytest.approx([12000.0] * int(before.sum()))
    assert np.isnan(rpm[~before]).all()
    assert wp["motion"][~before].tolist() == ["cut", "cut", "rapid"]
    warned = [w for w in wp.attrs["warnings"] if "spindle output at 0" in w]
    assert len(warned) == 1, wp.attrs["warnings"]
    assert zero in warned[0]
    assert warned[0].endswith("(2 times)")  # the two feed moves, not the PTP/MoveJ
    # without a zero, no such warning
    ok = read_toolpath(write(tmp_path, ext, GOOD[ext]), **opts)
    assert not any("spindle output at 0" in w for w in ok.attrs["warnings"])


def test_rapid_triggio_to_zero_warns_the_move_that_uses_it(tmp_path):
    text = _rapid_zero("TriggIO tg1, 0\\Start\\AOp:=aoS, 0;")
    wp = read_toolpath(
        write(tmp_path, ".mod", text), spindle_output="aoS", spindle_rpm_per_unit=24000.0
    )
    rpm = wp["rpm_programmed"].to_numpy()
    assert rpm[2] == 12000.0  # MoveL to z=20 still at speed: the trigger acts on the move using it
    assert np.isnan(rpm[3])
    warned = [w for w in wp.attrs["warnings"] if "spindle output at 0" in w]
    assert len(warned) == 1, warned
    assert "TriggIO tg1 to aoS = 0, line 6" in warned[0]
    assert warned[0].startswith("prog.mod:8:")
