"""Model files: anything that is not a robolobe .npz is refused by name, pickles never loaded."""

from __future__ import annotations

import pickle
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from robolobe._npz import read_npz
from robolobe.errors import InputError
from robolobe.tl.estimator import ModalPredictor


def _shipped() -> bytes:
    return resources.files("robolobe.data").joinpath("models", "A.npz").read_bytes()


@pytest.mark.parametrize(
    ("content", "match"),
    [
        (b"", "not a robolobe model file: the file is empty"),
        (b"format = 'robolobe-robot/1'\n", r"not a robolobe model file: expected a \.npz"),
        (pickle.dumps({"x": 1}), r"not a robolobe model file: expected a \.npz"),
        (None, "damaged or truncated"),
    ],
)
def test_bad_model_files_are_refused(tmp_path: Path, content: bytes | None, match: str) -> None:
    f = tmp_path / "m.npz"
    f.write_bytes(_shipped()[: len(_shipped()) // 2] if content is None else content)
    with pytest.raises(InputError, match=match) as info:
        ModalPredictor.load(f)
    assert "allow_pickle" not in str(info.value)
    assert str(f) in str(info.value)


def test_object_arrays_are_never_unpickled(tmp_path: Path) -> None:
    f = tmp_path / "obj.npz"
    np.savez(f, meta=np.array([{"evil": True}], dtype=object))
    with pytest.raises(InputError, match="Python objects, which robolobe never loads"):
        read_npz(f)


def test_directory_and_missing(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="found a directory"):
        read_npz(tmp_path)
    with pytest.raises(InputError, match="no such file"):
        read_npz(tmp_path / "nope.npz")


def test_shipped_model_still_loads() -> None:
    with resources.as_file(resources.files("robolobe.data").joinpath("models", "A.npz")) as p:
        assert ModalPredictor.load(p).n_modes >= 1
