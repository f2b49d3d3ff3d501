"""The output layer: bad output paths refused before work, sets replaced whole, umask honoured."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from robolobe._atomic import MANIFEST, atomic_dir, atomic_path, check_output_dir, check_output_file
from robolobe.errors import InputError


def test_output_file_that_is_a_directory_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"^-o: .* is a directory; expected a file path"):
        check_output_file(tmp_path, "-o")


def test_output_file_below_a_file_is_refused(tmp_path: Path) -> None:
    f = tmp_path / "f.txt"
    f.write_text("x")
    with pytest.raises(InputError, match=r"is a file, so .* cannot be created"):
        check_output_file(f / "sub" / "out.csv", "-o")


def test_output_dir_that_is_a_file_is_refused(tmp_path: Path) -> None:
    f = tmp_path / "f.txt"
    f.write_text("x")
    with pytest.raises(InputError, match="is a file; expected a folder path"):
        check_output_dir(f, "-o")
    with pytest.raises(InputError, match="is a file, so"):
        check_output_dir(f / "sub", "-o")


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
def test_unwritable_output_is_refused() -> None:
    # /proc refuses new files even to root, so this runs the same as any user.
    with pytest.raises(InputError, match="is not writable"):
        check_output_file("/proc/robolobe-x.csv")
    with pytest.raises(InputError, match="is not writable"):
        check_output_dir("/proc/robolobe-out")


def test_new_nested_paths_are_accepted(tmp_path: Path) -> None:
    assert check_output_file(tmp_path / "a" / "b.csv") == tmp_path / "a" / "b.csv"
    assert check_output_dir(tmp_path / "a" / "b") == tmp_path / "a" / "b"


def test_atomic_file_honours_umask(tmp_path: Path) -> None:
    old = os.umask(0o022)
    try:
        with atomic_path(tmp_path / "x.txt") as tmp:
            tmp.write_text("x")
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "x.txt").stat().st_mode) == 0o644


def test_atomic_dir_replaces_managed_set_and_keeps_foreign_files(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with atomic_dir(out, "plan") as tmp:
        (tmp / "summary.json").write_text("1")
        (tmp / "report.html").write_text("old")
        (tmp / "plots").mkdir()
        (tmp / "plots" / "a.png").write_bytes(b"png")
    (out / "notes.txt").write_text("mine")
    with atomic_dir(out, "plan") as tmp:
        (tmp / "summary.json").write_text("2")
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "notes.txt", "summary.json"]
    assert (out / "summary.json").read_text() == "2"


def test_atomic_dir_failure_changes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with atomic_dir(out, "plan") as tmp:
        (tmp / "summary.json").write_text("keep")

    def failing_run() -> None:
        with atomic_dir(out, "plan") as tmp:
            (tmp / "summary.json").write_text("new")
            raise RuntimeError("boom")

    with pytest.raises(RuntimeError):
        failing_run()
    assert (out / "summary.json").read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "summary.json"]


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", *args],
        capture_output=True,
        text=True,
        check=False,
    )


def test_cli_sld_output_directory_is_one_line_exit_2(tmp_path: Path) -> None:
    modes = tmp_path / "modes.csv"
    modes.write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,500,0.03,2e7\nyy,1,520,0.03,2e7\n")
    r = _cli(
        "sld", "--modes", str(modes), "--teeth", "2", "--immersion", "0.5",
        "--rpm", "5000:20000:50", "--material", "Al7075-T6", "-o", str(tmp_path),
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    assert "is a directory" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_cli_simulate_output_that_is_a_file_is_refused_before_work(tmp_path: Path) -> None:
    f = tmp_path / "camp"
    f.write_text("x")
    r = _cli("simulate", "B", "--design", "seed", "-o", str(f))
    assert r.returncode == 2, r.stderr
    assert "is a file; expected a folder path" in r.stderr
    assert f.read_text() == "x"


@pytest.mark.slow
@pytest.mark.parametrize(
    "args",
    [
        ["identify", "CAMP", "-o", "DIR"],
        ["identify", "CAMP", "-o", "DIR/m.csv", "--plots", "FILE"],
        ["plan", "-o", "FILE"],
        ["plan", "-o", "FILE/sub"],
        ["batch", "PATH", "--job", "JOB", "-o", "FILE"],
        ["compare", "PATH", "--job", "JOB", "-o", "FILE"],
        ["sld", "--modes", "MODES", "--teeth", "2", "--immersion", "0.5", "--rpm", "5000:6000",
         "--material", "Al7075-T6", "-o", "M/x.csv", "--plot", "DIR"],
        ["transfer", "MODES", "--robot", "B", "-o", "DIR"],
        ["train", "MODES", "-o", "FILE/m.npz"],
        ["predict", "B", "MODES", "-o", "DIR"],
        ["design-tests", "B", "--n", "20", "-o", "DIR"],
        ["diagnose", "CAMP", "--json", "DIR"],
        ["diagnose", "CAMP", "--json", "M/d.json", "--report", "FILE"],
        ["verify", "CAMP", "--robot", "B", "-o", "FILE"],
    ],
)  # fmt: skip
def test_cli_bad_outputs_refused_before_work(tmp_path: Path, args: list[str]) -> None:
    d = tmp_path / "d"
    d.mkdir()
    f = tmp_path / "file.txt"
    f.write_text("x")
    modes = tmp_path / "modes.csv"
    modes.write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,500,0.03,2e7\n")
    subst = {
        "DIR": str(d), "FILE": str(f), "CAMP": str(tmp_path / "camp"), "MODES": str(modes),
        "PATH": str(tmp_path / "p.nc"), "JOB": str(tmp_path / "j.toml"), "M": str(tmp_path),
    }  # fmt: skip

    def expand(arg: str) -> str:
        head, _, rest = arg.partition("/")
        return subst.get(head, head) + (f"/{rest}" if rest else "")

    argv = [expand(a) for a in args]
    r = _cli(*argv)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    assert any(o in r.stderr for o in ("--output", "--plot", "--json", "--report")), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d", "file.txt", "modes.csv"]
    assert f.read_text() == "x"


def test_plot_text_of_user_names() -> None:
    from robolobe._text import plot_text

    assert plot_text("r1") == "r1"
    assert plot_text("\x1b[31mred\n") == "\\x1b[31mred\\n"
    assert plot_text("cost$5$") == r"cost\$5\$"
    short = plot_text("a" * 10 + "b" * 300 + "c" * 10, 32)
    assert len(short) == 32
    assert short.startswith("aaaaaaaaaa")
    assert short.endswith("cccccccccc")
    assert "..." in short
