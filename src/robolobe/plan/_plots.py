"""The plan's four plots, drawn from plain data, in this process or in a worker process.

:mod:`robolobe.plan.report` turns a plan into the small data records below
(what each figure shows, nothing more) and draws them here. The records hold
numpy arrays, numbers and strings only, and this module imports neither
pandas nor the pipeline, so a worker process (:class:`PlotWorker`) can draw
them: it is started before planning, imports matplotlib (about 0.3 s) while
the plan is computed, and draws while the plan's tables are written, on the
second core. A worker that has not finished importing by then (the machine
had no idle core for it) is dropped and the figures are drawn in-process.
The PNG bytes are the same in either process.
"""

from __future__ import annotations

import contextlib
import io
import os
import pickle
import select
import subprocess
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = [
    "LobesData",
    "PathMarginData",
    "PlotWorker",
    "SpeedMapData",
    "SpeedPowerData",
    "draw",
    "png",
]


@dataclass(frozen=True, eq=False)
class LobesData:
    """What the lobes figure shows.

    Attributes
    ----------
    rpm : ndarray, shape (n_rpm,)
        Speed grid [rpm].
    curves_mm : ndarray, shape (k, n_rpm)
        Limiting depth of each shown waypoint [mm].
    labels : tuple of str, length k
    dot_rpm : ndarray, shape (k,)
        Planned speed at each shown waypoint [rpm].
    depth_mm, safety_factor, top_mm : float
        Planned depth [mm], safety factor, top of the depth axis [mm].
    """

    rpm: FloatArray
    curves_mm: FloatArray
    labels: tuple[str, ...]
    dot_rpm: FloatArray
    depth_mm: float
    safety_factor: float
    top_mm: float


@dataclass(frozen=True, eq=False)
class SpeedMapData:
    """What the stability map shows.

    Attributes
    ----------
    rows : ndarray of int, shape (r,)
        Cutting waypoints drawn (every ``step``-th).
    z : ndarray, shape (r, n_rpm)
        ``log2(a_lim / (SF depth))`` clipped to [-2, 2].
    rpm_lo, rpm_hi : float
        Ends of the speed grid [rpm].
    planned_rpm : ndarray, shape (n_cut,)
    constant_rpm : float or None
        The best constant speed [rpm].
    depth_mm : float
    """

    rows: IntArray
    z: FloatArray
    rpm_lo: float
    rpm_hi: float
    planned_rpm: FloatArray
    constant_rpm: float | None
    depth_mm: float


@dataclass(frozen=True, eq=False)
class PathMarginData:
    """What the path figure shows.

    Attributes
    ----------
    x_mm, y_mm, margin : ndarray, shape (n,)
        Every waypoint in the workpiece frame and its margin (NaN: not cutting).
    tightest : int
        Row of the tightest waypoint.
    safety_factor : float
    """

    x_mm: FloatArray
    y_mm: FloatArray
    margin: FloatArray
    tightest: int
    safety_factor: float


@dataclass(frozen=True, eq=False)
class SpeedPowerData:
    """What the speed and power figure shows.

    Attributes
    ----------
    s_mm : ndarray, shape (n_cut,)
        Cutting length [mm].
    rpm : ndarray, shape (n_cut,)
        Planned speed [rpm]; ``constant_rpm`` and ``programmed_rpm`` the
        comparison plans' (None where absent).
    method : str
    power_kW : ndarray, shape (n_cut,)
    power_limit_kW : float
    """

    s_mm: FloatArray
    rpm: FloatArray
    method: str
    constant_rpm: FloatArray | None
    programmed_rpm: FloatArray | None
    power_kW: FloatArray
    power_limit_kW: float


