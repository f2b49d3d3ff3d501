"""``robolobe examples`` copies the bundled jobs and paths, and refuses to overwrite."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from typer.testing import CliRunner

from robolobe.cli.main import app


def test_examples_copies_every_bundled_file_byte_for_byte(tmp_path: Path) -> None:
    out = tmp_path / "ex"
    r = CliRunner().invoke(app, ["examples", str(out)])
    assert r.exit_code == 0, r.output
    base = resources.files("robolobe.data").joinpath("examples")
    for name in ("pocket.nc", "contour.apt", "face.mod", "slot.src", "job_B_contour.toml"):
        assert (out / name).read_bytes() == base.joinpath(name).read_bytes()
    assert not (out / "__init__.py").exists()


def test_examples_refuses_to_overwrite_without_force(tmp_path: Path) -> None:
    (tmp_path / "pocket.nc").write_text("mine")
    r = CliRunner().invoke(app, ["examples", str(tmp_path)])
    assert r.exit_code != 0
    assert (tmp_path / "pocket.nc").read_text() == "mine"
    assert not (tmp_path / "contour.apt").exists()
    r = CliRunner().invoke(app, ["examples", str(tmp_path), "--force"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "pocket.nc").read_text() != "mine"
