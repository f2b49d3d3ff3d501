"""G41/G42 cutter radius compensation against offsets worked out by hand for each program."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths.gcode import parse_gcode

# a 40 x 30 rectangle with an R20 arc at one corner, run counter-clockwise
CONTOUR = """G21 G90 G17
G0 X-20 Y-20 Z5
G1 Z-2 F300
{on} X0 Y0 D1 F600
X40
Y30
G3 X20 Y50 I-20 J0
G1 X0
Y0
G40 X-20 Y-20
M30
"""


def _xy(df):
    return df[["x_m", "y_m"]].to_numpy() * 1e3


def test_g41_inside_of_a_ccw_contour():
    df = parse_gcode(CONTOUR.format(on="G41"), "c.nc", cutter_radius_mm=5.0)
    p = _xy(df)
    line = df["line"].to_numpy()
    by_line = {ln: p[line == ln] for ln in set(line.tolist())}
    # entry: to the first element's start offset perpendicular to it (left of +x: +y)
    assert by_line[4][-1] == pytest.approx([0.0, 5.0])
    # inside corners end at the intersection of the offset elements
    assert by_line[5][-1] == pytest.approx([35.0, 5.0])
    assert by_line[6][-1] == pytest.approx([35.0, 30.0])
    # the arc's radius shrinks by the cutter radius about the same centre
    arc = by_line[7]
    assert np.hypot(arc[:, 0] - 20, arc[:, 1] - 30) == pytest.approx(np.full(len(arc), 15.0))
    assert arc[-1] == pytest.approx([20.0, 45.0])
    assert by_line[8][-1] == pytest.approx([5.0, 45.0])
    assert by_line[9][-1] == pytest.approx([5.0, 0.0])  # perpendicular to the last element
    assert by_line[10][-1] == pytest.approx([-20.0, -20.0])  # exit: uncompensated
    assert (df["motion"] == "cut").sum() == len(df) - 1
    assert np.all(df["z_m"].to_numpy()[1:] * 1e3 == pytest.approx(-2.0))


def test_g42_outside_goes_around_the_corners():
    df = parse_gcode(CONTOUR.format(on="G42"), "c.nc", cutter_radius_mm=5.0)
    p = _xy(df)
    line = df["line"].to_numpy()
    # right of +x is -y; the corner at (40, 0) is outside: an arc of radius 5 about it
    seg5 = p[line == 5]
    assert seg5[0] == pytest.approx([40.0, -5.0])
    corner = seg5[1:]
    assert np.hypot(corner[:, 0] - 40, corner[:, 1]) == pytest.approx(np.full(len(corner), 5.0))
    assert corner[-1] == pytest.approx([45.0, 0.0])
    # the arc grows by the cutter radius
    arc = p[line == 7]
    assert np.hypot(arc[:, 0] - 20, arc[:, 1] - 30)[:-1] == pytest.approx(25.0, abs=1e-9)


def test_compensation_refusals():
    with pytest.raises(InputError, match=r"c\.nc:4.*\[path\] cutter_radius_mm"):
        parse_gcode(CONTOUR.format(on="G41"), "c.nc")
    with pytest.raises(InputError, match="does not fit the arc"):
        parse_gcode(CONTOUR.format(on="G41"), "c.nc", cutter_radius_mm=21.0)
    text = "G21 G90 G17\nG0 X-5 Y-5\nG41 G1 X0 Y0 F100\nX40\nY2\nX0\nG40 X-5 Y-5\nM30\n"
    with pytest.raises(InputError, match="does not fit the inside corner"):
        parse_gcode(text, "n.nc", cutter_radius_mm=5.0)
    with pytest.raises(InputError, match="G18"):
        parse_gcode("G18 G0 X0 Y0\nG41 G1 X5\n", "p.nc", cutter_radius_mm=1.0)


def test_zero_radius_is_the_programmed_contour():
    comp = parse_gcode(CONTOUR.format(on="G41"), "c.nc", cutter_radius_mm=0.0)
    plain = parse_gcode(CONTOUR.format(on=""), "c.nc")
    np.testing.assert_allclose(_xy(comp), _xy(plain), atol=1e-9)


def test_written_program_keeps_compensation(tmp_path):
    """The writer changes only S/F words: the compensated path reads back the same."""
    from robolobe.plan.paths._edit import ProgramEdit
    from robolobe.plan.paths.gcode import write_gcode

    text = CONTOUR.format(on="G41").replace("G21", "G21 S9000 M3")
    wp = parse_gcode(text, "c.nc", cutter_radius_mm=5.0)
    n = len(wp)
    cut = (wp["motion"] == "cut").to_numpy()
    edit = ProgramEdit(
        waypoints=wp,
        rpm=np.where(cut, 10000.0, np.nan),
        feed_mm_per_min=np.where(cut, 700.0, np.nan),
        margin=np.full(n, math.nan),
        passes=np.ones(n, np.int64),
        depth_mm=np.full(n, math.nan),
    )
    back = parse_gcode(write_gcode(text, "c.nc", edit), "c.nc", cutter_radius_mm=5.0)
    np.testing.assert_allclose(_xy(back), _xy(wp), atol=1e-9)
    assert (back["rpm_programmed"].to_numpy()[cut] == 10000.0).all()


def test_plan_with_compensation_and_a_program_it_cannot_hold(tmp_path):
    """Planned with the job's radius; passes whose copies would lose G41 are refused."""
    from robolobe.plan.job import load_job
    from robolobe.plan.pipeline import plan_path
    from robolobe.plan.program import program_edit, program_text

    ex = Path(__file__).resolve().parents[2] / "src" / "robolobe" / "data" / "examples"
    text = (
        "G21 G90 G17\nS18000 M3\nG0 X-20 Y-20 Z5\nG41 D1 G0 X0 Y0\nG1 Z-2 F600\nX40\nY30\n"
        "G3 X20 Y50 I-20 J0\nG1 X0\nY0\nG40 X-20 Y-20\nG0 Z5\nM30\n"
    )
    src = tmp_path / "comp.nc"
    src.write_text(text)
    job = load_job(ex / "job_A_pocket.toml")
    job = job.replace(path_options={**job.path_options, "cutter_radius_mm": 5.0})
    res = plan_path(src, job, refine=False)
    files = program_text(res)  # one pass: only S/F change, the compensated path reads back
    assert "G41 D1" in files["program.nc"]
    edit = program_edit(res, passes=2, depth_mm=2.0)
    with pytest.raises(InputError, match="cannot write this program faithfully"):
        program_text(res, edit=edit)