def png(fig: Figure) -> bytes:
    """The figure as PNG bytes (110 dpi, Agg)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def margins(
    fig: Figure,
    *,
    left: float,
    right: float = 0.981,
    bottom: float = 0.122,
    top: float = 0.924,
    hspace: float | None = None,
) -> None:
    """Fixed margins (figure fractions) where ``tight_layout`` would measure every label.

    The values are what ``tight_layout`` chose on the bundled plans, with room
    for five-digit tick labels; measuring them cost about 40 % of a plot.
    """
    fig.subplots_adjust(left=left, right=right, bottom=bottom, top=top, hspace=hspace)


def runs(x: FloatArray, y: FloatArray, cls: IntArray) -> tuple[list[FloatArray], IntArray]:
    """Polylines through consecutive moves of one class: the moves ``i -> i + 1`` of
    class ``cls[i]`` (-1: not drawn) joined while the class stays the same.

    Returns each run's (k, 2) vertices and its class.
    """
    if cls.size == 0:
        return [], np.zeros(0, np.int64)
    cut = np.flatnonzero(np.diff(cls)) + 1
    starts = np.r_[0, cut]
    stops = np.r_[cut, cls.size]
    keep = cls[starts] >= 0
    xy = np.column_stack([x, y])
    lines = [xy[a : b + 1] for a, b in zip(starts[keep], stops[keep], strict=True)]
    return lines, cls[starts[keep]]


def margin_classes(margin: FloatArray, bounds: list[float]) -> IntArray:
    """Colour class of each margin as ``BoundaryNorm(bounds)`` bins it (-1: NaN, not drawn).

    ``len(bounds) - 1`` is the 'over' class (at or above the last bound).
    """
    m = np.asarray(margin, dtype=np.float64)
    fin = np.isfinite(m)
    cls = np.maximum(np.searchsorted(bounds, np.where(fin, m, 0.0), side="right") - 1, 0)
    return np.where(fin, cls, -1).astype(np.int64)


def draw_lobes(d: LobesData) -> Figure:
    """Lobes of the tightest distinct waypoints, each with its operating point."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 4.8))
    ax = fig.add_subplot()
    for row, label, rpm in zip(d.curves_mm, d.labels, d.dot_rpm, strict=True):
        (line,) = ax.plot(d.rpm, row, lw=1.3, label=label, zorder=2)
        ax.plot([rpm], [d.depth_mm], "o", ms=9, mfc=line.get_color(), mec="k", mew=1.2, zorder=4)
    ax.axhline(d.depth_mm, color="k", lw=1.0, ls="--", label=f"planned depth {d.depth_mm:.3g} mm")
    ax.axhline(
        d.depth_mm * d.safety_factor,
        color="k",
        lw=0.8,
        ls=":",
        label=f"depth x safety factor {d.safety_factor:g}",
    )
    ax.set_ylim(0, d.top_mm)
    pad = 0.015 * (d.rpm[-1] - d.rpm[0])
    ax.set_xlim(d.rpm[0] - pad, d.rpm[-1] + pad)
    ax.set_xlabel("spindle speed [rpm]")
    ax.set_ylabel("limiting depth a_lim [mm]")
    ax.set_title("Stability lobes at the tightest waypoints (dots: planned speed and depth)")
    ax.legend(fontsize=8, loc="upper left", framealpha=0.9)
    margins(fig, left=0.09)
    return fig


def draw_speed_map(d: SpeedMapData) -> Figure:
    """Waypoint x speed map of ``a_lim / (SF depth)`` (log2) with the planned speeds."""
    from matplotlib.colors import TwoSlopeNorm
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 4.8))
    ax = fig.add_subplot()
    im = ax.imshow(
        d.z.T,
        origin="lower",
        aspect="auto",
        extent=(d.rows[0] - 0.5, d.rows[-1] + 0.5, d.rpm_lo, d.rpm_hi),
        cmap="RdYlGn",
        norm=TwoSlopeNorm(vcenter=0.0, vmin=-2.0, vmax=2.0),
        interpolation="nearest",
    )
    ax.plot(np.arange(d.planned_rpm.size), d.planned_rpm, color="k", lw=1.2, label="planned speed")
    if d.constant_rpm is not None:
        ax.axhline(d.constant_rpm, color="b", lw=0.8, ls="--", label="best constant")
    cb = fig.colorbar(im, ax=ax)
    cb.set_label("log2( a_lim / (SF x depth) ): > 0 stable")
    ax.set_xlabel("cutting waypoint")
    ax.set_ylabel("spindle speed [rpm]")
    ax.set_title(f"Stability map at depth {d.depth_mm:.3g} mm")
    ax.legend(fontsize=7, loc="upper right")
    margins(fig, left=0.115)
    return fig


