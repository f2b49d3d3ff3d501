"""Worker processes: the pool (results in order, progress counted) and the plot workers.

The plot workers (:class:`robolobe.plan._plots.PlotWorker`) must deliver the
PNGs drawn in-process, byte for byte, when they are ready, and must never
make a plan wait for them when they are not (a machine busy with other
programs, where a low-priority worker starves): then the figures are drawn
in-process at once.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import signal
import threading
import time
from collections.abc import Iterator

import pytest

from robolobe._workers import map_chunks
from robolobe.plan import _plots, report
from robolobe.plan._plots import PlotWorker
from robolobe.plan.job import load_job
from robolobe.plan.pipeline import plan_path

from .plan.conftest import example

#: Alone, after the parallel run: the plot workers' readiness has wall-clock limits and a
#: worker importing at nice 19 beside two busy test processes may never get the CPU.
pytestmark = pytest.mark.serial


def _affine(x: int, a: int = 1, b: int = 0) -> int:
    return a * x + b


@pytest.mark.slow
@pytest.mark.parametrize(("chunk", "parts"), [(3, None), (8, None), (1, 5), (1, 100)])
def test_map_chunks_keeps_the_order_over_workers(chunk, parts):
    items = list(range(23))
    fn = functools.partial(_affine, a=3, b=-2)
    seen: list[int] = []
    got = map_chunks(fn, items, 2, chunk=chunk, parts=parts, progress=seen.append)
    assert got == [3 * x - 2 for x in items]
    assert sum(seen) == len(items)


def test_map_chunks_in_process_below_four_items_or_one_job():
    seen: list[int] = []
    assert map_chunks(_affine, [5, 6, 7], 2, progress=seen.append) == [5, 6, 7]
    assert map_chunks(_affine, list(range(6)), 1) == list(range(6))
    assert seen == [1, 1, 1]


# ---------------------------------------------------------------- plot workers

#: Longest wait [s] for a worker at normal priority to import matplotlib, on a loaded
#: machine (a test fails, rather than hangs, when a worker never gets ready).
READY_S = 120.0


@pytest.fixture(scope="module")
def result():
    job = load_job(example("job_B_contour.toml")).replace(model="twin")
    return plan_path(example("contour.apt"), job, refine=False)


@pytest.fixture
def normal_priority(monkeypatch):
    """Workers at the caller's priority: ready in seconds however busy the test machine."""
    monkeypatch.setattr(_plots, "_import_priority_here", lambda: (0, None))


@pytest.fixture(scope="module")
def here(tmp_path_factory, result):
    """The PNGs drawn in this process (the reference)."""
    out = report.write_outputs(result, tmp_path_factory.mktemp("here") / "o", html_report=False)
    return {name: (out / "plots" / f"{name}.png").read_bytes() for name in report.PLOTS}


def _records(result):
    return {name: report._DATA[name](result) for name in report.PLOTS}


@pytest.fixture
def stopped() -> Iterator[list[int]]:
    """Pids to SIGSTOP in a test; killed at the end whatever happens."""
    pids: list[int] = []
    yield pids
    for pid in pids:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


def _in_thread(fn, limit_s: float):
    """``fn()`` in a daemon thread; (finished within ``limit_s``, result, seconds)."""
    box: dict[str, object] = {}

    def run() -> None:
        box["value"] = fn()

    t0 = time.monotonic()
    th = threading.Thread(target=run, daemon=True)
    th.start()
    th.join(limit_s)
    return not th.is_alive(), box.get("value"), time.monotonic() - t0


@pytest.mark.slow
def test_ready_plot_workers_draw_the_same_pngs_and_a_dead_one_falls_back(
    tmp_path, result, here, monkeypatch, normal_priority
):
    """Ready workers deliver the PNGs drawn in-process, byte for byte, and nothing is
    drawn here; a worker that died before drawing leaves the same files (drawn here)."""
    with PlotWorker(2) as worker:
        assert worker.ready(READY_S) == 2
        worker.send(_records(result))
        got = worker.receive()
    assert got is not None  # the workers delivered
    assert got == here
    with monkeypatch.context() as m, PlotWorker(2) as worker:
        assert worker.ready(READY_S) == 2
        # nothing may be drawn here when the workers deliver (their processes are not patched)
        m.setattr(_plots, "draw", lambda rec: pytest.fail("drawn in-process"))
        there = report.write_outputs(result, tmp_path / "there", html_report=False, worker=worker)
    dead = PlotWorker(processes=2)
    assert len(dead._procs) == 2
    dead._procs[1].kill()
    dead._procs[1].wait()
    fallback = report.write_outputs(result, tmp_path / "dead", html_report=False, worker=dead)
    for name in report.PLOTS:
        assert (there / "plots" / f"{name}.png").read_bytes() == here[name], name
        assert (fallback / "plots" / f"{name}.png").read_bytes() == here[name], name
    # the report shows the figures in PLOTS' order whoever drew them
    with PlotWorker(processes=2) as worker:
        worker.ready(READY_S)
        out = report.write_outputs(result, tmp_path / "html", worker=worker)
    html = (out / "report.html").read_text(encoding="utf-8")
    assert re.findall(r'<img alt="([a-z_]+)"', html) == list(report.PLOTS)


