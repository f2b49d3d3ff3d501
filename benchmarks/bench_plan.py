"""Planner speed: one 10,000-waypoint path end to end, and batch throughput.

    python benchmarks/bench_plan.py                 # both parts, full size
    python benchmarks/bench_plan.py --part path     # 10k-waypoint path only
    python benchmarks/bench_plan.py --part batch --paths 40 --waypoints 1000

Part 1 plans a dense zig-zag finishing path (10,000 waypoints, 3-axis, tool
down) on robot A with each mode source of ``--sources`` (default: the twin,
the default source; the shipped tl network; the twin planned robustly) and
writes the outputs without the HTML report; it prints the seconds per stage
(read, IK, modes, FRFs, lobes, optimization, table, outputs) per source and
side by side, and the number of distinct dynamics the lobes were computed
for. Target (issues 6, 11): under 10 s on 2 cores.

Part 2 plans ``--paths`` paths of ``--waypoints`` waypoints each (shifted
copies of a pocket-like path) with 1 and then 2 worker processes and prints
the throughput per worker and the scaling from 1 to 2 workers.

The numbers are for the machine the script runs on; compare runs side by
side on one machine (the ratio), not against a fixed threshold.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from robolobe.plan.batch import batch_plan
from robolobe.plan.job import load_job
from robolobe.plan.pipeline import plan_path
from robolobe.plan.report import write_outputs

EXAMPLES = Path(__file__).resolve().parents[1] / "src" / "robolobe" / "data" / "examples"


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


def part_path(n: int, tmp: Path, sources: list[str]) -> None:
    path = tmp / "zigzag.nc"
    path.write_text(zigzag_gcode(n, 400.0, 300.0, 10.0), encoding="utf-8")
    base_job = load_job(EXAMPLES / "job_A_pocket.toml")
    pl = base_job.placement.copy()
    pl[:3, 3] = [1.55, -0.15, 0.30]  # the zig-zag's corner; the path runs +x, +y from here
    base_job = base_job.replace(placement=pl)
    stages: dict[str, dict[str, float]] = {}
    for spec in sources:
        model, _, mode = spec.partition("+")
        job = base_job.replace(model=model)
        if mode == "robust":
            job = job.replace(plan=dataclasses.replace(job.plan, robust=True))
        plan_path(EXAMPLES / "pocket.nc", job)  # warm-up: imports, model load, casadi
        t0 = time.perf_counter()
        res = plan_path(path, job)
        t1 = time.perf_counter()
        write_outputs(res, tmp / "out", plots=True, html_report=False)
        t2 = time.perf_counter()
        s = res.summary
        print(
            f"path [{spec}: {s['mode_source']}]: {s['n_waypoints']} waypoints ({s['n_cut']} "
            f"cutting), {s['n_dynamics_groups']} distinct dynamics, cores: {os.cpu_count()}, "
            f"load {os.getloadavg()[0]:.1f}"
        )
        for k, v in res.timings.items():
            print(f"  {k:<10s} {v:7.3f} s")
        print(f"  {'outputs':<10s} {t2 - t1:7.3f} s  (csv, json, 4 plots; no html)")
        print(f"  {'total':<10s} {t2 - t0:7.3f} s  (target < 10 s)")
        print(f"  lobes:     { {k: round(v, 3) for k, v in res.lobes.timings.items()} }")
        print(f"  optimizer: { {k: round(v, 3) for k, v in res.outcome.timings.items()} }")
        rng = f"{s['rpm_min']:.0f}-{s['rpm_max']:.0f} rpm"
        print(f"  plan: {s['method']}, depth {s['depth_mm']} mm, {rng}")
        stages[spec] = {**res.timings, "total": t2 - t0}
    if len(stages) > 1:
        names = list(stages)
        print("stage seconds side by side: " + " | ".join(names))
        for k in stages[names[0]]:
            print(
                f"  {k:<10s} " + " | ".join(f"{stages[m].get(k, float('nan')):7.3f}" for m in names)
            )


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
    ap.add_argument("--part", choices=("path", "batch", "all"), default="all")
    ap.add_argument("--waypoints-path", type=int, default=10_000)
    ap.add_argument("--paths", type=int, default=200)
    ap.add_argument("--waypoints", type=int, default=1000)
    ap.add_argument(
        "--sources",
        default="twin,builtin,twin+robust",
        help="Mode sources of part 1 (robot.model values; '+robust' plans robustly).",
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if args.part in ("path", "all"):
            part_path(args.waypoints_path, tmp, args.sources.split(","))
        if args.part in ("batch", "all"):
            part_batch(args.paths, args.waypoints, tmp)


if __name__ == "__main__":
    main()
