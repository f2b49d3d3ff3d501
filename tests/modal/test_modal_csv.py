"""modal.csv reader/writer (FORMATS.md section 3): round trip and one clear error per problem."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robolobe.errors import InputError
from robolobe.modal.modal_csv import MODAL_COLUMNS, read_modal_csv, write_modal_csv

HEADER = ",".join(MODAL_COLUMNS)


def _frame() -> pd.DataFrame:
    rng = np.random.default_rng(0)
    rows = []
    for p, pid in enumerate(["p10", "p2", "007"]):
        q = rng.uniform(-90, 90, 6)
        for d in ("zz", "xx", "xy"):
            for mode in (2, 1):
                rows.append(
                    {
                        "posture_id": pid,
                        **{f"q{i + 1}_deg": q[i] for i in range(6)},
                        "dir": d,
                        "mode": mode,
                        "f_hz": 7.0 + 3.1 * mode + p / 3.0,
                        "zeta": 0.002 + 0.01 * mode,
                        "k_N_per_m": (1.0 if d != "xy" else -1.0) * 10 ** rng.uniform(4.5, 6.5),
                        "f_hz_std": 0.01 * mode,
                    }
                )
    return pd.DataFrame(rows)


def test_round_trip_exact_and_sorted(tmp_path: Path) -> None:
    df = _frame()
    out = tmp_path / "modal.csv"
    write_modal_csv(out, df)
    back = read_modal_csv(out)
    assert list(back.columns) == [*MODAL_COLUMNS, "f_hz_std"]
    # posture order of first appearance, then xx, yy, zz, cross, then mode
    assert list(dict.fromkeys(back["posture_id"])) == ["p10", "p2", "007"]
    first = back[back["posture_id"] == "p10"]
    assert list(first["dir"]) == ["xx", "xx", "zz", "zz", "xy", "xy"]
    assert list(first["mode"]) == [1, 2, 1, 2, 1, 2]
    assert back["mode"].dtype == np.int64
    assert back["posture_id"].iloc[-1] == "007"  # leading zeros kept: posture ids are strings
    # exact float round trip
    key = ["posture_id", "dir", "mode"]
    merged = df.merge(back, on=key, suffixes=("_a", "_b"))
    assert len(merged) == len(df)
    for c in ("q1_deg", "q6_deg", "f_hz", "zeta", "k_N_per_m", "f_hz_std"):
        np.testing.assert_array_equal(merged[c + "_a"].to_numpy(), merged[c + "_b"].to_numpy())
    assert not list(tmp_path.glob(".*tmp"))


def _write(tmp_path: Path, lines: list[str]) -> Path:
    p = tmp_path / "modal.csv"
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


GOOD = "p1,0,-90,90,0,45,0,xx,1,7.5,0.02,150000"


@pytest.mark.parametrize(
    ("line", "needle"),
    [
        ("p1,0,-90,90,0,45,0,xq,1,7.5,0.02,150000", "column 'dir'"),
        ("p1,0,-90,90,0,45,0,xx,0,7.5,0.02,150000", "column 'mode': expected an integer >= 1"),
        ("p1,0,-90,90,0,45,0,xx,1.5,7.5,0.02,150000", "column 'mode'"),
        ("p1,0,-90,90,0,45,0,xx,2,-7.5,0.02,150000", "column 'f_hz': expected > 0"),
        ("p1,0,-90,90,0,45,0,xx,2,7.5,2,150000", "column 'zeta'"),
        ("p1,0,-90,90,0,45,0,xx,2,7.5,0,150000", "column 'zeta'"),
        ("p1,0,-90,90,0,45,0,xx,2,7.5,0.02,-150000", "column 'k_N_per_m': expected > 0"),
        ("p1,0,-90,90,0,45,0,xy,2,7.5,0.02,0", "column 'k_N_per_m'"),
        ("p1,0,-90,90,0,45,0,xx,2,nan,0.02,150000", "column 'f_hz': expected a finite number"),
        ("p1,0,-90,90,0,45,0,xx,2,abc,0.02,150000", "column 'f_hz': expected a number"),
        ("p1,0,-90,90,0,45,x,xx,2,7.5,0.02,150000", "column 'q6_deg'"),
        ("p1,0,-90,90,0,45,0,xx,2,7.5,0.02", "expected 12 fields"),
        (",0,-90,90,0,45,0,xx,2,7.5,0.02,150000", "column 'posture_id'"),
        ("p1,0,-90,91,0,45,0,xx,2,7.5,0.02,150000", "joint angles differ"),
        ("p1,0,-90,90,0,45,0,xx,1,7.6,0.02,150000", "duplicate row"),
    ],
)
def test_bad_row_names_file_line_and_column(tmp_path: Path, line: str, needle: str) -> None:
    p = _write(tmp_path, [HEADER, GOOD, line])
    with pytest.raises(InputError) as info:
        read_modal_csv(p)
    msg = str(info.value)
    assert f"{p}:3" in msg
    assert needle in msg


def test_blank_lines_do_not_shift_line_numbers(tmp_path: Path) -> None:
    p = _write(tmp_path, [HEADER, GOOD, "", "p2,0,-90,90,0,45,0,zz,1,7.5,0.02,-1"])
    with pytest.raises(InputError, match=r"modal\.csv:4: column 'k_N_per_m'"):
        read_modal_csv(p)


def test_missing_column_lists_expected_and_found(tmp_path: Path) -> None:
    p = _write(tmp_path, [HEADER.replace(",zeta", ",damping"), GOOD])
    with pytest.raises(InputError, match=r"modal\.csv:1: .*missing zeta.*found .*damping"):
        read_modal_csv(p)


def test_duplicate_column_and_empty_file(tmp_path: Path) -> None:
    p = _write(tmp_path, [HEADER + ",f_hz", GOOD + ",1"])
    with pytest.raises(InputError, match="duplicate column"):
        read_modal_csv(p)
    p.write_text("", encoding="utf-8")
    with pytest.raises(InputError, match="empty file"):
        read_modal_csv(p)
    p.write_text(HEADER + "\n", encoding="utf-8")
    with pytest.raises(InputError, match="at least one data row"):
        read_modal_csv(p)
    with pytest.raises(InputError, match="no such file"):
        read_modal_csv(tmp_path / "nope.csv")


def test_extra_columns_kept_typed(tmp_path: Path) -> None:
    p = _write(tmp_path, [HEADER + ",note,k_std", GOOD + ",hello,12.5"])
    df = read_modal_csv(p)
    assert df["note"].iloc[0] == "hello"
    assert df["k_std"].dtype == np.float64
    assert df["k_N_per_m"].iloc[0] == 150000.0


def test_write_rejects_bad_frame_and_leaves_nothing(tmp_path: Path) -> None:
    df = _frame()
    df.loc[4, "zeta"] = np.nan
    out = tmp_path / "modal.csv"
    with pytest.raises(InputError, match=r"row 4.*column 'zeta'"):
        write_modal_csv(out, df)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(InputError, match="missing k_N_per_m"):
        write_modal_csv(out, _frame().drop(columns="k_N_per_m"))
