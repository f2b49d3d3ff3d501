"""A run that cannot finish (a full disk, SIGTERM) leaves nothing new and no worker behind.

* full disk: whichever output of a command fails, the
  command ends in one line naming that output's option, exit code 2, and
  the outputs this run created before it are gone;
* SIGTERM: the command exits 143 at once, its worker processes end with it
  and no temporary file stays.
"""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
FUZZ = settings(
    max_examples=4,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


def _full_disk(*args: object, **kwargs: object) -> None:
    raise OSError(errno.ENOSPC, "No space left on device")


@pytest.fixture(scope="module")
def modes_csv(tmp_path_factory: pytest.TempPathFactory) -> Path:
    p = tmp_path_factory.mktemp("m") / "modes.csv"
    p.write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,922,0.011,1.34e6\nyy,1,922,0.011,1.34e6\n")
    return p


@pytest.mark.parametrize("failing", ["csv", "plot"])
def test_sld_full_disk_leaves_nothing(
    tmp_path: Path,
    modes_csv: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    failing: str,
) -> None:
    import robolobe.sld.io
    import robolobe.sld.plot

    target = {
        "csv": (robolobe.sld.io, "write_lobes_csv"),
        "plot": (robolobe.sld.plot, "save_lobe_plot"),
    }
    monkeypatch.setattr(*target[failing], _full_disk)
    out = tmp_path / f"o{failing}"
    argv = ["sld", "--modes", str(modes_csv), "--teeth", "2", "--immersion", "0.5",
            "--rpm", "5000:9000:20", "--material", "Al7075-T6",
            "-o", str(out / "l.csv"), "--plot", str(out / "l.png")]  # fmt: skip
    out.mkdir()
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    option = "--output" if failing == "csv" else "--plot"
    assert lines[0].startswith(f"error: {option}: cannot write"), err
    assert "No space left" in lines[0]
    assert list(out.iterdir()) == [], "an output of the failed run stayed"


@pytest.fixture(scope="module")
def small_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from robolobe.campaign import write_campaign
    from robolobe.robots import load_robot
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.model import Twin

    q = np.radians([[0, 10, -20, 0, 20, 0], [30, 0, -30, 10, 30, 5], [-20, 20, -40, 0, 10, 0]])
    camp = simulate_campaign(
        Twin(load_robot("B")).receptance, "B", ["1", "2", "3"], q,
        rng=np.random.default_rng(0), exact=False, dirs=("xx", "yy"), fmax_hz=40.0,
    )  # fmt: skip
    out = tmp_path_factory.mktemp("camp") / "camp"
    write_campaign(out, camp, fmt="csv")
    return out


@pytest.mark.slow
@pytest.mark.parametrize("failing", ["report", "updated-model"])
def test_diagnose_full_disk_leaves_no_json(
    tmp_path: Path,
    small_campaign: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    failing: str,
) -> None:
    import robolobe.diagnose.report
    import robolobe.diagnose.updated_model

    module, name = {
        "report": (robolobe.diagnose.report, "write_report"),
        "updated-model": (robolobe.diagnose.updated_model, "write_updated_model"),
    }[failing]
    monkeypatch.setattr(module, name, _full_disk)
    argv = ["diagnose", str(small_campaign), "--candidates", "none", "--folds", "2",
            "--json", str(tmp_path / "d.json"), "--report", str(tmp_path / "r"),
            "--updated-model", str(tmp_path / "u")]  # fmt: skip
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    assert f"error: --{failing}: cannot write" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == [], "d.json or the report stayed"


def _descendants(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-eo", "pid=,ppid="], capture_output=True, text=True).stdout
    children: dict[int, list[int]] = {}
    for line in out.splitlines():
        p, pp = (int(v) for v in line.split())
        children.setdefault(pp, []).append(p)
    found, todo = [], [pid]
    while todo:
        for c in children.get(todo.pop(), []):
            found.append(c)
            todo.append(c)
    return found


@pytest.mark.slow
@pytest.mark.serial  # wall-clock limits: the pool up within 60 s, its workers gone 3 s after
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigterm_stops_the_workers_and_leaves_no_temporary(tmp_path: Path) -> None:
    from robolobe.cli.main import main as _

    camp = tmp_path / "camp"
    subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", "simulate", "B", "--design", "random",
         "--n", "16", "-o", str(camp)],
        check=True, capture_output=True, env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )  # fmt: skip
    out = tmp_path / "modal.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "robolobe.cli.main", "identify", str(camp), "-o", str(out),
         "--jobs", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT / "src")},
    )  # fmt: skip
    try:
        t0 = time.monotonic()
        while len(_descendants(proc.pid)) < 2 and time.monotonic() - t0 < 60:
            time.sleep(0.2)  # the worker pool is up
        workers = _descendants(proc.pid)
        assert workers, "no worker started"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
        assert proc.returncode == 143, err
        assert "Traceback" not in err
        time.sleep(3)
        alive = [p for p in workers if Path(f"/proc/{p}").exists()]
        assert not alive, f"workers still running 3 s after SIGTERM: {alive}"
        assert not out.exists()
        assert not [p.name for p in tmp_path.iterdir() if "tmp" in p.name.lower()]
    finally:
        if proc.poll() is None:
            proc.kill()