def draw_path_margin(d: PathMarginData) -> Figure:
    """Top view (x-y, workpiece frame) of the path, cutting moves coloured by margin."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.collections import LineCollection
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.figure import Figure

    sf = d.safety_factor
    x, y = d.x_mm, d.y_mm
    fig = Figure(figsize=(8, 5.5))
    ax = fig.add_subplot()
    ax.plot(x, y, color="0.75", lw=0.6, ls="--", zorder=1, label="rapid / non-cutting")
    # A move ends at its row: segment i-1 -> i carries row i's margin.
    # Classes an engineer reads at a glance: below the safety factor (the
    # plan's own limit) is red, at it orange, then more and more spare depth.
    bounds = [0.0, 1.0, sf, 1.1 * sf, 1.5 * sf, 2.0 * sf, 4.0 * sf]
    colors = ["#8b0000", "#e34a33", "#fdae61", "#fee08b", "#a6d96a", "#1a9850"]
    cmap = ListedColormap(colors).with_extremes(over="#006837")
    norm = BoundaryNorm(bounds, cmap.N)
    # the class of each move (its colour), consecutive moves of a class drawn as one
    # line: the same picture as one segment per move, without a path object per move
    lines, run_cls = runs(x, y, margin_classes(d.margin[1:], bounds))
    lc = LineCollection(lines, colors=[cmap(c) for c in run_cls], linewidths=2.4, zorder=2)
    ax.add_collection(lc)
    k = d.tightest
    ax.plot(x[k], y[k], "kx", ms=10, mew=2, zorder=3, label="tightest waypoint")
    cb = fig.colorbar(
        ScalarMappable(norm=norm, cmap=cmap), ax=ax, extend="max", ticks=bounds, spacing="uniform"
    )
    cb.ax.set_yticklabels(["0", "1 (chatter)", f"{sf:g} (SF)", *(f"{b:.2f}" for b in bounds[3:])])
    cb.set_label("margin = limiting depth / planned depth")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("Path (top view) coloured by stability margin")
    ax.legend(fontsize=8, loc="best")
    margins(fig, left=0.1, right=0.945, bottom=0.106, top=0.934)
    return fig


def draw_speed_power(d: SpeedPowerData) -> Figure:
    """Speed and cutting power along the cutting length."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 5))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(d.s_mm, d.rpm, "k", lw=1.2, label=f"plan ({d.method})")
    if d.constant_rpm is not None:
        ax1.plot(d.s_mm, d.constant_rpm, "b--", lw=0.8, label="best constant")
    if d.programmed_rpm is not None:
        ax1.plot(d.s_mm, d.programmed_rpm, "r:", lw=0.8, label="programmed")
    ax1.set_ylabel("speed [rpm]")
    ax1.legend(fontsize=7)
    ax2.plot(d.s_mm, d.power_kW, "k", lw=1.2)
    ax2.axhline(d.power_limit_kW, color="r", lw=0.8, ls="--", label="power limit")
    ax2.set_ylabel("cutting power [kW]")
    ax2.set_xlabel("cutting length along the path [mm]")
    ax2.legend(fontsize=7)
    ax1.set_title("Spindle speed and cutting power along the path")
    margins(fig, left=0.115, bottom=0.117, top=0.927, hspace=0.11)
    return fig


