"""G-code dialects: ``:`` main blocks and absolute arc centres (G90.1 / ``arc_centres``).

Small programs written for the test; the expected points are worked by hand
(a quarter circle of radius 10 about (20, 0): every chord point at 10 mm
from the centre, the end where the program says).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.job import load_job
from robolobe.plan.paths import read_toolpath
from robolobe.plan.paths.gcode import parse_gcode

# a quarter turn counter-clockwise from (30, 0) to (20, 10) about (20, 0)
QUARTER = np.array([20.0, 0.0])


def _radii(df, lines: tuple[int, ...]) -> np.ndarray:
    pts = df[df["line"].isin(lines)][["x_m", "y_m"]].to_numpy() * 1e3
    return np.hypot(*(pts - QUARTER).T)


def test_colon_main_blocks_are_read_as_blocks() -> None:
    """ISO 6983 main blocks (``:`` in place of ``N``, no number): the rest is a block;
    ``:`` with a number alone is a program number; a bare ``:`` and a comment: nothing."""
    text = "\n".join(
        [
            ": (PGM, NAME=1001)",
            ":1001",
            ": G90 G40 G94",
            "G21",
            ":T1 M6",
            "S12000 M3",
            ":G0 X30 Y0 Z5",
            ":  G1 Z-1 F300",
            ":",
            "G1 X40 Y0",
            "M30",
        ]
    )
    df = parse_gcode(text, "colon.nc")
    assert df["line"].tolist() == [7, 8, 10]
    assert df[["x_m", "y_m", "z_m"]].to_numpy() * 1e3 == pytest.approx(
        np.array([[30, 0, 5], [30, 0, -1], [40, 0, -1]])
    )
    assert df["motion"].tolist() == ["rapid", "cut", "cut"]
    assert df["feed_mm_per_min"].iloc[1] == pytest.approx(300.0)
    assert df["rpm_programmed"].iloc[2] == pytest.approx(12000.0)


def test_colon_with_a_number_and_words_still_needs_a_block() -> None:
    """``:10 G1 X5`` (a numbered main block) reads as ``N10 G1 X5``; O-word control flow
    after a number is still refused."""
    df = parse_gcode("G21 G90\n:10 G0 X5 Y0 Z1\nM30\n", "n.nc")
    assert df["x_m"].iloc[0] * 1e3 == pytest.approx(5.0)
    with pytest.raises(InputError, match=r"o\.nc:2: .*O-word"):
        parse_gcode("G21\nO100 SUB\nM30\n", "o.nc")


ABSOLUTE = "G21 G90 G17\nG0 X30 Y0 Z0\nG3 X20 Y10 I20 J0 F500\nM30\n"
INCREMENTAL = "G21 G90 G17\nG0 X30 Y0 Z0\nG3 X20 Y10 I-10 J0 F500\nM30\n"


def test_g90_1_and_g91_1_select_the_centres_where_the_program_says() -> None:
    df = parse_gcode(ABSOLUTE.replace("G17", "G17 G90.1"), "a.nc", arc_tol_mm=0.001)
    assert _radii(df, (3,)) == pytest.approx(10.0, abs=1e-9)
    assert df[["x_m", "y_m"]].iloc[-1].to_numpy() * 1e3 == pytest.approx([20.0, 10.0])
    # G91.1 in the program wins over the reader option; so does G90.1
    df = parse_gcode(INCREMENTAL.replace("G17", "G17 G91.1"), "i.nc", arc_centres="absolute")
    assert _radii(df, (3,)) == pytest.approx(10.0, abs=1e-6)
    df = parse_gcode(ABSOLUTE.replace("G17", "G17 G90.1"), "a.nc", arc_centres="incremental")
    assert _radii(df, (3,)) == pytest.approx(10.0, abs=1e-6)
    # modal: G91.1 later switches back
    two = ABSOLUTE.replace("G17", "G17 G90.1").replace(
        "M30", "G0 X30 Y0\nG91.1 G3 X20 Y10 I-10 J0\nM30"
    )
    df = parse_gcode(two, "two.nc")
    assert _radii(df, (3, 5)) == pytest.approx(10.0, abs=1e-6)


def test_arc_centres_option_reads_absolute_centres_without_g90_1() -> None:
    df = parse_gcode(ABSOLUTE, "a.nc", arc_centres="absolute", arc_tol_mm=0.001)
    assert _radii(df, (3,)) == pytest.approx(10.0, abs=1e-9)
    assert len(df) > 10  # chords of the quarter turn, not a straight line
    # the default still reads the incremental program as before
    df = parse_gcode(INCREMENTAL, "i.nc")
    assert _radii(df, (3,)) == pytest.approx(10.0, abs=1e-6)


def test_absolute_centres_not_stated_are_refused_naming_the_key() -> None:
    """I20 J0 read as an offset puts the centre at (50, 0): radii 20 and 31.6 to the start
    and end; read absolute, both 10. Refused at the arc's line, naming the job key."""
    with pytest.raises(InputError) as ei:
        parse_gcode(ABSOLUTE, "abs.nc")
    msg = str(ei.value)
    assert msg.startswith("abs.nc:3: ")
    assert '[path] arc_centres = "absolute"' in msg
    assert "G90.1" in msg
    assert "20 and 31.62" in msg
    assert "both are 10 mm" in msg
    # an arc inconsistent both ways is the reader's usual radius error, not this one
    with pytest.raises(InputError) as ei:
        parse_gcode("G21 G90\nG0 X30 Y0 Z0\nG3 X20 Y10 I-3 J0 F500\nM30\n", "bad.nc")
    assert "arc_centres" not in str(ei.value)


def test_bad_arc_centres_value_is_refused() -> None:
    with pytest.raises(InputError, match="arc_centres"):
        parse_gcode(ABSOLUTE, "a.nc", arc_centres="abs")


def test_job_key_reaches_the_reader(tmp_path: Path) -> None:
    from importlib import resources

    ex = resources.files("robolobe.data.examples")
    with resources.as_file(ex.joinpath("job_A_pocket.toml")) as jp:
        text = Path(jp).read_text(encoding="utf-8")
    job_file = tmp_path / "job.toml"
    job_file.write_text(text + '\n[path]\narc_centres = "absolute"\n', encoding="utf-8")
    job = load_job(job_file)
    assert job.path_options["arc_centres"] == "absolute"
    prog = tmp_path / "abs.nc"
    prog.write_text(ABSOLUTE, encoding="utf-8")
    df = read_toolpath(prog, applicable_only=True, **job.path_options)
    assert _radii(df, (3,)) == pytest.approx(10.0, abs=1e-6)
    job_file.write_text(text + '\n[path]\narc_centres = "sometimes"\n', encoding="utf-8")
    with pytest.raises(InputError, match="arc_centres"):
        load_job(job_file)
