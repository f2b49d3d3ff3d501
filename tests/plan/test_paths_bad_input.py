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