def test_starved_plot_workers_are_not_waited_for(tmp_path, result, here, stopped):
    """Workers that have had no CPU time (as at nice 19 beside busy programs; here they
    are stopped) are not ready when the plan is done: the figures are drawn in-process at
    once, the same PNGs, and the workers are killed. Before, the plan waited for them (at
    nice 19 beside two busy processes, a minute)."""
    worker = PlotWorker(processes=2)
    procs = list(worker._procs)
    assert len(procs) == 2
    for p in procs:
        os.kill(p.pid, signal.SIGSTOP)
        stopped.append(p.pid)
    assert worker.ready() == 0
    done, _, seconds = _in_thread(
        lambda: report.write_outputs(result, tmp_path / "o", html_report=False, worker=worker), 60
    )
    assert done, "write_outputs waited for workers that were not ready"
    assert [p.poll() for p in procs] == [-signal.SIGKILL] * 2  # stopped, not left behind
    assert seconds < 60
    for name in report.PLOTS:
        assert (tmp_path / "o" / "plots" / f"{name}.png").read_bytes() == here[name], name


@pytest.mark.slow
def test_only_the_ready_worker_draws(tmp_path, result, here, stopped, normal_priority):
    """One worker ready, one starved: the ready one draws every figure, the other is
    killed."""
    worker = PlotWorker(processes=2)
    slow, fast = worker._procs
    os.kill(slow.pid, signal.SIGSTOP)
    stopped.append(slow.pid)
    t0 = time.monotonic()
    while worker.ready() < 1 and time.monotonic() - t0 < READY_S:
        time.sleep(0.05)
    assert worker._ready == [fast]
    worker.send(_records(result))
    assert slow.poll() == -signal.SIGKILL
    got = worker.receive()
    assert got == here


@pytest.mark.slow
def test_a_plot_worker_that_does_not_deliver_in_time_is_stopped(
    tmp_path, result, here, monkeypatch, normal_priority
):
    """A ready worker that has not delivered by the time limit is killed and the figures
    are drawn in-process: the same files, nothing left running."""
    monkeypatch.setattr(_plots, "RECEIVE_TIMEOUT_S", 1e-6)
    worker = _plots.PlotWorker(2)
    assert worker.ready(READY_S) == 2
    procs = list(worker._procs)
    late = report.write_outputs(result, tmp_path / "late", html_report=False, worker=worker)
    # killed at the limit (a worker cannot have drawn four figures in 1 us)
    assert [p.poll() for p in procs] == [-signal.SIGKILL] * len(procs)
    for name in report.PLOTS:
        assert (late / "plots" / f"{name}.png").read_bytes() == here[name], name


def test_plot_worker_reports_a_drawing_error_as_a_failure(normal_priority):
    """A record a ready worker cannot draw makes receive() return None (the caller then
    draws in-process and raises the real error there), not a hang or a partial result."""
    with PlotWorker(2) as worker:
        assert worker.ready(READY_S) == 2
        worker.send({"bad": object()})
        assert worker._sent
        assert worker.receive() is None


@pytest.mark.parametrize(
    ("cores", "load", "expected"),
    [
        (2, 0.3, 2),  # quiet: the workers import on the idle core while the plan runs
        (2, 1.9, 2),
        (2, 2.0, 0),  # every core busy on average: a worker would not be ready in time
        (2, 4.2, 0),
        (1, 0.0, 0),  # one core: nothing to gain
        (16, 3.0, 2),
        (16, 40.0, 0),
        (2, float("nan"), 2),  # load unknown: as on a quiet machine
    ],
)
def test_plot_workers_started_only_where_they_can_be_ready(cores, load, expected):
    assert _plots._default_processes(cores, load) == expected


