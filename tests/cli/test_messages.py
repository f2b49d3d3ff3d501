"""CLI messages print user text as written; --version."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

import robolobe
from robolobe.cli.main import app


def test_version() -> None:
    r = CliRunner().invoke(app, ["--version"])
    assert r.exit_code == 0
    assert r.output.strip() == f"robolobe {robolobe.__version__}"


def test_emoji_codes_in_user_text_are_not_interpreted(tmp_path: Path) -> None:
    modes = tmp_path / "modes.csv"
    modes.write_text("root:x:0:0:root:/root:/bin/bash\n")
    r = subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", "sld", "--modes", str(modes),
         "--teeth", "2", "--immersion", "0.5", "--rpm", "5000:6000",
         "--material", "Al7075-T6", "-o", str(tmp_path / "l.csv")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert r.returncode == 2
    assert "root:x:0:0" in r.stderr
    assert "\u274c" not in r.stderr


def test_progress_without_a_terminal_is_logged(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from robolobe.cli import _common

    monkeypatch.setattr(_common, "LOG_EVERY_S", 0.01)
    with _common.status("planning"):
        time.sleep(0.05)
    with _common.progress() as bar:
        task = bar.add_task("identifying", total=3)
        for _ in range(3):
            time.sleep(0.02)
            bar.advance(task)
    err = capsys.readouterr().err
    assert "planning (still running" in err
    assert "planning done in" in err
    assert "identifying: 3/3 done" in err


def _main_err(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    from robolobe.cli.main import main

    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err, err
    return err


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["simulate", "A", "-o", "{t}/s", "--design", "random", "--n", "2", "--window-end", "5"],
         "error: --window-end: expected a number in [0.001, 1], found 5"),
        (["simulate", "A", "-o", "{t}/s", "--design", "random", "--n", "2", "--impacts", "0"],
         "error: --impacts: expected an integer >= 1, found 0"),
        (["simulate", "A", "-o", "{t}/s", "--design", "random", "--n", "2", "--double-hits", "2"],
         "error: --double-hits: expected a probability in [0, 1], found 2"),
        (["sld", "--modes", "{t}/m.csv", "--teeth", "2", "--immersion", "0.5", "--rpm",
          "5000:6000", "-o", "{t}/l.csv", "--kt", "700", "--kr", "0.3"],
         "error: --kt: expected 1e+07 to 2e+10 N/m^2"),
        (["sld", "--modes", "{t}/m.csv", "--teeth", "2", "--immersion", "0.5", "--rpm",
          "5000:6000", "-o", "{t}/l.csv", "--material", "unobtainium"],
         "error: --material: expected one of"),
        (["sld", "--modes", "{t}/m.csv", "--teeth", "2", "--immersion", "0.5", "--rpm",
          "5000:6000", "-o", "{t}/l.csv", "--kt", "7e8"],
         "error: --kt and --kr: expected both (or --material NAME), found only --kt"),
    ],
)  # fmt: skip
def test_messages_name_the_option(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], expected: str
) -> None:
    """Option names, not class or argument names (HammerTestSettings.window_end, Kt)."""
    (tmp_path / "m.csv").write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,50,0.02,1e7\n")
    err = _main_err([a.format(t=tmp_path) for a in args], capsys)
    assert err.startswith(expected), err
    assert "HammerTestSettings" not in err
    assert not list(tmp_path.glob("s*")), "nothing written"


@pytest.mark.parametrize(
    "args",
    [
        ["plan", "{ex}/pocket.nc", "--job", "{d}", "-o", "{t}/o"],
        ["plan", "{d}", "--job", "{ex}/job_A_pocket.toml", "-o", "{t}/o"],
        ["simulate", "{d}", "-o", "{t}/o", "--design", "random", "--n", "2"],
        ["design-tests", "{d}", "--n", "3", "-o", "{t}/o.csv"],
        ["batch", "{ex}/pocket.nc", "{d}", "--job", "{ex}/job_A_pocket.toml", "-o", "{t}/o"],
        ["sld", "--modes", "{d}", "--teeth", "2", "--immersion", "0.5", "--rpm", "5000:6000",
         "-o", "{t}/o.csv", "--material", "steel"],
    ],
)  # fmt: skip
def test_a_directory_given_for_a_file_is_called_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str]
) -> None:
    from importlib import resources

    ex = Path(str(resources.files("robolobe.data").joinpath("examples")))
    d = tmp_path / "a folder"
    d.mkdir()
    err = _main_err([a.format(t=tmp_path, d=d, ex=ex) for a in args], capsys)
    assert f"error: {d}: " in err, err
    assert "directory" in err, err
    assert "no such file" not in err, err


def test_batch_refuses_a_missing_path_before_planning(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from importlib import resources

    ex = Path(str(resources.files("robolobe.data").joinpath("examples")))
    err = _main_err(
        ["batch", str(ex / "pocket.nc"), "paths/*.nc", "--job", str(ex / "job_A_pocket.toml"),
         "-o", str(tmp_path / "b")],
        capsys,
    )  # fmt: skip
    assert err == (
        "error: paths/*.nc: expected a toolpath file, found no such file "
        "(a shell pattern that matched nothing?)"
    )
    assert not (tmp_path / "b").exists()