def draw(data: LobesData | SpeedMapData | PathMarginData | SpeedPowerData) -> Figure:
    """The figure of a plot record (by its type)."""
    if isinstance(data, LobesData):
        return draw_lobes(data)
    if isinstance(data, SpeedMapData):
        return draw_speed_map(data)
    if isinstance(data, PathMarginData):
        return draw_path_margin(data)
    return draw_speed_power(data)


#: Longest wait [s] for a worker's PNGs: a worker that has not delivered by then is
#: taken for hung (drawing four figures takes well under a second on 10k waypoints).
RECEIVE_TIMEOUT_S = 300.0

#: Relative drawing cost of each record type (measured on a 10k-waypoint plan), used to
#: share the figures between worker processes.
_COST = {LobesData: 0.8, SpeedMapData: 1.3, PathMarginData: 0.9, SpeedPowerData: 0.9}


class PlotWorker:
    """Processes that draw plots beside the planning process.

    Started before planning: each imports matplotlib (about 0.3 s of CPU)
    while the plan is computed; :meth:`send` shares the plot records between
    the processes that are ready by then and :meth:`receive` returns the
    PNGs. Any failure (a process could not start, died, raised, or none was
    ready) makes :meth:`receive` return None, and the caller draws in its own
    process instead, which gives the same PNGs or raises the real error. Use
    as a context manager, or call :meth:`close`.

    The workers import at a lower CPU priority (:func:`_import_priority`), so
    that on two cores they take only the time the plan leaves idle instead of
    slowing its two-thread kernels: nice 19 where the worker may restore its
    priority before drawing (root, ``CAP_SYS_NICE`` or a permissive
    ``RLIMIT_NICE``), otherwise +5 for the whole run (bounded). A worker says
    when it is ready (imported, priority restored); one that is not ready when
    the records are sent is stopped. So on a quiet machine the figures are
    drawn on the idle core, and on a machine busy with other programs, where
    a worker at nice 19 would starve (about 1/70 of a core beside one busy
    process), they are drawn in-process, at the caller's fair share, without
    the workers' extra imports.

    Parameters
    ----------
    processes : int, optional
        Worker processes; default 2, each drawing about half of the figures,
        none on a one-core machine or one already busy (load average at least
        the cores: :func:`_default_processes`); with none :meth:`receive`
        returns None and the caller draws. Measured on the 10k-waypoint
        benchmark plan (2 cores, quiet): one worker at normal priority
        1.71-1.98 s end to end, two at nice 19 1.54-1.60 s, two at +5
        1.66-1.68 s, two at normal priority 1.81-2.02 s (their start-up
        slows the plan). For the bundled plan beside busy processes see
        ``benchmarks/bench_load.py``.
    """

    def __init__(self, processes: int | None = None) -> None:
        if processes is None:
            processes = _default_processes(_cores(), _load())
        # the same robolobe as this process, whatever the worker's sys.path
        root = str(Path(__file__).resolve().parents[2])
        increment, restore_to = _import_priority_here()
        # the lower priority first: importing numpy and robolobe is part of the start-up
        code = (
            f"import os; os.nice({increment}); import sys; sys.path.insert(0, {root!r}); "
            f"from robolobe.plan._plots import _serve; _serve({restore_to!r})"
        )
        self._procs: list[subprocess.Popen[bytes]] = []
        self._ready: list[subprocess.Popen[bytes]] = []  # imported, priority restored
        self._sent = False
        if not sys.executable:  # embedded interpreters: draw in-process
            return
        try:
            for _ in range(int(processes)):
                self._procs.append(
                    subprocess.Popen(
                        [sys.executable, "-c", code],
                        stdin=subprocess.PIPE,
                        stdout=subprocess.PIPE,
                        stderr=subprocess.DEVNULL,
                        bufsize=0,  # unbuffered: nothing left to flush into a dead one's pipe
                        env=_worker_env(os.environ),
                    )
                )
        except OSError:
            self.close()

    def ready(self, timeout: float = 0.0) -> int:
        """Wait up to ``timeout`` seconds for the workers to be ready; how many are.

        A worker is ready once it has imported matplotlib and restored its
        priority (it writes one byte, ``R``, to its stdout then).
        """
        deadline = time.monotonic() + timeout
        while True:
            waiting = {
                p.stdout: p for p in self._procs if p not in self._ready and p.stdout is not None
            }
            if not waiting:
                break
            left = max(0.0, deadline - time.monotonic())
            if os.name == "posix":
                readable, _, _ = select.select(list(waiting), [], [], left)
            else:  # no select() on pipes: wait for each (the time limit does not apply)
                readable = list(waiting)
            for pipe in readable:
                proc = waiting[pipe]
                if pipe.read(1) == b"R":
                    self._ready.append(proc)
                else:  # died before it was ready
                    self._procs.remove(proc)
                    _stop(proc)
            if time.monotonic() >= deadline:
                break
        return len(self._ready)

    def send(self, records: dict[str, Any]) -> None:
        """Share the plot records between the ready processes (returns once they have read them).

        The processes not ready yet are stopped (the machine had no idle core
        for them); with none ready, nothing is sent and :meth:`receive`
        returns None.

        Parameters
        ----------
        records : dict of str to plot record
            :class:`LobesData`, :class:`SpeedMapData`, ... by plot name.
        """
        self.ready()
        for proc in self._procs:
            if proc not in self._ready:
                _stop(proc)
        self._procs = list(self._ready)
        if not self._procs:
            return
        # longest first onto the least loaded process
        shares: list[dict[str, Any]] = [{} for _ in self._procs]
        load = [0.0] * len(self._procs)
        for name in sorted(records, key=lambda k: -_COST.get(type(records[k]), 1.0)):
            i = load.index(min(load))
            shares[i][name] = records[name]
            load[i] += _COST.get(type(records[name]), 1.0)
        try:
            for proc, share in zip(self._procs, shares, strict=True):
                assert proc.stdin is not None
                data = memoryview(pickle.dumps(share, protocol=pickle.HIGHEST_PROTOCOL))
                while data:
                    data = data[proc.stdin.write(data) or 0 :]
                proc.stdin.close()
                proc.stdin = None  # closed: communicate() in receive() must not flush it
        except OSError:  # a process died: receive() says so
            self.close()
            return
        self._sent = True

    def receive(self) -> dict[str, bytes] | None:
        """PNG bytes per name of the records sent; None if a process failed."""
        procs, self._procs, self._ready = self._procs, [], []
        if not procs or not self._sent:
            for proc in procs:
                _stop(proc)
            return None
        images: dict[str, bytes] = {}
        try:
            for proc in procs:
                out, _ = proc.communicate(timeout=RECEIVE_TIMEOUT_S)
                status, got = pickle.loads(out)
                if proc.returncode != 0 or status != "ok":
                    raise RuntimeError(got)
                images.update(got)
        except Exception:  # a dead, hung or broken worker: the caller draws in-process
            for proc in procs:
                _stop(proc)
            return None
        return images

    def close(self) -> None:
        """Stop the processes that have not delivered."""
        procs, self._procs, self._ready = self._procs, [], []
        for proc in procs:
            _stop(proc)

    def __enter__(self) -> PlotWorker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


