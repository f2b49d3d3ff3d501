"""The bundled plan on a busy machine: with and without plots, quiet and beside busy processes.

    python benchmarks/bench_load.py                  # quiet, then beside 2 busy processes
    python benchmarks/bench_load.py --busy 2 --reps 5
    python benchmarks/bench_load.py --busy 0         # as the machine is, only

Runs ``robolobe plan`` on the bundled pocket as a user would (a fresh
process each time, the same robolobe as this script imports) in three
variants, one after another in each round so that they see the same load
(each round starts with another variant):

- ``plots``: the default, plots and report (drawn by the plot workers where
  they are ready when the plan is done; in-process on a machine whose load
  average is at least its cores, where no worker is started);
- ``in-process``: plots and report drawn in the planning process (the plot
  workers off, as on a one-core machine);
- ``no plots``: ``--no-plots --no-html``.

The runs use current bytecode, as an installed robolobe has (pip compiles
it): they cache it in a temporary folder (``PYTHONPYCACHEPREFIX``), filled by
a warm-up run of each variant, whatever ``PYTHONDONTWRITEBYTECODE`` says. A
checkout whose ``__pycache__`` is stale would otherwise compile the changed
modules in every run (0.1 s and more; Python does not rewrite the cache where
``PYTHONDONTWRITEBYTECODE`` is set).

It does so first as the machine is ("quiet"), then beside ``--busy`` CPU-bound
child processes it starts itself for that phase and kills at its end (also
on an error or Ctrl-C). It prints each run's wall and CPU time (the plan's
process and its plot workers), the medians with their ratios to ``no plots``
(the CPU ratio hardly moves with the load, the wall ratio does), the load
average at the start and end of each phase, and a note when the machine was
already busy before its own busy processes (the goals are for an otherwise
quiet machine).

Goals (issue 28): beside two busy processes on 2 cores, the plan with plots
and report within 2x the same plan without them and under 15 s; on a quiet
machine, the bundled ``robolobe plan`` under 2 s. The seconds are the
machine's; compare the ratios within one run.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import robolobe

#: The variants: (label, extra CLI arguments, plot workers off).
VARIANTS: tuple[tuple[str, tuple[str, ...], bool], ...] = (
    ("plots", (), False),
    ("in-process", (), True),
    ("no plots", ("--no-plots", "--no-html"), False),
)

#: Runs the robolobe command; with "off" the plot workers are off (the one-core path).
_RUNNER = (
    "import sys\n"
    "if sys.argv[1] == 'off':\n"
    "    from robolobe.plan import _plots\n"
    "    _plots._cores = lambda: 1\n"
    "sys.argv = ['robolobe', *sys.argv[2:]]\n"
    "from robolobe.cli.main import main\n"
    "main()\n"
)


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"load {one:.1f}/{five:.1f}"


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


@contextlib.contextmanager
def busy_processes(n: int) -> Iterator[list[subprocess.Popen[bytes]]]:
    """``n`` CPU-bound child processes for the duration of the block, killed at its end."""
    procs: list[subprocess.Popen[bytes]] = []
    try:
        for _ in range(n):
            procs.append(subprocess.Popen([sys.executable, "-c", "while True: pass"]))
        yield procs
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


def run_plan(
    out: Path, extra: tuple[str, ...], workers_off: bool, pycache: Path
) -> tuple[float, float]:
    """One ``robolobe plan`` of the bundled pocket: (wall seconds, CPU seconds).

    ``pycache``: the folder of the runs' bytecode (``PYTHONPYCACHEPREFIX``).
    """
    root = str(Path(robolobe.__file__).resolve().parents[1])
    env = {
        **{k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"},
        "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]),
        "PYTHONPYCACHEPREFIX": str(pycache),
    }
    args = ["off" if workers_off else "on", "plan", "-o", str(out), *extra]
    c0 = _children_cpu()
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", _RUNNER, *args],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        timeout=900,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"robolobe plan {' '.join(extra)} failed:\n{proc.stderr[-2000:]}")
    # the plan's CPU and its plot workers' (reaped by it, so counted with it)
    return wall, _children_cpu() - c0


def phase(label: str, reps: int, tmp: Path) -> dict[str, list[float]]:
    """``reps`` rounds of the variants; prints and returns the wall times per variant."""
    walls: dict[str, list[float]] = {v[0]: [] for v in VARIANTS}
    cpus: dict[str, list[float]] = {v[0]: [] for v in VARIANTS}
    start = _load()
    for r in range(reps):
        # a different variant first in each round: no variant always follows the same one
        for name, extra, off in VARIANTS[r % len(VARIANTS) :] + VARIANTS[: r % len(VARIANTS)]:
            wall, cpu = run_plan(tmp / name.replace(" ", "_"), extra, off, tmp / "pycache")
            walls[name].append(wall)
            cpus[name].append(cpu)
    print(f"{label}: {reps} rounds; {start} at the start, {_load()} at the end, {_cores()} cores")
    base = statistics.median(walls["no plots"])
    base_cpu = statistics.median(cpus["no plots"])
    for name, *_ in VARIANTS:
        med, cpu = statistics.median(walls[name]), statistics.median(cpus[name])
        runs = " ".join(f"{w:5.2f}/{c:4.2f}" for w, c in zip(walls[name], cpus[name], strict=True))
        print(
            f"  {name:<11s} median {med:6.2f} s wall (x{med / base:4.2f} of no plots), "
            f"CPU {cpu:5.2f} s (x{cpu / base_cpu:4.2f}); runs wall/CPU s: {runs}"
        )
    return walls


def _cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--busy", type=int, default=2, help="Busy processes of the loaded phase.")
    ap.add_argument("--reps", type=int, default=3, help="Rounds of the three variants per phase.")
    args = ap.parse_args()
    if args.busy < 0 or args.reps < 1:
        ap.error("--busy must be >= 0 and --reps >= 1")
    print(
        f"robolobe {robolobe.__version__} from {Path(robolobe.__file__).resolve().parent}, "
        f"Python {sys.version.split()[0]}, {_cores()} cores, {_load()} before the warm-up; "
        f"--busy {args.busy} --reps {args.reps}"
    )
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for _, extra, off in VARIANTS:  # disk caches; the bytecode of every module they import
            run_plan(tmp / "warm-up", extra, off, tmp / "pycache")
        quiet_load = os.getloadavg()[0]
        quiet = phase("quiet (as the machine is)", args.reps, tmp)
        loaded = None
        if args.busy:
            with busy_processes(args.busy):
                time.sleep(1.0)  # let them start
                loaded = phase(f"beside {args.busy} busy processes", args.reps, tmp)
    print("side by side (median wall s): plots | in-process | no plots")
    rows = [("quiet", quiet)] + ([(f"{args.busy} busy", loaded)] if loaded else [])
    for label, walls in rows:
        cells = " | ".join(f"{statistics.median(walls[v[0]]):6.2f}" for v in VARIANTS)
        print(f"  {label:<8s} {cells}")
    if quiet_load >= _cores():
        print(
            f"note: the machine was busy with other work (load average {quiet_load:.1f} on "
            f"{_cores()} cores before the first phase): the goals are for an otherwise quiet "
            "machine; compare the ratios"
        )
    q = statistics.median(quiet["plots"])
    verdict = "met" if q < 2 else "NOT met"
    print(f"goal, quiet: bundled plan with plots < 2 s: {q:.2f} s ({verdict})")
    if loaded:
        w, b = statistics.median(loaded["plots"]), statistics.median(loaded["no plots"])
        ok = w <= 2 * b and w < 15
        print(
            f"goal, beside {args.busy} busy: with plots <= 2x without and < 15 s: "
            f"{w:.2f} s = x{w / b:.2f} of {b:.2f} s ({'met' if ok else 'NOT met'})"
        )


if __name__ == "__main__":
    main()
