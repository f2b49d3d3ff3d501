"""UFF 58 FRF files: round trips and conversion of mobility / accelerance to receptance."""

from __future__ import annotations

import numpy as np
import pytest
import pyuff

from robolobe.errors import InputError
from robolobe.twin.uff import read_uff_frf, write_uff_frf


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
    with pytest.raises(InputError, match="not found"):
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