#: Thread-pool sizes of the BLAS libraries numpy may load, set to one in a worker: drawing
#: uses no BLAS threads, and starting them costs about 0.1 s of CPU per worker (measured with
#: numpy's OpenBLAS on 2 cores: import of numpy and matplotlib 0.51 s of CPU, 0.41 s with one).
_ONE_THREAD = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def _worker_env(env: Mapping[str, str]) -> dict[str, str]:
    """A plot worker's environment: ``env`` with one BLAS thread (:data:`_ONE_THREAD`)."""
    return {**env, **dict.fromkeys(_ONE_THREAD, "1")}


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """Kill a worker and close its pipes (a write still buffered for a dead one is dropped)."""
    if proc.poll() is None:
        proc.kill()
    for pipe in (proc.stdin, proc.stdout):
        if pipe is not None:
            with contextlib.suppress(OSError):
                pipe.close()
    proc.wait()


def _default_processes(cores: int, load: float) -> int:
    """Plot workers to start: 2 on two or more cores, none where none would be ready.

    Parameters
    ----------
    cores : int
        CPUs this process may run on.
    load : float
        The machine's one-minute load average (runnable processes; NaN: unknown).

    Returns
    -------
    int
        0 on one core, and on a machine whose load average is at least its
        cores: other programs keep every core busy, so a worker importing at
        low priority would not be ready when the plan is done (it would be
        stopped then, its start-up wasted). Measured with
        ``benchmarks/bench_load.py``: beside two busy processes the figures
        drawn in-process cost the same as with workers that are never ready.
    """
    if cores < 2 or load >= cores:
        return 0
    return 2


