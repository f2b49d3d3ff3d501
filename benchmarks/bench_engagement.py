"""Engagement stage (robolobe.stock): Z-map material removal and per-move engagement.

    python benchmarks/bench_engagement.py                       # 10k and 1e6 moves
    python benchmarks/bench_engagement.py --moves 10000,200000
    python benchmarks/bench_engagement.py --pocket              # also the bundled pocket

For each size it reads the zig-zag of ``bench_plan.py`` (the 10k-waypoint
path of its part ``path`` and the 1e6-waypoint path of its part ``long``:
400 x 300 mm, 10 mm step-over, 1 mm deep) with the 20 mm cutter of
``job_A_pocket.toml``, derives the default stock and computes the engagement
of every move at the default Z-map cell (diameter / 40 = 0.5 mm). It prints
the CPU seconds (``time.process_time``) of the read and of the engagement
(compilation excluded: a warm-up on a short path first), the moves per
second, the peak resident memory, and the share of moves in each milling
class (a check that the numbers describe real work: the zig-zag's first pass
is a slot, the others half-width up and down milling). Budget (issue 26):
the engagement must fit in the 10k plan's < 3 s and the 1e6 plan's < 60 s
and < 2 GB.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from robolobe.plan.job import load_job
from robolobe.plan.paths import read_toolpath
from robolobe.stock import compute_engagement, default_stock

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_plan import EXAMPLES, zigzag_gcode


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _run(path: Path, diameter: float) -> tuple[float, float, int, dict[str, int], float]:
    t0 = time.process_time()
    wp = read_toolpath(path)
    t1 = time.process_time()
    xyz = wp[["x_m", "y_m", "z_m"]].to_numpy()
    cut = (wp["motion"] == "cut").to_numpy()
    axis = wp[["i", "j", "k"]].to_numpy()
    del wp
    t2 = time.process_time()
    stock = default_stock(xyz, cut, 0.5 * diameter)
    e = compute_engagement(xyz, cut, diameter, stock, axis=axis)
    t3 = time.process_time()
    kinds, counts = np.unique(e.milling()[cut], return_counts=True)
    classes = {str(k) or "air": int(c) for k, c in zip(kinds, counts, strict=True)}
    return t1 - t0, t3 - t2, int(cut.sum()), classes, e.resolution_m


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--moves", default="10000,1000000", help="comma-separated path sizes")
    ap.add_argument("--pocket", action="store_true", help="also the bundled pocket.nc")
    args = ap.parse_args()
    job = load_job(EXAMPLES / "job_A_pocket.toml")
    d = job.tool.diameter_m
    sizes = [int(s) for s in args.moves.split(",") if s]
    one, five = os.getloadavg()[:2]
    cores = os.cpu_count()
    print(f"engagement stage, {d * 1e3:g} mm cutter, cores {cores}, load {one:.1f}/{five:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        warm = Path(tmp) / "warm.nc"
        warm.write_text(zigzag_gcode(200, 40.0, 30.0, 10.0), encoding="utf-8")
        _run(warm, d)  # compile (or load the cached kernels)
        paths = []
        if args.pocket:
            paths.append((EXAMPLES / "pocket.nc", "pocket.nc"))
        for n in sizes:
            p = Path(tmp) / f"zigzag_{n}.nc"
            p.write_text(zigzag_gcode(n, 400.0, 300.0, 10.0), encoding="utf-8")
            paths.append((p, f"zig-zag {n:,}"))
        for p, name in paths:
            t_read, t_eng, n_cut, classes, res = _run(p, d)
            print(
                f"  {name:<18s} {n_cut:>9,} cutting moves: read {t_read:6.2f} s CPU, engagement "
                f"{t_eng:6.2f} s CPU ({n_cut / max(t_eng, 1e-9):,.0f} moves/s, cell "
                f"{res * 1e3:g} mm), peak RSS {_rss_mb():,.0f} MB; {classes}"
            )


if __name__ == "__main__":
    main()
