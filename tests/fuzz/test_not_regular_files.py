"""Inputs that are not regular files: a FIFO, a folder, a missing path (hypothesis names).

Opening a FIFO waits for a writer forever, so a reader that opens one before
checking hangs the command. Every input of every command, replaced by a
FIFO, a folder or nothing, must end at once in one line naming it and what
it is (``a named pipe``, ``a directory``, ``no such file``), exit code 2,
nothing written. A watchdog alarm turns a hang into a failure.
"""

from __future__ import annotations

import os
import shutil
import signal
from collections.abc import Iterator
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.cli.main import main

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))
FUZZ = settings(
    max_examples=3,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
HANG_S = 30

pytestmark = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")


@pytest.fixture
def watchdog() -> Iterator[None]:
    def hung(signum: int, frame: object) -> None:
        raise TimeoutError(f"the command hung for {HANG_S} s (opened a FIFO?)")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(HANG_S)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder of good inputs: a campaign (CSV), a modal dataset, modes, a plan."""
    from robolobe.campaign import write_campaign
    from robolobe.plan.job import load_job
    from robolobe.plan.pipeline import plan_path
    from robolobe.plan.report import write_outputs
    from robolobe.robots import load_robot
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.model import Twin

    root = tmp_path_factory.mktemp("inputs")
    q = np.radians([[0, 10, -20, 0, 20, 0], [30, 0, -30, 10, 30, 5], [-20, 20, -40, 0, 10, 0]])
    camp = simulate_campaign(
        Twin(load_robot("B")).receptance, "B", ["1", "2", "3"], q,
        rng=np.random.default_rng(0), exact=True, dirs=("xx", "yy"), fmax_hz=20.0,
    )  # fmt: skip
    write_campaign(root / "camp", camp, fmt="csv")
    (root / "modes.csv").write_text(
        "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,922,0.011,1.34e6\nyy,1,922,0.011,1.34e6\n"
    )
    res = plan_path(EX / "pocket.nc", load_job(EX / "job_A_pocket.toml"), refine=False)
    write_outputs(res, root / "plan", plots=False, html_report=False)
    shutil.copy(EX / "pocket.nc", root / "pocket.nc")
    shutil.copy(EX / "job_A_pocket.toml", root / "job.toml")
    (root / "post.csv").write_text(
        "posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\nP1,0,-60,90,0,30,0\n"
    )
    return root


#: (command with IN/... for inputs and OUT for the output, the input replaced).
CASES = [
    (["identify", "IN/camp", "-o", "OUT.csv"], "camp/frf.csv"),
    (["identify", "IN/camp", "-o", "OUT.csv"], "camp/postures.csv"),
    (["diagnose", "IN/camp", "--json", "OUT.json"], "camp/frf.csv"),
    (["sld", "--modes", "IN/modes.csv", "--teeth", "2", "--immersion", "0.5",
      "--rpm", "5000:9000:20", "--material", "Al7075-T6", "-o", "OUT.csv"], "modes.csv"),
    (["plan", "IN/pocket.nc", "--job", "IN/job.toml", "-o", "OUT", "--no-plots"], "job.toml"),
    (["verify", "IN/plan", "--robot", "A", "-o", "OUT"], "plan/summary.json"),
    (["verify", "IN/plan", "--robot", "A", "-o", "OUT"], "plan/waypoints.csv"),
    (["predict", "IN/model.npz", "IN/post.csv", "-o", "OUT.csv"], "model.npz"),
    (["predict", "A", "IN/post.csv", "-o", "OUT.csv"], "post.csv"),
    (["transfer", "IN/modal.csv", "--robot", "B", "-o", "OUT.npz"], "modal.csv"),
    (["simulate", "IN/robot.toml", "--design", "seed", "-o", "OUT"], "robot.toml"),
]  # fmt: skip


@pytest.mark.usefixtures("watchdog")
@pytest.mark.parametrize(("argv", "target"), CASES, ids=lambda v: v if isinstance(v, str) else v[0])
@pytest.mark.parametrize("kind", ["fifo", "folder", "missing"])
@FUZZ
@given(suffix=st.sampled_from(["", " x", "[bold]"]))
def test_input_that_is_not_a_regular_file(
    tmp_path: Path,
    inputs: Path,
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
    target: str,
    kind: str,
    suffix: str,
) -> None:
    root = tmp_path / f"in{suffix}"
    if root.exists():
        shutil.rmtree(root)
    shutil.copytree(inputs, root)
    victim = root / target
    if victim.exists():
        victim.unlink()
    if kind == "fifo":
        os.mkfifo(victim)
    elif kind == "folder":
        victim.mkdir()
    out = tmp_path / "out"
    args = [a.replace("IN", str(root), 1) if a.startswith("IN") else a for a in argv]
    args = [str(out) + a.removeprefix("OUT") if a.startswith("OUT") else a for a in args]
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(args)
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("warning:")]
    assert info.value.code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith("error: "), err
    assert victim.name in lines[0], err
    said = {"fifo": "named pipe", "folder": "directory", "missing": "no such"}[kind]
    if not (kind == "missing" and target.startswith("camp/")):  # "missing frf.csv" names it too
        assert said in lines[0], err
    assert not list(tmp_path.glob("out*")), "something was written"


#: Output options of a fast command, and how to build its argument list.
_SLD_MODES = "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,922,0.011,1.34e6\nyy,1,922,0.011,1.34e6\n"


@FUZZ
@given(
    option=st.sampled_from(["-o", "--plot"]),
    name=st.text(alphabet="abcxyz_.-", min_size=1, max_size=8).filter(lambda s: s not in ".."),
)
def test_an_output_onto_a_fifo_is_refused_and_the_node_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], watchdog: None, option: str, name: str
) -> None:
    """An output path that is a FIFO (or, as root, a device: never tried here) is refused.

    The output is renamed onto its path: that would replace the node itself
    (as root, ``-o /dev/null`` replaced the device with a regular file).
    """
    modes = tmp_path / "m.csv"
    modes.write_text(_SLD_MODES)
    node = tmp_path / f"node{name}"
    if node.exists():
        node.unlink()
    os.mkfifo(node)
    out = {"-o": str(tmp_path / "l.csv"), "--plot": str(tmp_path / "l.png"), option: str(node)}
    argv = ["sld", "--modes", str(modes), "--teeth", "2", "--immersion", "0.5",
            "--rpm", "5000:9000:20", "--material", "Al7075-T6",
            "-o", out["-o"], "--plot", out["--plot"]]  # fmt: skip
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    assert "named pipe" in err
    assert len([ln for ln in err.splitlines() if ln.strip()]) == 1, err
    assert node.is_fifo()
    assert not (tmp_path / "l.csv").exists()
    assert not (tmp_path / "l.png").exists()


def test_atomic_writers_refuse_a_fifo(tmp_path: Path) -> None:
    from robolobe._atomic import atomic_write_text
    from robolobe.errors import InputError

    node = tmp_path / "pipe"
    os.mkfifo(node)
    with pytest.raises(InputError, match="named pipe"):
        atomic_write_text(node, "x")
    assert node.is_fifo()
    assert [p.name for p in tmp_path.iterdir()] == ["pipe"]  # no temporary file left


@pytest.mark.parametrize("kind", ["fifo", "file", "missing"])
def test_a_campaign_that_is_not_a_folder_says_what_it_is(tmp_path: Path, kind: str) -> None:
    from robolobe.campaign import read_campaign
    from robolobe.errors import InputError

    p = tmp_path / "camp"
    if kind == "fifo":
        os.mkfifo(p)
    elif kind == "file":
        p.write_text("x")
    want = {"fifo": "a named pipe", "file": "a file", "missing": "no such folder"}[kind]
    with pytest.raises(InputError, match=f"expected a campaign folder, found {want}"):
        read_campaign(p)