def _load() -> float:
    """The one-minute load average (NaN where the system has none)."""
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):
        return float("nan")


def _cores() -> int:
    """CPUs this process may run on (its affinity mask where the system has one)."""
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return os.cpu_count() or 1


def _import_priority(base: int, euid: int, rlimit_nice: int, cores: int | None) -> tuple[int, bool]:
    """Niceness increment while a worker imports, and whether it restores ``base`` after.

    Parameters
    ----------
    base : int
        The worker's niceness at start (its parent's).
    euid : int
        Effective user id (0: may lower its niceness).
    rlimit_nice : int
        Soft ``RLIMIT_NICE``: an unprivileged process may set a niceness down
        to ``20 - rlimit_nice``.
    cores : int or None
        CPUs this process may run on.

    Returns
    -------
    increment : int
        0 on more than two cores (the plan leaves cores idle anyway).
    restore : bool
        Whether the worker sets its niceness back to ``base`` before drawing.
    """
    if (cores or 1) > 2:
        return 0, False
    if euid == 0 or 20 - rlimit_nice <= base:
        return 19 - base, True
    return max(0, min(5, 19 - base)), False


def _import_priority_here() -> tuple[int, int | None]:
    """:func:`_import_priority` for this process: (increment, niceness to restore or None)."""
    if not hasattr(os, "getpriority"):  # not a POSIX system: normal priority
        return 0, None
    import resource

    base = os.getpriority(os.PRIO_PROCESS, 0)
    increment, restore = _import_priority(
        base, os.geteuid(), resource.getrlimit(resource.RLIMIT_NICE)[0], _cores()
    )
    return increment, (base if restore and increment else None)


def _serve(restore_to: int | None = None) -> None:
    """The worker's loop: import matplotlib, read the records, write the PNGs.

    Parameters
    ----------
    restore_to : int, optional
        Niceness to set once matplotlib is imported (the caller's).
    """
    import matplotlib.backends.backend_agg  # the costly imports, before the data
    import matplotlib.figure  # noqa: F401

    if restore_to is not None:
        with contextlib.suppress(OSError):  # drawing at the low priority is still right
            os.setpriority(os.PRIO_PROCESS, 0, restore_to)
    sys.stdout.buffer.write(b"R")  # ready: the caller sends the records to ready workers only
    sys.stdout.buffer.flush()

    try:
        records = pickle.load(sys.stdin.buffer)
        result: tuple[str, Any] = ("ok", {k: png(draw(v)) for k, v in records.items()})
    except Exception as exc:  # reported; the caller redraws in-process and raises there
        result = ("error", repr(exc))
    sys.stdout.buffer.write(pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))
    sys.stdout.buffer.flush()
    # the caller waits for the exit: skip the interpreter's teardown of matplotlib & co.
    # (about 0.07 s); nothing is left to flush or clean up
    os._exit(0)
