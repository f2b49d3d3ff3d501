"""Planner speed: a 10,000-waypoint path end to end, batch throughput, a million waypoints.

    python benchmarks/bench_plan.py                 # parts path and batch, full size
    python benchmarks/bench_plan.py --part path     # 10k-waypoint path only
    python benchmarks/bench_plan.py --part batch --paths 40 --waypoints 1000
    python benchmarks/bench_plan.py --part long     # 1e6 waypoints: time, peak RSS
    python benchmarks/bench_plan.py --part long --stock    # the same with [stock] engagement

Part 1 (``path``) plans a dense zig-zag finishing path (10,000 waypoints,
3-axis, tool down) on robot A with each mode source of ``--sources``
(default: the twin, the default source; the shipped tl network; the twin
planned robustly; ``corrected``: a corrected twin of A, what ``robolobe
transfer modal.csv --robot A`` makes, fitted before the timing to 20
simulated hammer tests and planned robustly on its own spread, the default
for a robot with tests) and writes the outputs without the HTML report; it prints
the seconds per stage (read, IK, modes, FRFs, lobes, optimization, table,
outputs) per source, each as a share of the total and beside the same plan
on the numpy reference paths (compiled kernels off, same process; whether
the plan came out the same), then the sources side by side as ratios to the
first, with the load average (``--cpu-stages``: in CPU seconds of the
process, all threads, as for part 3). It also prints the lobe stage's own
split (grouping, ZOA) and the optimizer's seconds per step summed over all
its runs for the plan (the pass counts tried, the schedule made again after
a steep-wall split) with their number. A source ending in ``+stock`` plans with the
job's ``[stock]`` at its default (the stock the program implies, cell
diameter / 40): the engagement of every move on the Z-map is then its own
stage (``engagement``, between ``read`` and ``ik``). Targets: < 10 s (issues
6, 11), < 2 s (issue 17), < 3 s with the stock (issue 26).

Part 2 (``batch``) plans ``--paths`` paths of ``--waypoints`` waypoints each
(shifted copies of a pocket-like path) with 1 and then 2 worker processes
and prints the throughput per worker and the scaling from 1 to 2 workers.

Part 3 (``long``, run alone so that the peak RSS is the plan's) plans a
zig-zag of ``--waypoints-long`` waypoints (default 1e6) on the twin and
writes the waypoints (``--format csv|parquet|none``, ``--every K`` thins
them) without plots; it prints the seconds per stage, the total wall and
CPU time, the peak resident memory (decimal GB and bytes: the target
is 2e9 bytes, not 2 GiB) and the load average; ``--stock`` plans
with the default ``[stock]`` (the engagement stage included);
``--cpu-stages`` gives the stages in CPU seconds of the process (all
threads) instead of wall seconds: on a shared machine these compare between
runs where wall seconds do not. Target (issues 16, 17, 26): < 60 s and
< 2 GB on 2 cores, with the engagement too.

The numbers are for the machine the script runs on; compare runs side by
side on one machine (the ratios), not against a fixed threshold.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from robolobe.plan import pipeline as _pipeline
from robolobe.plan._plots import PlotWorker
from robolobe.plan.batch import batch_plan
from robolobe.plan.job import Job, StockSpec, load_job
from robolobe.plan.pipeline import plan_path
from robolobe.plan.report import write_outputs

EXAMPLES = Path(__file__).resolve().parents[1] / "src" / "robolobe" / "data" / "examples"
#: The long path's peak resident memory target (issues 16, 17, 26: "< 2 GB"), decimal bytes.
PEAK_TARGET_BYTES = 2_000_000_000


def zigzag_gcode(n_target: int, width_mm: float, height_mm: float, step_mm: float) -> str:
    """A finishing-style zig-zag with evenly spaced points (like a CAM surface path)."""
    passes = int(height_mm // step_mm) + 1
    per_pass = max(2, round(n_target / passes))
    lines = [
        "%",
        "O3001 (BENCH ZIGZAG)",
        "G90 G21 G17",
        "S18000 M3",
        "G0 X0. Y0. Z5.",
        "G1 Z-1. F1000.",
    ]
    for k in range(passes):
        y = k * step_mm
        xs = np.linspace(0.0, width_mm, per_pass)
        if k % 2:
            xs = xs[::-1]
        if k:
            lines.append(f"Y{y:.3f}")
        lines += [f"X{x:.3f} F4000." if i == 0 else f"X{x:.3f}" for i, x in enumerate(xs)]
    lines += ["G0 Z5.", "M30", "%"]
    return "\n".join(lines) + "\n"


def _load() -> str:
    one, five = os.getloadavg()[:2]
    return f"load {one:.1f}/{five:.1f}"


@contextlib.contextmanager
def _numpy_paths() -> Iterator[None]:
    """The numpy reference paths: compiled kernels off (as ``ROBOLOBE_NO_JIT=1``)."""
    from robolobe import _jit

    old = dict(_jit._STATE)
    _jit._STATE["ok"] = False
    try:
        yield
    finally:
        _jit._STATE.clear()
        _jit._STATE.update(old)


def _children_cpu() -> float:
    """CPU seconds of the finished child processes (the plot worker)."""
    import resource

    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


@contextlib.contextmanager
def _stage_cpu(on: bool) -> Iterator[None]:
    """With ``on``, the plan's stage timings are CPU seconds of the process (all threads).

    The pipeline times its stages with ``time.perf_counter``; its module's
    ``time`` (and the lobe stage's and the optimizer's, for their steps) is
    replaced by one whose ``perf_counter`` is ``process_time``
    (on a shared machine the CPU seconds compare where wall seconds do not).
    """
    if not on:
        yield
        return
    import types

    from robolobe.plan import lobes as _lobes
    from robolobe.plan.optimize import _api as _opt

    clock = types.SimpleNamespace(perf_counter=time.process_time, process_time=time.process_time)
    mods = (_pipeline, _lobes, _opt)  # the stages, the lobe stage's and optimizer's steps
    old = [m.time for m in mods]
    for m in mods:
        m.time = clock  # type: ignore[assignment]
    try:
        yield
    finally:
        for m, t in zip(mods, old, strict=True):
            m.time = t


def _with_stock(job: Job) -> Job:
    """The job with ``[stock]`` at its default (the program's stock, default cell)."""
    return job.replace(stock=StockSpec())


def _timed_plan(
    path: Path, job: Any, out: Path, cpu_stages: bool = False
) -> tuple[Any, dict[str, float]]:
    clock = time.process_time if cpu_stages else time.perf_counter
    t0 = clock()
    c0 = time.process_time() + _children_cpu()
    with PlotWorker() as worker, _stage_cpu(cpu_stages):  # plots drawn on the other core
        res = plan_path(path, job)
        t1 = clock()
        write_outputs(res, out, plots=True, html_report=False, worker=worker)
    t2 = clock()
    cpu = time.process_time() + _children_cpu() - c0  # the plot worker's CPU included
    # the plan records its stages (the engagement stage after read); with cpu_stages
    # every stage, outputs and total in CPU seconds of this process (all threads; the
    # plot workers' only in "cpu")
    st = {**res.timings, "outputs": t2 - t1, "total": t2 - t0, "cpu": cpu}
    return res, st


def _corrected_model(tmp: Path) -> str:
    """A corrected twin of robot A fitted to 20 designed postures (not timed): its .npz."""
    from robolobe.robots import load_robot
    from robolobe.tl.design import design_postures
    from robolobe.tl.residual import CorrectedTwin
    from robolobe.tl.twin_data import twin_modal_dataset
    from robolobe.twin import Twin
    from robolobe.twin.designs import TESTED_RANGES_DEG

    robot = load_robot("A")
    rng = np.random.default_rng(2026)
    q = design_postures(robot, 20, rng=rng, ranges_deg=TESTED_RANGES_DEG["A"]).q_rad
    ds = twin_modal_dataset(Twin(robot), [f"P{i}" for i in range(len(q))], q, rng=rng)
    t0 = time.perf_counter()
    model = CorrectedTwin(robot="A").fit_dataset(ds)
    out = tmp / "A_pred.npz"
    model.save(out)
    print(f"corrected twin of A fitted to {len(q)} postures in {time.perf_counter() - t0:.1f} s")
    return str(out)


def part_path(
    n: int, tmp: Path, sources: list[str], reference: bool, cpu_stages: bool = False
) -> None:
    path = tmp / "zigzag.nc"
    path.write_text(zigzag_gcode(n, 400.0, 300.0, 10.0), encoding="utf-8")
    base_job = load_job(EXAMPLES / "job_A_pocket.toml")
    pl = base_job.placement.copy()
    pl[:3, 3] = [1.55, -0.15, 0.30]  # the zig-zag's corner; the path runs +x, +y from here
    base_job = base_job.replace(placement=pl)
    stages: dict[str, dict[str, float]] = {}
    for spec in sources:
        model, *modes = spec.split("+")
        if model == "corrected":
            model = _corrected_model(tmp)
        job = base_job.replace(model=model)
        if "robust" in modes:
            job = job.replace(plan=dataclasses.replace(job.plan, robust=True))
        if "stock" in modes:
            job = _with_stock(job)
        # warm-up: imports, model load, casadi, and the compiled kernels this path takes
        # (the bundled pocket alone no longer starts numba: it is below every kernel's
        # size; numba's start-up per process is benchmarks/bench_jit.py's)
        plan_path(path, job)
        res, st = _timed_plan(path, job, tmp / "out", cpu_stages)
        s = res.summary
        print(
            f"path [{spec}: {s.mode_source}, robust {s.robust}]: {s.n_waypoints} "
            f"waypoints ({s.n_cut} cutting), {s.n_dynamics_groups} distinct dynamics, "
            f"cores: {os.cpu_count()}, "
            f"{_load()}"
        )
        ref = None
        if reference:
            # the same plan on the numpy reference paths (no compiled kernels), same process
            with _numpy_paths():
                res_ref, ref = _timed_plan(path, job, tmp / "out_ref", cpu_stages)
            same = res_ref.outcome.best.depth_m == res.outcome.best.depth_m and np.array_equal(
                res_ref.outcome.best.rpm, res.outcome.best.rpm
            )
            print(f"  reference: numpy paths (kernels off), {_load()}; same plan: {same}")
        for k, v in st.items():
            unit = "s CPU" if cpu_stages and k != "cpu" else "s"
            line = f"  {k:<10s} {v:7.3f} {unit}  ({v / st['total']:5.1%} of total)"
            if ref is not None and k in ref:
                line += f"  numpy reference {ref[k]:7.3f} s (x{ref[k] / max(v, 1e-9):.2f})"
            print(line)
        print("  outputs: csv, json, 4 plots; no html. targets: < 10 s (issue 6), < 2 s (issue 17)")
        print(f"  lobes:     { {k: round(v, 3) for k, v in res.lobes.timings.items()} }")
        opt = dict(res.outcome.timings)
        runs = int(opt.pop("runs", 1))
        opt_s = {k: round(v, 3) for k, v in opt.items()}
        print(f"  optimizer: {runs} runs, seconds summed: {opt_s}")
        rng = f"{s.rpm_min:.0f}-{s.rpm_max:.0f} rpm"
        print(f"  plan: {s.method}, depth {s.depth_mm} mm, {rng}; refinement: {s.nlp_status}")
        stages[spec] = st
    if len(stages) > 1:
        names = list(stages)
        first = names[0]
        print(
            f"stage seconds side by side ({_load()}; ratio to {first} in brackets): "
            + " | ".join(names)
        )
        keys = list(dict.fromkeys(k for m in names for k in stages[m]))
        for k in keys:
            cells = []
            for m in names:
                v = stages[m].get(k, float("nan"))
                cells.append(f"{v:7.3f} (x{v / max(stages[first].get(k, 0.0), 1e-9):4.2f})")
            print(f"  {k:<10s} " + " | ".join(cells))


def part_long(
    n: int,
    tmp: Path,
    fmt: str,
    every: int,
    program: bool = True,
    stock: bool = False,
    cpu_stages: bool = False,
) -> None:
    """A long zig-zag (``n`` waypoints) planned and written; wall, CPU, peak RSS, load."""
    import resource

    path = tmp / "long.nc"
    path.write_text(zigzag_gcode(n, 400.0, 300.0, 10.0), encoding="utf-8")
    job = load_job(EXAMPLES / "job_A_pocket.toml")
    pl = job.placement.copy()
    pl[:3, 3] = [1.55, -0.15, 0.30]
    job = job.replace(placement=pl)
    if stock:
        job = _with_stock(job)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    t0 = time.perf_counter()
    c0 = time.process_time()
    with _stage_cpu(cpu_stages):
        res = plan_path(path, job)
    t1 = time.perf_counter()
    c1 = time.process_time()
    write_outputs(
        res,
        tmp / "out_long",
        plots=False,
        html_report=False,
        waypoints=fmt,
        waypoints_every=every,
        program=program,
    )
    t2 = time.perf_counter()
    c2 = time.process_time()
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # KiB on Linux: bytes
    s = res.summary
    print(
        f"long path: {s.n_waypoints} waypoints ({s.n_cut} cutting), "
        f"{s.n_dynamics_groups} distinct dynamics, cores {os.cpu_count()}, {_load()}"
        + (", [stock] engagement" if stock else "")
    )
    stages = dict(res.timings)
    if cpu_stages:
        print(f"  (stages in CPU seconds, all threads; plan CPU {c1 - c0:.2f} s)")
        for k, v in stages.items():
            print(f"  {k:<10s} {v:7.2f} s CPU ({v / max(c1 - c0, 1e-9):5.1%} of the plan's CPU)")
    else:
        for k, v in stages.items():
            print(f"  {k:<10s} {v:7.2f} s  ({v / (t2 - t0):5.1%})")
    sizes = {p.name: p.stat().st_size for p in (tmp / "out_long").iterdir() if p.is_file()}
    what = "with program.nc (written, read back)" if program else "no program"
    print(f"  outputs    {t2 - t1:7.2f} s  (waypoints {fmt}, every {every}, {what}: {sizes} bytes)")
    print(
        f"  total      {t2 - t0:7.2f} s wall, {c2 - c0:.2f} s CPU (plan {c1 - c0:.2f} s, "
        f"outputs {c2 - c1:.2f} s; target < 60 s wall)"
    )
    print(
        f"  peak RSS   {rss / 1e9:7.3f} GB = {rss:,} bytes ({rss / 2**20:.0f} MiB; before planning "
        f"{rss0 / 1e9:.3f} GB; target < {PEAK_TARGET_BYTES / 1e9:g} GB = {PEAK_TARGET_BYTES:.0e} "
        f"bytes: {'met' if rss < PEAK_TARGET_BYTES else 'NOT met'})"
    )
    print(f"  plan: {s.method}, depth {s.depth_mm} mm; refinement: {s.nlp_status}")


def part_batch(n_paths: int, n_wp: int, tmp: Path) -> None:
    text = zigzag_gcode(n_wp, 120.0, 80.0, 10.0)
    paths = []
    for i in range(n_paths):
        p = tmp / f"b{i:04d}.nc"
        p.write_text(text.replace("O3001", f"O{4000 + i}"), encoding="utf-8")
        paths.append(str(p))
    job = load_job(EXAMPLES / "job_A_pocket.toml")
    pl = job.placement.copy()
    pl[:3, 3] = [1.70, -0.04, 0.30]
    job = job.replace(placement=pl)
    rates = {}
    for workers in (1, 2):
        t0 = time.perf_counter()
        rows = list(batch_plan(paths, job, workers=workers))
        dt = time.perf_counter() - t0
        ok = sum(r["status"] == "ok" for r in rows)
        rates[workers] = len(rows) / dt
        per_path = np.mean([r["elapsed_s"] for r in rows])
        print(
            f"batch: {len(rows)} paths x {n_wp} waypoints, {workers} worker(s): {dt:.1f} s, "
            f"{rates[workers]:.2f} paths/s ({rates[workers] / workers:.2f} per worker), "
            f"{per_path:.2f} s per path in the worker, {ok} ok"
        )
    print(f"scaling 1 -> 2 workers: x{rates[2] / rates[1]:.2f} (ideal x2; {os.cpu_count()} cores)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=("path", "batch", "long", "all"), default="all")
    ap.add_argument("--waypoints-path", type=int, default=10_000)
    ap.add_argument("--paths", type=int, default=200)
    ap.add_argument("--waypoints", type=int, default=1000)
    ap.add_argument(
        "--sources",
        default="twin,twin+stock,builtin,twin+robust,corrected",
        help=(
            "Mode sources of part 1 (robot.model values; '+robust' plans robustly, "
            "'+stock' with the job's [stock] given; since issue 26 every plan has the "
            "engagement stage, on the stock the program implies without one)."
        ),
    )
    ap.add_argument(
        "--no-reference", action="store_true", help="Part 1 without the numpy reference run."
    )
    ap.add_argument("--waypoints-long", type=int, default=1_000_000)
    ap.add_argument("--format", default="csv", choices=("csv", "parquet", "none"))
    ap.add_argument("--every", type=int, default=1, help="Long part: write every k-th waypoint.")
    ap.add_argument(
        "--no-program",
        action="store_true",
        help="Long part: without program.nc (written and read back by default).",
    )
    ap.add_argument(
        "--cpu-stages",
        action="store_true",
        help=(
            "Parts path and long: the stages in CPU seconds (all threads) instead of "
            "wall seconds (on a shared machine these compare between runs)."
        ),
    )
    ap.add_argument(
        "--stock",
        action="store_true",
        help="Long part: with the default [stock] (the engagement stage included).",
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if args.part in ("path", "all"):
            part_path(
                args.waypoints_path,
                tmp,
                args.sources.split(","),
                not args.no_reference,
                args.cpu_stages,
            )
        if args.part in ("batch", "all"):
            part_batch(args.paths, args.waypoints, tmp)
        if args.part == "long":  # alone: the peak RSS is the process's
            part_long(
                args.waypoints_long,
                tmp,
                args.format,
                args.every,
                not args.no_program,
                args.stock,
                args.cpu_stages,
            )


if __name__ == "__main__":
    main()
