"""UFF 58 FRF files: round trips and conversion of mobility / accelerance to receptance."""

from __future__ import annotations

import gc

import numpy as np
import pytest
import pyuff

from robolobe.campaign.uff import read_uff_frf, read_uff_frfs, write_uff_frf
from robolobe.errors import InputError


def _frf(n: int = 161, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    f = np.arange(n) * 0.25
    h = (rng.standard_normal((n, 3, 3)) + 1j * rng.standard_normal((n, 3, 3))) * 1e-6
    h[:, 0, 1] = np.nan  # xy absent
    h[:, 2, 0] = np.nan  # zx absent
    return f, h


def test_receptance_round_trip(tmp_path):
    f, h = _frf()
    write_uff_frf(tmp_path / "p.uff", f, h, name="P1")
    f2, h2 = read_uff_frf(tmp_path / "p.uff")
    np.testing.assert_array_equal(f2, f)
    # ASCII UFF 58 keeps 12 significant digits (E20.11).
    np.testing.assert_allclose(h2, h, rtol=1e-10, equal_nan=True)
    assert np.isnan(h2[:, 0, 1]).all()
    assert np.isnan(h2[:, 2, 0]).all()


@pytest.mark.parametrize("quantity", ["velocity", "acceleration"])
def test_mobility_and_accelerance_are_converted(tmp_path, quantity):
    f, h = _frf()
    write_uff_frf(tmp_path / "p.uff", f, h, quantity=quantity)
    code = {"velocity": 11, "acceleration": 12}[quantity]
    sets = pyuff.UFF(str(tmp_path / "p.uff")).read_sets()
    assert all(s["ordinate_spec_data_type"] == code for s in sets)
    assert all(s["func_type"] == 4 for s in sets)
    # The stored values are i w H or -w^2 H ...
    w = 2 * np.pi * f
    stored = next(s for s in sets if s["rsp_dir"] == 1 and s["ref_dir"] == 1)["data"]
    factor = 1j * w if quantity == "velocity" else -(w**2)
    np.testing.assert_allclose(stored, factor * h[:, 0, 0], rtol=1e-10, atol=1e-300)
    # ... and reading gives receptance back; 0 Hz (undefined there) is dropped.
    f2, h2 = read_uff_frf(tmp_path / "p.uff")
    np.testing.assert_array_equal(f2, f[1:])
    np.testing.assert_allclose(h2, h[1:], rtol=1e-10, equal_nan=True)


def test_accelerance_written_by_pyuff_directly(tmp_path):
    # A file written the way other tools do it: acceleration/force, negative direction code.
    f = np.arange(1, 81) * 0.5
    w = 2 * np.pi * f
    h = 1 / (1e6 * (1 - (f / 12.0) ** 2 + 2j * 0.02 * f / 12.0))
    d = pyuff.prepare_58(
        func_type=4,
        rsp_node=7,
        rsp_dir=-2,  # -Y response
        ref_node=7,
        ref_dir=2,
        data=-(w**2) * h,
        x=f,
        abscissa_spacing=1,
        abscissa_spec_data_type=18,
        ordinate_spec_data_type=12,
        orddenom_spec_data_type=13,
    )
    pyuff.UFF(str(tmp_path / "q.uff")).write_sets([d], mode="overwrite")
    f2, h2 = read_uff_frf(tmp_path / "q.uff")
    np.testing.assert_allclose(f2, f)
    np.testing.assert_allclose(h2[:, 1, 1], -h, rtol=1e-10)
    assert np.isnan(h2[:, 0, 0]).all()


def test_bad_files(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_uff_frf(tmp_path / "missing.uff")
    f, h = _frf()
    d = pyuff.prepare_58(
        func_type=1,  # time response, not an FRF
        rsp_node=1,
        rsp_dir=1,
        ref_node=1,
        ref_dir=1,
        data=h[:, 0, 0],
        x=f,
        abscissa_spacing=1,
        abscissa_spec_data_type=18,
        ordinate_spec_data_type=8,
        orddenom_spec_data_type=13,
    )
    pyuff.UFF(str(tmp_path / "t.uff")).write_sets([d], mode="overwrite")
    with pytest.raises(InputError, match="function type 4"):
        read_uff_frf(tmp_path / "t.uff")
    d.update(func_type=4, rsp_dir=5)
    pyuff.UFF(str(tmp_path / "r.uff")).write_sets([d], mode="overwrite")
    with pytest.raises(InputError, match="translational"):
        read_uff_frf(tmp_path / "r.uff")
    d.update(rsp_dir=1, ordinate_spec_data_type=0)
    pyuff.UFF(str(tmp_path / "u.uff")).write_sets([d], mode="overwrite")
    with pytest.raises(InputError, match="ordinate data type"):
        read_uff_frf(tmp_path / "u.uff")
    d.update(ordinate_spec_data_type=8)
    pyuff.UFF(str(tmp_path / "dup.uff")).write_sets([d, dict(d)], mode="overwrite")
    with pytest.raises(InputError, match="already in record 1"):
        read_uff_frf(tmp_path / "dup.uff")
    (tmp_path / "junk.uff").write_text("not a universal file\n")
    with pytest.raises(InputError, match=r"junk\.uff"):
        read_uff_frf(tmp_path / "junk.uff")


# ---------------------------------------------------------------- records keyed by node
def _set(rsp_node, rsp_dir, ref_node, ref_dir, data, x, **kw):
    d = dict(
        func_type=4,
        rsp_node=rsp_node,
        rsp_dir=rsp_dir,
        ref_node=ref_node,
        ref_dir=ref_dir,
        data=data,
        x=x,
        abscissa_spacing=1,
        abscissa_spec_data_type=18,
        ordinate_spec_data_type=8,
        orddenom_spec_data_type=13,
    )
    d.update(kw)
    return pyuff.prepare_58(**d)


def _h(f, fn=12.0, k=1e6):
    return 1 / (k * (1 - (f / fn) ** 2 + 2j * 0.02 * f / fn))


def test_multi_reference_file_keyed_by_node_and_direction(tmp_path):
    f = np.arange(1, 81) * 0.5
    sets = [_set(1, 1, ref, 1, _h(f) * ref, f) for ref in (1, 2, 3)]  # roving hammer
    sets.append(_set(1, 2, 2, -3, _h(f, 20.0), f))
    pyuff.UFF(str(tmp_path / "m.uff")).write_sets(sets, mode="overwrite")
    recs = read_uff_frfs(tmp_path / "m.uff")
    assert [r.key for r in recs] == [(1, 1, 1, 1), (1, 1, 2, 1), (1, 1, 3, 1), (1, 2, 2, 3)]
    assert [r.driving_point for r in recs] == [True, False, False, False]
    assert recs[3].label == "1+Y/2+Z"
    for ref in (1, 2, 3):
        np.testing.assert_allclose(recs[ref - 1].H, _h(f) * ref, rtol=1e-10)
    np.testing.assert_allclose(recs[3].H, -_h(f, 20.0), rtol=1e-10)  # -3: sign flipped
    # record and line of each record (line of its "-1" delimiter)
    text = (tmp_path / "m.uff").read_text().splitlines()
    for r in recs:
        assert text[r.line - 1].strip() == "-1"
        assert text[r.line].strip().startswith("58")
    # a campaign posture file is one node: the multi-point file is refused by name
    with pytest.raises(
        InputError, match=r"record 2: FRF 1\+X/2\+X; the file has FRFs at nodes \[1, 2, 3\]"
    ):
        read_uff_frf(tmp_path / "m.uff")
    # the same pair twice is refused with both record numbers, and the line
    pyuff.UFF(str(tmp_path / "d.uff")).write_sets([sets[1], sets[0], sets[1]], mode="overwrite")
    with pytest.raises(InputError, match=r"d\.uff:\d+: record 3: FRF 1\+X/2\+X .* record 1"):
        read_uff_frfs(tmp_path / "d.uff")


def test_direction_0_is_refused_clearly(tmp_path):
    f = np.arange(1, 81) * 0.5
    pyuff.UFF(str(tmp_path / "z.uff")).write_sets(
        [_set(1, 1, 1, 1, _h(f), f), _set(4, 0, 1, 1, _h(f), f)], mode="overwrite"
    )
    with pytest.raises(InputError, match=r"z\.uff:\d+: record 2 .*response direction 0 .* node 4"):
        read_uff_frfs(tmp_path / "z.uff")


@pytest.mark.parametrize(
    ("label", "denom", "code", "scale", "quantity"),
    [
        ("m/N", "NONE", 8, 1.0, "displacement"),
        ("mm/N", "NONE", 8, 1e-3, "displacement"),
        ("in/lbf", "NONE", 8, 0.0254 / 4.4482216152605, "displacement"),
        ("(m/s)/N", "NONE", 11, 1.0, "velocity"),
        ("m/s^2/N", "NONE", 12, 1.0, "acceleration"),
        ("g", "N", 12, 9.80665, "acceleration"),
        ("m/s2", "N", 1, 1.0, "acceleration"),  # "general" data type: the label decides
    ],
)
def test_unit_labels_are_interpreted(tmp_path, label, denom, code, scale, quantity):
    f = np.arange(1, 81) * 0.5
    w = 2 * np.pi * f
    factor = {"displacement": 1.0, "velocity": 1j * w, "acceleration": -(w**2)}[quantity]
    stored = factor * _h(f) / scale
    d = _set(
        1,
        1,
        1,
        1,
        stored,
        f,
        ordinate_spec_data_type=code,
        ordinate_axis_units_lab=label,
        orddenom_axis_units_lab=denom,
    )
    pyuff.UFF(str(tmp_path / "u.uff")).write_sets([d], mode="overwrite")
    (rec,) = read_uff_frfs(tmp_path / "u.uff")
    assert rec.quantity == quantity
    assert rec.scale == pytest.approx(scale, rel=1e-12)
    np.testing.assert_allclose(rec.H, _h(f), rtol=1e-9)


@pytest.mark.parametrize(
    ("label", "code", "match"),
    [
        ("Pa", 12, "unknown unit label 'Pa'"),
        ("m/s^2", 12, "not a length, velocity or acceleration per force"),  # no force, no denom
        ("N/m", 8, "not a length, velocity or acceleration per force"),
        ("m/N", 12, r"data type 12 \(acceleration\) contradicts the unit label 'm/N'"),
    ],
)
def test_bad_unit_labels_are_refused_by_name(tmp_path, label, code, match):
    f = np.arange(1, 81) * 0.5
    d = _set(1, 1, 1, 1, _h(f), f, ordinate_spec_data_type=code, ordinate_axis_units_lab=label)
    pyuff.UFF(str(tmp_path / "u.uff")).write_sets([d], mode="overwrite")
    with pytest.raises(InputError, match=match):
        read_uff_frfs(tmp_path / "u.uff")


def _good_file(tmp_path):
    f = np.arange(1, 81) * 0.5
    h = np.full((f.size, 3, 3), np.nan + 0j)
    h[:, 0, 0] = _h(f)
    h[:, 1, 0] = _h(f, 20.0)
    write_uff_frf(tmp_path / "g.uff", f, h)
    return f, h, (tmp_path / "g.uff").read_bytes()


@pytest.mark.parametrize(
    "variant",
    ["bom", "crlf", "mixed", "latin1_header"],
)
def test_encodings_and_line_endings_read_the_same(tmp_path, variant):
    f, h, raw = _good_file(tmp_path)
    data = {
        "bom": b"\xef\xbb\xbf" + raw,
        "crlf": raw.replace(b"\n", b"\r\n"),
        "mixed": raw.replace(b"\n", b"\r\n", 25),
        "latin1_header": raw.replace(b"robolobe FRF", b"Pr\xfcfling FRF"),  # Latin-1 u-umlaut
    }[variant]
    (tmp_path / "v.uff").write_bytes(data)
    f2, h2 = read_uff_frf(tmp_path / "v.uff")
    np.testing.assert_allclose(f2, f)
    np.testing.assert_allclose(h2, h, rtol=1e-10, equal_nan=True)


def test_broken_files_are_refused_with_file_and_line(tmp_path):
    raw = _good_file(tmp_path)[2]
    cases = {
        "empty": (b"", r"empty\.uff:1: empty file"),
        "blank": (b"\n\n  \n", r"blank\.uff:1: empty file"),
        "binary": (bytes(range(256)) * 8, r"binary\.uff:1: not a UFF file"),
        "cut": (raw[: int(len(raw) * 0.7)], r"cut\.uff:\d+: truncated file"),
        "cut_inside_data": (raw[: int(len(raw) * 0.3)], r"cut_inside_data\.uff:1: truncated"),
        "trailing": (raw + b"    -1\n    58\nabc\n", r"trailing\.uff:\d+: truncated"),
    }
    for name, (data, match) in cases.items():
        (tmp_path / f"{name}.uff").write_bytes(data)
        with pytest.raises(InputError, match=match):
            read_uff_frf(tmp_path / f"{name}.uff")


@pytest.mark.parametrize(
    ("value", "match"),
    [
        (1e300, r"implausible receptance"),
        (2e3, r"implausible receptance"),
        (3e2, r"times the median"),
    ],
)
def test_absurd_values_are_refused_naming_record_and_line(tmp_path, value, match):
    f = np.arange(1, 81) * 0.5
    v = _h(f)
    v[37] = value
    pyuff.UFF(str(tmp_path / "a.uff")).write_sets([_set(1, 1, 1, 1, v, f)], mode="overwrite")
    with pytest.raises(InputError, match=r"a\.uff:1: record 1 .*line 38 of the data \(19 Hz\).*"):
        read_uff_frf(tmp_path / "a.uff")
    with pytest.raises(InputError, match=match):
        read_uff_frf(tmp_path / "a.uff")


# pyuff's binary writer leaves its file handle to the garbage collector
@pytest.mark.filterwarnings("ignore::pytest.PytestUnraisableExceptionWarning")
@pytest.mark.filterwarnings("ignore::ResourceWarning")
def test_binary_58b_records_and_a_cut_binary_file(tmp_path):
    f = np.arange(1, 200) * 0.5
    u = pyuff.UFF(str(tmp_path / "b.uff"))
    for ref in (1, 2):
        u.write_sets(_set(1, 1, ref, 1, _h(f) * ref, f, binary=1), mode="add")
    gc.collect()  # close pyuff's leaked handles here, under this test's filters
    recs = read_uff_frfs(tmp_path / "b.uff")
    assert [r.label for r in recs] == ["1+X/1+X", "1+X/2+X"]
    assert recs[0].line == 1
    assert recs[1].line > 1
    np.testing.assert_allclose(recs[1].H, 2 * _h(f), rtol=1e-12)
    raw = (tmp_path / "b.uff").read_bytes()
    (tmp_path / "cut.uff").write_bytes(raw[: int(len(raw) * 0.8)])
    with pytest.raises(InputError, match=rf"cut\.uff:{recs[1].line}: truncated file"):
        read_uff_frfs(tmp_path / "cut.uff")
