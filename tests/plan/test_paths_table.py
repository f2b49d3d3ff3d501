"""Waypoint tables: CSV/Parquet round trip, validation, format detection."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths import COLUMNS, detect_format, read_toolpath, write_table


def test_round_trip_csv_and_parquet(tmp_path, data_dir):
    df = read_toolpath(data_dir / "face.mod")
    for name in ("wp.csv", "wp.parquet"):
        write_table(df, tmp_path / name)
        back = read_toolpath(tmp_path / name)
        assert tuple(back.columns) == COLUMNS
        num = [c for c in COLUMNS if c not in ("motion", "source")]
        assert np.allclose(back[num].to_numpy(float), df[num].to_numpy(float), equal_nan=True)
        assert back["motion"].tolist() == df["motion"].tolist()


def test_minimal_table_gets_defaults(tmp_path):
    p = tmp_path / "min.csv"
    p.write_text("# a comment line\nx_m,y_m,z_m\n0,0,0\n0.1,0,0\n0.1,0.1,0\n", encoding="utf-8")
    df = read_toolpath(p)
    assert np.allclose(df[["i", "j", "k"]].to_numpy(), [0, 0, 1])
    assert (df["motion"] == "cut").all()
    assert df[["fx", "fy", "fz"]].iloc[2].tolist() == pytest.approx([0, 1, 0])
    assert df[["fx", "fy", "fz"]].iloc[0].tolist() == pytest.approx([1, 0, 0])
    assert df["line"].tolist() == [2, 3, 4]


@pytest.mark.parametrize(
    ("body", "what"),
    [
        ("x_m,y_m\n0,0\n", "missing"),
        ("x_m,y_m,z_m\n0,0,0\n0,abc,0\n", r"min\.csv:3: column y_m"),
        ("x_m,y_m,z_m,motion\n0,0,0,cut\n0,1,0,fly\n", r"min\.csv:3: column motion"),
        ("x_m,y_m,z_m,i,j,k\n0,0,0,0,0,0\n", r"min\.csv:2: .*tool axis"),
    ],
)
def test_table_errors(tmp_path, body, what):
    p = tmp_path / "min.csv"
    p.write_text(body, encoding="utf-8")
    with pytest.raises(InputError, match=what):
        read_toolpath(p)


def test_detect_format_by_content(tmp_path, data_dir):
    for src, fmt in (
        ("pocket_fanuc.nc", "gcode"),
        ("contour_catia_ok.apt", "apt"),
        ("face.mod", "rapid"),
    ):
        q = tmp_path / (src.split(".")[0] + ".txt")
        q.write_text((data_dir / src).read_text(encoding="utf-8"), encoding="utf-8")
        assert detect_format(q) == fmt
    bad = tmp_path / "x.txt"
    bad.write_text("hello\n", encoding="utf-8")
    with pytest.raises(InputError, match="cannot tell"):
        detect_format(bad)
    with pytest.raises(InputError, match="no such file"):
        read_toolpath(tmp_path / "missing.nc")


def test_reader_options_are_checked(data_dir):
    with pytest.raises(InputError, match="options"):
        read_toolpath(data_dir / "pocket_fanuc.nc", tool_direction="x")
    df = read_toolpath(data_dir / "pocket_fanuc.nc", arc_tol_mm=0.5)
    assert len(df) < len(read_toolpath(data_dir / "pocket_fanuc.nc"))
    assert isinstance(df, pd.DataFrame)