def test_a_busy_machine_starts_no_plot_worker(monkeypatch):
    monkeypatch.setattr(_plots, "_load", lambda: 9.5)
    monkeypatch.setattr(_plots, "_cores", lambda: 2)
    with PlotWorker() as worker:
        assert worker._procs == []
        worker.send({"x": object()})
        assert worker.receive() is None  # the caller draws in-process


@pytest.mark.parametrize(
    ("base", "euid", "rlimit", "cores", "expected"),
    [
        (0, 0, 0, 2, (19, True)),  # root: nice 19 while importing, then back
        (0, 1000, 20, 2, (19, True)),  # RLIMIT_NICE 20 allows niceness 0 again
        (0, 1000, 0, 2, (5, False)),  # may not go back: a bounded +5 for the whole run
        (16, 1000, 0, 2, (3, False)),  # never past 19
        (19, 1000, 0, 2, (0, False)),
        (0, 1000, 0, 8, (0, False)),  # cores to spare: normal priority
        (0, 0, 0, 1, (19, True)),
    ],
)
def test_plot_workers_import_priority(base, euid, rlimit, cores, expected):
    assert _plots._import_priority(base, euid, rlimit, cores) == expected


@pytest.mark.skipif(not hasattr(os, "getpriority"), reason="POSIX priorities")
def test_plot_worker_imports_at_low_priority_and_restores_it():
    """A worker runs at the lowered priority while it imports, then (where allowed) at
    the caller's again, and only then says it is ready."""
    increment, restore_to = _plots._import_priority_here()
    if increment == 0:
        pytest.skip("no lowered priority on this machine (more than two cores or nice 19)")
    base = os.getpriority(os.PRIO_PROCESS, 0)
    seen = []
    with PlotWorker(1) as worker:
        pid = worker._procs[0].pid
        t0 = time.monotonic()
        while time.monotonic() - t0 < READY_S:
            p = os.getpriority(os.PRIO_PROCESS, pid)
            if not seen or seen[-1] != p:
                seen.append(p)
            if worker.ready():
                break
            time.sleep(0.005)
        assert worker.ready() == 1, "not ready in time (a busy machine starves nice 19)"
        seen.append(os.getpriority(os.PRIO_PROCESS, pid))
        worker.send({})
        assert worker.receive() == {}
    assert base + increment in seen
    if restore_to is not None:
        assert seen[-1] == base  # restored before it said it was ready


@pytest.mark.skipif(not hasattr(os, "getpriority"), reason="POSIX priorities")
def test_an_unprivileged_plot_worker_stays_at_plus_5_and_delivers(result, here, monkeypatch):
    """Where the worker could not restore its priority it runs at +5 throughout and still
    delivers the figures drawn in-process."""
    base = os.getpriority(os.PRIO_PROCESS, 0)
    if base + 5 > 19:
        pytest.skip("already at the lowest priority")
    monkeypatch.setattr(_plots, "_import_priority_here", lambda: (5, None))
    records = {name: rec for name, rec in _records(result).items() if name == report.PLOTS[0]}
    with _plots.PlotWorker(1) as worker:
        pid = worker._procs[0].pid
        t0 = time.monotonic()
        while os.getpriority(os.PRIO_PROCESS, pid) != base + 5 and time.monotonic() - t0 < 30:
            time.sleep(0.005)
        assert os.getpriority(os.PRIO_PROCESS, pid) == base + 5
        assert worker.ready(READY_S) == 1
        worker.send(records)
        got = worker.receive()
    assert got is not None
    assert got[report.PLOTS[0]] == here[report.PLOTS[0]]


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="threads counted in /proc")
def test_a_plot_worker_starts_no_blas_threads(monkeypatch, normal_priority):
    """A worker draws on one thread: numpy's BLAS starts no thread pool there (about
    0.1 s of CPU per worker), whatever the caller's environment asks for."""
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "4")
    monkeypatch.setenv("OMP_NUM_THREADS", "4")
    with PlotWorker(1) as worker:
        assert worker.ready(READY_S) == 1  # numpy and matplotlib imported
        pid = worker._procs[0].pid
        assert len(os.listdir(f"/proc/{pid}/task")) == 1
        worker.send({})
        assert worker.receive() == {}
