"""Campaign folders (FORMATS.md section 2): round trips and reader validation."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from robolobe._atomic import MANIFEST
from robolobe.campaign import Campaign, PostureFRF, read_campaign, read_postures, write_campaign
from robolobe.errors import InputError

# Robot B's test postures (seed paper Table 3): every B robot file must accept them.
Q_DEG = np.array(
    [
        [-2, 21, -27, 5, 1, -29],
        [-60, 50, -120, 115, -66, -197],
        [23, -28, -101, -82, 124, 168],
    ],
    dtype=float,
)
IDS = ("T1", "T2", "T3")


def _campaign(dirs=("xx", "yy", "zz", "xy"), n_freq: int = 41, seed: int = 0) -> Campaign:
    rng = np.random.default_rng(seed)
    f = np.arange(n_freq) * 0.25
    h = (
        rng.standard_normal((3, n_freq, 3, 3)) + 1j * rng.standard_normal((3, n_freq, 3, 3))
    ) * 1e-6
    return Campaign.from_arrays(
        "B",
        IDS,
        np.radians(Q_DEG),
        f,
        h,
        dirs=dirs,
        notes="test campaign",
        test={"sample_rate_hz": 1024.0, "duration_s": 4.0, "impacts": 5},
    )


def _write(tmp_path: Path) -> Path:
    return write_campaign(tmp_path / "camp", _campaign())


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines()


def _put(path: Path, lines: list[str]) -> None:
    path.write_text("\n".join(lines) + "\n")


# ---------------------------------------------------------------- round trips
def test_csv_round_trip_exact(tmp_path):
    c = _campaign()
    out = write_campaign(tmp_path / "camp", c)
    assert sorted(p.name for p in out.iterdir()) == [
        MANIFEST,
        "campaign.toml",
        "frf.csv",
        "postures.csv",
    ]
    r = read_campaign(out)
    assert r.robot == "B"
    assert r.posture_ids == IDS
    assert r.notes == "test campaign"
    assert r.test == {"sample_rate_hz": 1024.0, "duration_s": 4.0, "impacts": 5}
    np.testing.assert_allclose(r.q_rad, c.q_rad, rtol=1e-15, atol=1e-15)
    f, h, has = r.common_grid()
    f0, h0, has0 = c.common_grid()
    np.testing.assert_array_equal(f, f0)
    np.testing.assert_array_equal(has, has0)
    np.testing.assert_array_equal(h, h0)  # exact: full float precision in the CSV
    assert r.dirs == {"xx", "yy", "zz", "xy"}
    _, hxy = r.frf("T2", "xy")
    np.testing.assert_array_equal(hxy, h0[1, :, 0, 1])
    with pytest.raises(InputError, match="no direction 'zx'"):
        r.frf("T2", "zx")
    with pytest.raises(InputError, match="unknown posture"):
        r.frf("T9", "xx")


def test_uff_round_trip(tmp_path):
    c = _campaign()
    out = write_campaign(tmp_path / "camp", c, fmt="uff")
    assert sorted(p.name for p in (out / "frf").iterdir()) == ["T1.uff", "T2.uff", "T3.uff"]
    assert not (out / "frf.csv").exists()
    r = read_campaign(out)
    f, h, has = r.common_grid()
    f0, h0, has0 = c.common_grid()
    np.testing.assert_array_equal(f, f0)
    np.testing.assert_array_equal(has, has0)
    np.testing.assert_allclose(h, h0, rtol=1e-10, equal_nan=True)


def test_uff_accelerance_is_read_as_receptance(tmp_path):
    c = _campaign()
    out = write_campaign(tmp_path / "camp", c, fmt="uff", uff_quantity="acceleration")
    r = read_campaign(out)
    f, h, _ = r.common_grid()
    f0, h0, _ = c.common_grid()
    np.testing.assert_array_equal(f, f0[1:])  # 0 Hz dropped: accelerance / -w^2 undefined
    np.testing.assert_allclose(h, h0[:, 1:], rtol=1e-10, equal_nan=True)


def test_switching_format_removes_the_other(tmp_path):
    out = write_campaign(tmp_path / "camp", _campaign(), fmt="uff")
    write_campaign(out, _campaign(), fmt="csv")
    assert not (out / "frf").exists()
    read_campaign(out)
    write_campaign(out, _campaign(), fmt="uff")
    assert not (out / "frf.csv").exists()
    read_campaign(out)


def test_per_posture_grids(tmp_path):
    h = np.full((41, 3, 3), np.nan + 0j)
    h[:, 0, 0] = 1e-6
    g = np.full((21, 3, 3), np.nan + 0j)
    g[:, 1, 1] = 2e-6
    c = Campaign(
        robot="B",
        posture_ids=IDS[:2],
        q_rad=np.radians(Q_DEG[:2]),
        frfs=(PostureFRF(np.arange(41) * 0.25, h), PostureFRF(np.arange(21) * 0.5, g)),
    )
    assert not c.has_common_grid()
    with pytest.raises(InputError, match="different frequency grids"):
        c.common_grid()
    r = read_campaign(write_campaign(tmp_path / "camp", c))
    f1, h1 = r.frf("T2", "yy")
    np.testing.assert_array_equal(f1, np.arange(21) * 0.5)
    np.testing.assert_array_equal(h1, 2e-6)
    assert r.frfs[0].dirs == {"xx"}


def test_robot_file_relative_to_folder(tmp_path):
    from robolobe.robots import load_robot, save_robot

    robot_file = tmp_path / "robots" / "mine.toml"
    robot_file.parent.mkdir()
    save_robot(load_robot("B"), robot_file)
    c = _campaign()
    c = Campaign(robot=str(robot_file), posture_ids=c.posture_ids, q_rad=c.q_rad, frfs=c.frfs)
    out = write_campaign(tmp_path / "camp", c)
    assert 'robot = "../robots/mine.toml"' in (out / "campaign.toml").read_text()
    assert Path(read_campaign(out).robot) == robot_file.resolve()
    # A self-contained copy.
    out2 = write_campaign(tmp_path / "camp2", c, copy_robot=True)
    assert 'robot = "robot.toml"' in (out2 / "campaign.toml").read_text()
    assert Path(read_campaign(out2).robot) == (out2 / "robot.toml").resolve()


def test_blank_lines_and_extra_columns_are_accepted(tmp_path, caplog):
    out = _write(tmp_path)
    lines = _lines(out / "frf.csv")
    lines.insert(3, "")
    _put(out / "frf.csv", [*lines, "", ""])
    post = _lines(out / "postures.csv")
    post[0] += ",rol"
    post[1:] = [p + ",train" for p in post[1:]]
    _put(out / "postures.csv", post)
    (out / "campaign.toml").write_text('robot = "B"\nnotse = "x"\n')
    with caplog.at_level(logging.WARNING):
        r = read_campaign(out)
    assert r.n_postures == 3
    assert "did you mean 'notes'" in caplog.text
    # 'rol' is not close to a known column: no warning; a typo of one is.
    assert "'rol'" not in caplog.text
    post[0] = post[0].replace(",rol", ",q7_deg")
    _put(out / "postures.csv", post)
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        read_campaign(out)
    assert "unknown column 'q7_deg'" in caplog.text


# ---------------------------------------------------------------- validation
def _edit_frf(out: Path, line: int, text: str) -> None:
    lines = _lines(out / "frf.csv")
    lines[line - 1] = text
    _put(out / "frf.csv", lines)


@pytest.mark.parametrize(
    ("line", "text", "source", "match"),
    [
        (1, "posture_id,dir,freq_hz,re,imag", "frf.csv:1", r"missing column\(s\) im; expected"),
        (5, "T1,xx,1.0,abc,0", "frf.csv:5", "expected a number in column re, found 'abc'"),
        (6, "T1,xx,1.25,nan,0", "frf.csv:6", "finite number in column re"),
        (7, "T1,xx,1.5,1e-6,inf", "frf.csv:7", "finite number in column im"),
        (8, "T1,xx,1.75,,0", "frf.csv:8", "missing value in column re"),
        (9, "T1,xw,2.0,1e-6,0", "frf.csv:9", "expected dir of two letters"),
        (10, "T7,xx,2.25,1e-6,0", "frf.csv:10", "'T7' is not in postures.csv"),
        (11, "T1,xx,2.0,1e-6,0", "frf.csv:11", "duplicate row .* \\(first at line 10\\)"),
        (12, "T1,xx,-1,1e-6,0", "frf.csv:12", "freq_hz >= 0"),
        (12, "T1,xx,1.0,1e-6,0", "frf.csv:12", "duplicate row .* \\(first at line 6\\)"),
        (12, "T1,xx,0.9,1e-6,0", "frf.csv:12", "must increase: 0.9 after 2.25 \\(line 11\\)"),
        (12, "T1,xx,2.6,1e-6,0", "frf.csv:", "one grid per posture"),
        (12, "T1,xx,2.75,1e-6,0,9", "frf.csv:12", "CSV syntax error"),
    ],
)
def test_frf_csv_errors_name_file_and_line(tmp_path, line, text, source, match):
    out = _write(tmp_path)
    _edit_frf(out, line, text)
    with pytest.raises(InputError, match=match) as exc:
        read_campaign(out)
    assert exc.value.source is not None
    assert exc.value.source.startswith(source)


def test_missing_frf_rows_for_a_posture(tmp_path):
    out = _write(tmp_path)
    lines = [ln for ln in _lines(out / "frf.csv") if not ln.startswith("T3,")]
    _put(out / "frf.csv", lines)
    with pytest.raises(InputError, match="'T3' has no rows") as exc:
        read_campaign(out)
    assert exc.value.source == "postures.csv:4"


@pytest.mark.parametrize(
    ("line", "text", "source", "match"),
    [
        (1, "posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg", "postures.csv:1", "q6_deg"),
        (3, "T1,1,2,3,4,5,6", "postures.csv:3", "duplicate posture_id 'T1' \\(first at line 2\\)"),
        (3, "T2,1,2,x,4,5,6", "postures.csv:3", "column q3_deg, found 'x'"),
        (4, "T3,200,2,-50,4,5,6", "postures.csv:4", "posture 'T3': q1_deg = 200"),
    ],
)
def test_postures_csv_errors(tmp_path, line, text, source, match):
    out = _write(tmp_path)
    lines = _lines(out / "postures.csv")
    lines[line - 1] = text
    _put(out / "postures.csv", lines)
    with pytest.raises(InputError, match=match) as exc:
        read_campaign(out)
    assert exc.value.source == source


def test_toml_errors(tmp_path):
    out = _write(tmp_path)
    (out / "campaign.toml").write_text('notes = "no robot"\n')
    with pytest.raises(InputError, match="missing key robot"):
        read_campaign(out)
    (out / "campaign.toml").write_text('robot = "B\n')
    with pytest.raises(InputError, match="TOML syntax error") as exc:
        read_campaign(out)
    assert exc.value.source == "campaign.toml:1"
    (out / "campaign.toml").write_text('robot = "nosuch.toml"\n')
    with pytest.raises(InputError, match=r"nosuch\.toml"):
        read_campaign(out)
    (out / "campaign.toml").unlink()
    with pytest.raises(InputError, match=r"missing campaign\.toml"):
        read_campaign(out)
    with pytest.raises(InputError, match="no such folder"):
        read_campaign(tmp_path / "nowhere")


def test_missing_frf_files(tmp_path):
    out = _write(tmp_path)
    (out / "frf.csv").unlink()
    with pytest.raises(InputError, match=r"missing frf\.csv"):
        read_campaign(out)
    out = write_campaign(tmp_path / "u", _campaign(), fmt="uff")
    (out / "frf" / "T2.uff").unlink()
    with pytest.raises(InputError, match=r"no file frf/T2\.uff") as exc:
        read_campaign(out)
    assert exc.value.source == "postures.csv:3"
    (out / "frf" / "T9.uff").write_text("")
    with pytest.raises(InputError, match=r"'T9' is not in postures\.csv"):
        read_campaign(out)


def test_read_postures_alone(tmp_path):
    p = tmp_path / "p.csv"
    p.write_text("posture_id, q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\na, 0,0,0,0,0,0\n")
    ids, q = read_postures(p)
    assert ids == ("a",)
    np.testing.assert_array_equal(q, 0.0)
    p.write_text("posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n")
    with pytest.raises(InputError, match="no postures"):
        read_postures(p)
    p.write_text("")
    with pytest.raises(InputError, match="empty file") as exc:
        read_postures(p)
    assert exc.value.source == f"{p}:1"


def test_failed_write_leaves_nothing(tmp_path):
    c = _campaign()
    bad = Campaign(robot="B", posture_ids=("a/b",), q_rad=c.q_rad[:1], frfs=c.frfs[:1])
    with pytest.raises(InputError, match="cannot be a file name"):
        write_campaign(tmp_path / "camp", bad, fmt="uff")
    assert not (tmp_path / "camp").exists()
    assert list(tmp_path.iterdir()) == []


def test_campaign_validation():
    c = _campaign()
    with pytest.raises(InputError, match="duplicate posture id"):
        Campaign(robot="B", posture_ids=("a", "a"), q_rad=c.q_rad[:2], frfs=c.frfs[:2])
    with pytest.raises(InputError, match="q_rad"):
        Campaign(robot="B", posture_ids=("a",), q_rad=c.q_rad, frfs=c.frfs[:1])
    h = np.full((3, 3, 3), 1e-6 + 0j)
    h[1, 0, 0] = np.nan
    with pytest.raises(InputError, match="fully finite or fully NaN"):
        PostureFRF(np.arange(3.0), h)


def test_posture_ids_needing_quotes_round_trip(tmp_path):
    c = _campaign()
    ids = ('pose, "one"', "two", "three")
    c = Campaign(robot="B", posture_ids=ids, q_rad=c.q_rad, frfs=c.frfs)
    r = read_campaign(write_campaign(tmp_path / "camp", c))
    assert r.posture_ids == ids
    np.testing.assert_array_equal(r.common_grid()[1], c.common_grid()[1])


def test_write_over_a_file_is_an_input_error(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="found a file"):
        write_campaign(tmp_path / "f", _campaign())
    c = _campaign()
    c2 = Campaign(
        robot="B",
        posture_ids=c.posture_ids,
        q_rad=c.q_rad,
        frfs=c.frfs,
        test={"impacts": np.int64(5), "duration_s": np.float64(4.0)},
    )
    assert read_campaign(write_campaign(tmp_path / "c", c2)).test == {
        "impacts": 5,
        "duration_s": 4.0,
    }


def test_simulate_campaign_exact_and_tested():
    from robolobe.twin.campaign import simulate_campaign

    def receptance(q: np.ndarray, f: np.ndarray) -> np.ndarray:
        # 1-DOF per axis whose frequency depends on q1 (a toy posture dependence).
        fn = 10.0 * (1 + 0.2 * q[0]) * np.array([1.0, 1.3, 1.7])
        r = np.asarray(f)[:, None] / fn
        h = 1 / (1e6 * (1 - r**2 + 0.06j * r))
        return np.einsum("ni,ij->nij", h, np.eye(3))

    q = np.radians(Q_DEG)
    ex = simulate_campaign(
        receptance, "B", IDS, q, rng=np.random.default_rng(0), exact=True, dirs=["xx", "zz"]
    )
    f, h, has = ex.common_grid()
    np.testing.assert_allclose(f, np.arange(161) * 0.25)
    assert has[:, 0, 0].all()
    assert has[:, 2, 2].all()
    assert has.sum() == 6
    np.testing.assert_array_equal(h[1, :, 0, 0], receptance(q[1], f)[:, 0, 0])
    assert ex.test == {}
    calls: list[int] = []
    sim = simulate_campaign(
        receptance,
        "B",
        IDS,
        q,
        rng=np.random.default_rng(0),
        dirs=["yy"],
        fmax_hz=20.0,
        on_posture=calls.append,
    )
    assert calls == [0, 1, 2]
    assert sim.dirs == {"yy"}
    assert sim.test["window_end"] == 0.05
    fs, hs, _ = sim.common_grid()
    assert fs[-1] == 20.0
    # Peaks where the exact receptance peaks (the window broadens but does not move them).
    for p in range(3):
        k_sim = np.argmax(np.abs(hs[p, 8:, 1, 1])) + 8
        k_ex = np.argmax(np.abs(receptance(q[p], fs)[8:, 1, 1])) + 8
        assert abs(fs[k_sim] - fs[k_ex]) <= 0.25


# ---------------------------------------------------------------- bad input (issue 14)
@pytest.mark.parametrize("variant", ["bom", "crlf", "mixed"])
def test_bom_and_line_endings_read_the_same(tmp_path, variant):
    out = _write(tmp_path)
    ref = read_campaign(out)
    for name in ("frf.csv", "postures.csv"):
        raw = (out / name).read_bytes()
        data = {
            "bom": b"\xef\xbb\xbf" + raw,
            "crlf": raw.replace(b"\n", b"\r\n"),
            "mixed": raw.replace(b"\n", b"\r\n", 7),
        }[variant]
        (out / name).write_bytes(data)
    got = read_campaign(out)
    assert got.posture_ids == ref.posture_ids
    for a, b in zip(got.frfs, ref.frfs, strict=True):
        np.testing.assert_array_equal(a.freq_hz, b.freq_hz)
        np.testing.assert_array_equal(a.H, b.H)


def test_line_numbers_survive_mixed_line_endings(tmp_path):
    out = _write(tmp_path)
    lines = _lines(out / "frf.csv")
    lines[9] = lines[9].rsplit(",", 1)[0] + ",abc"
    (out / "frf.csv").write_bytes(
        ("\r\n".join(lines[:5]) + "\n" + "\n".join(lines[5:]) + "\n").encode()
    )
    with pytest.raises(InputError, match=r"frf\.csv:10: expected a number in column im"):
        read_campaign(out)


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b"", r"frf\.csv:1: empty file"),
        (b"posture_id,dir,freq_hz,re,im\n\x00\x01\x02\x03" * 3, r"frf\.csv:2: binary data"),
        (b"posture_id,dir,freq_hz,re,im\nT1,xx,0,1e-6,\xe9\n", r"frf\.csv:2: not UTF-8"),
    ],
)
def test_empty_binary_and_non_utf8_frf_files(tmp_path, data, match):
    out = _write(tmp_path)
    (out / "frf.csv").write_bytes(data)
    with pytest.raises(InputError, match=match):
        read_campaign(out)


def test_truncated_frf_csv_names_the_cut_line(tmp_path):
    out = _write(tmp_path)
    raw = (out / "frf.csv").read_bytes()
    cut = raw[: int(len(raw) * 0.6)]
    cut = cut[: cut.rindex(b",") + 4]  # inside the last line's value
    (out / "frf.csv").write_bytes(cut)
    # the last line parses (a number cut short is still a number): the rows missing after
    # it are reported, with the hint that the file lacks its final line break
    with pytest.raises(InputError, match=r"has no rows in frf\.csv .*was it cut short"):
        read_campaign(out)
    (out / "frf.csv").write_bytes(cut[: cut.rindex(b",") + 1])  # cut after a comma
    last = cut.count(b"\n") + 1
    with pytest.raises(InputError, match=rf"frf\.csv:{last}: missing value"):
        read_campaign(out)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("1e300", r"frf\.csv:12: posture 'T1', dir 'xx': implausible receptance"),
        ("2e3", r"frf\.csv:12: posture 'T1', dir 'xx': implausible receptance"),
        ("5e2", r"frf\.csv:12: posture 'T1', dir 'xx': implausible value .* times the median"),
        ("inf", r"frf\.csv:12: expected a finite number in column re"),
        ("nan", r"frf\.csv:12: expected a finite number in column re"),
    ],
)
def test_non_finite_and_absurd_values(tmp_path, text, match):
    out = _write(tmp_path)
    lines = _lines(out / "frf.csv")
    pid, d, f, _re, im = lines[11].split(",")
    assert (pid, d) == ("T1", "xx")
    lines[11] = ",".join([pid, d, f, text, im])
    _put(out / "frf.csv", lines)
    with pytest.raises(InputError, match=match):
        read_campaign(out)


# ---------------------------------------------------------------- test header and force levels
def test_test_header_is_one_typed_rule_for_the_window():
    from robolobe.campaign import TestHeader
    from robolobe.modal.identify import settings_from_test

    h = TestHeader.from_mapping({"duration_s": 4.0, "window_end": 0.05, "operator": "x"})
    assert h.decay_per_s == pytest.approx(-np.log(0.05) / 4.0, rel=1e-15)
    assert h.has_window
    assert dict(h) == {"duration_s": 4.0, "window_end": 0.05, "operator": "x"}
    # identification takes the same number from the same rule
    assert settings_from_test(h).window_decay_per_s == h.decay_per_s
    direct = TestHeader.from_mapping({"window_decay_per_s": 0.7})
    assert direct.decay_per_s == 0.7
    assert direct.duration_s is None
    none = TestHeader()
    assert not none.has_window
    assert none.decay_per_s == 0.0
    assert len(none) == 0


@pytest.mark.parametrize(
    ("table", "key", "expect"),
    [
        ({"window_end": 0.05}, "test]", "needs duration_s"),
        ({"duration_s": 4.0, "window_end": 1.5}, "test.window_end", "[0.001, 1]"),
        # a window ending at 1e-300 leaves milliseconds of signal: the window, not the
        # structure, would set the decay
        ({"duration_s": 4.0, "window_end": 1e-300}, "test.window_end", "[0.001, 1]"),
        ({"duration_s": -1.0}, "test.duration_s", "record length"),
        ({"impacts": 2.5}, "test.impacts", "number of impacts"),
        ({"coherence_min": "high"}, "test.coherence_min", "coherence"),
        ({"duration_s": 4.0, "window_end": 0.1, "window_decay_per_s": 0.5}, "test]", "both"),
    ],
)
def test_test_header_refuses_bad_values_by_key(tmp_path, table, key, expect):
    import tomli_w

    folder = _write(tmp_path)
    (folder / "campaign.toml").write_text(tomli_w.dumps({"robot": "B", "test": table}))
    with pytest.raises(InputError) as exc:
        read_campaign(folder)
    assert f"campaign.toml[{key}" in str(exc.value)
    assert expect in str(exc.value)


def test_force_levels_round_trip_and_bad_value_names_the_line(tmp_path):
    c = _campaign()
    c2 = Campaign(
        c.robot, c.posture_ids, c.q_rad, c.frfs, test=c.test, force_N=np.array([200.0, 400, 800])
    )
    out = write_campaign(tmp_path / "camp", c2)
    back = read_campaign(out)
    assert back.force_N is not None
    assert np.array_equal(back.force_N, [200.0, 400.0, 800.0])
    assert read_campaign(write_campaign(tmp_path / "plain", c)).force_N is None
    lines = _lines(out / "postures.csv")
    assert lines[0].endswith(",force_N")
    lines[2] = lines[2].rsplit(",", 1)[0] + ",-5"
    _put(out / "postures.csv", lines)
    with pytest.raises(InputError, match=r"postures.csv:3.*peak force > 0 N.*-5"):
        read_campaign(out)


def test_a_folder_where_a_file_belongs_is_named(tmp_path):
    from robolobe.campaign.uff import read_uff_frfs

    folder = _write(tmp_path)
    (folder / "frf.csv").unlink()
    (folder / "frf.csv").mkdir()
    with pytest.raises(InputError, match=r"frf.csv: expected a CSV file, found a directory"):
        read_campaign(folder)
    with pytest.raises(InputError, match="expected a UFF file, found a directory"):
        read_uff_frfs(tmp_path)