#: How writers report a disk without room: with errno (Python's own files) or
#: with the number only in the text (pyarrow's "Error writing bytes to file").
def _refusal(kind: str, code: int) -> OSError:
    if kind == "errno":
        return OSError(code, os.strerror(code))
    return OSError(f"Error writing bytes to file. Detail: [errno {code}] {os.strerror(code)}")


@FUZZ
@given(
    kind=st.sampled_from(["errno", "text"]),
    code=st.sampled_from([errno.ENOSPC, errno.EFBIG, errno.EDQUOT]),
    folder=st.booleans(),
)
def test_a_full_disk_names_the_output(tmp_path: Path, kind: str, code: int, folder: bool) -> None:
    """Whichever writer fails for want of room, the one line names the output; nothing stays."""
    from robolobe._atomic import atomic_dir, atomic_path
    from robolobe.errors import InputError

    out = tmp_path / f"out{kind}{code}{folder}"

    def write() -> None:
        if folder:
            with atomic_dir(out, "plan", option="--output") as tmp:
                (tmp / "waypoints.csv").write_text("x")
                raise _refusal(kind, code)
        with atomic_path(out) as tmp:
            tmp.write_text("x")
            raise _refusal(kind, code)

    with pytest.raises((InputError, OSError)) as info:
        write()
    exc = info.value
    if folder:  # the folder's option is known: one line naming it and the output
        assert isinstance(exc, InputError)
        assert str(exc).startswith(f"--output: cannot write {out}: {os.strerror(code)}")
        assert "\n" not in str(exc)
    else:  # the caller names its option; the error carries errno and the file
        assert not isinstance(exc, InputError)
        assert exc.errno == code
        assert exc.filename == str(out)
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []


def test_other_os_errors_pass_through(tmp_path: Path) -> None:
    from robolobe._atomic import atomic_path

    with pytest.raises(PermissionError), atomic_path(tmp_path / "x") as _:
        raise PermissionError(errno.EACCES, "denied")
    assert list(tmp_path.iterdir()) == []


def test_a_real_file_size_limit_names_the_option(tmp_path: Path, modes_csv: Path) -> None:
    """``RLIMIT_FSIZE`` (a full disk as the kernel says it): one line naming the option."""
    import resource

    out = tmp_path / "o"
    out.mkdir()
    argv = [sys.executable, "-m", "robolobe", "sld", "--modes", str(modes_csv), "--teeth", "2",
            "--immersion", "0.5", "--rpm", "5000:9000:200", "--material", "Al7075-T6",
            "-o", str(out / "l.csv")]  # fmt: skip

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (1024, 1024))
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)

    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
    r = subprocess.run(argv, capture_output=True, text=True, timeout=120, preexec_fn=limit, env=env)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2, r.stderr
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith(f"error: --output: cannot write {out / 'l.csv'}: File too large")
    assert list(out.iterdir()) == []
