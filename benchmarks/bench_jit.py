"""Where each compiled kernel pays for numba's start-up: the crossovers of the size dispatch.

    python benchmarks/bench_jit.py                      # every kernel, default sizes
    python benchmarks/bench_jit.py --kernel stock,ik
    python benchmarks/bench_jit.py --kernel zoa --sizes 1e5,3e5,1e6

Each measurement runs in a fresh process (as a user's ``robolobe plan``), so
that numba's start-up is counted where it is paid. For each kernel and size
it prints the CPU seconds (``time.process_time``, all threads) of the call
on the numpy (or Python) path, compiled in a process where numba has not
started (``cold``: importing numba, its first dispatch and the kernel's
cache load included), and compiled where another kernel has started numba
already (``started``: the Z-map kernels compiled first on a short path, not
timed), then the size from which the compiled call wins in each case. These
are the thresholds :func:`robolobe._jit.use_compiled` takes (the constants
named in the output). The kernels' caches must exist (run once first: the
first run compiles, which takes seconds and is not a start-up cost).

Kernels and their size unit:

- ``stock``: the Z-map engagement (:func:`robolobe.stock.compute_engagement`)
  of zig-zags of the 20 mm cutter; unit :func:`robolobe.stock._kernels.work`
  (swept cells);
- ``ik``: :func:`robolobe.robots.ik_batch` of a smooth path of robot A; poses;
- ``zoa``: :func:`robolobe.sld.zoa.zoa_lobes` of a batch of tool-point
  models; waypoints x frequencies;
- ``group``: the leader clustering of :func:`robolobe.plan.lobes.group_features`
  on a smooth random walk of features; distinct rows.

The seconds are the machine's (compare the columns of one run); on a busy
machine repeat with ``--reps``: the minimum of each cell is printed.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

#: Default sizes per kernel (its unit).
SIZES = {
    "stock": "100,300,1000,3000",
    "ik": "2000,5000,10000,20000,40000",
    "zoa": "1e5,3e5,1e6,3e6",
    "group": "500,1000,2000,4000,8000",
}


def _start_numba() -> None:
    """Compile (load) the Z-map kernels on a short path: numba started, as by a plan."""
    from robolobe.stock import _kernels

    _kernels.kernels()
    from robolobe.stock import compute_engagement, default_stock

    xyz = np.array([[0.0, 0.0, 0.0], [0.02, 0.0, 0.0], [0.04, 0.0, 0.0]])
    cut = np.array([False, True, True])
    compute_engagement(xyz, cut, 0.02, default_stock(xyz, cut, 0.01))


def _stock(size: int, compiled: bool) -> tuple[float, float]:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_plan import EXAMPLES, zigzag_gcode

    from robolobe.plan.job import load_job
    from robolobe.plan.paths import read_toolpath
    from robolobe.stock import _kernels, compute_engagement, default_stock

    job = load_job(EXAMPLES / "job_A_pocket.toml")
    d = job.tool.diameter_m
    path = Path(os.environ.get("TMPDIR", "/tmp")) / f"bench_jit_{os.getpid()}.nc"
    path.write_text(zigzag_gcode(size, 100.0, 60.0, 10.0), encoding="utf-8")
    wp = read_toolpath(path)
    path.unlink()
    xyz = wp[["x_m", "y_m", "z_m"]].to_numpy()
    cut = (wp["motion"] == "cut").to_numpy()
    stock = default_stock(xyz, cut, 0.5 * d)
    units = _kernels.work(xyz, cut, 0.5 * d, d / 40)
    _kernels.JIT_MIN_WORK = _kernels.JIT_MIN_WORK_STARTED = 0.0 if compiled else math.inf
    t0 = time.process_time()
    compute_engagement(xyz, cut, d, stock)
    return time.process_time() - t0, units


def _ik(size: int, compiled: bool) -> tuple[float, float]:
    import importlib

    from robolobe.robots import ik_batch, load_robot, tcp_pose
    from robolobe.robots.limits import sample_postures

    robot = load_robot("A")
    knots = sample_postures(robot, 12, np.random.default_rng(0))
    t = np.linspace(0.0, 1.0, size)
    q = np.stack([np.interp(t, np.linspace(0, 1, 12), knots[:, j]) for j in range(6)], -1)
    poses = tcp_pose(robot, q)
    ik = importlib.import_module("robolobe.robots.ik")  # the module (robots.ik is a function)
    ik.JIT_MIN_POSES = ik.JIT_MIN_POSES_STARTED = 0 if compiled else 1 << 62
    t0 = time.process_time()
    ik_batch(robot, poses, q[0])
    return time.process_time() - t0, size


def _zoa(size: int, compiled: bool) -> tuple[float, float]:
    from robolobe.sld import (
        CuttingConditions,
        ModalModel,
        directional_factors,
        feed_frame,
        get_material,
        tool_point_model,
        zoa_lobes,
    )

    mat = get_material("Al7075-T6")
    nf = 460  # about the frequencies per waypoint of these models
    n = max(1, size // nf)
    rng = np.random.default_rng(0)
    w = 2 * math.pi * rng.uniform(5.0, 40.0, (n, 6))
    z = rng.uniform(0.01, 0.05, (n, 6))
    k = rng.uniform(0.3e5, 27e5, (n, 6, 1))
    shapes = rng.normal(size=(n, 6, 3))
    shapes *= w[..., None] / np.sqrt(k) / np.linalg.norm(shapes, axis=-1, keepdims=True)
    tool = ModalModel.from_directional(
        [700.0, 2200.0, 750.0, 2300.0], [0.03, 0.02, 0.03, 0.02],
        [3e7, 5e7, 3.2e7, 5e7], ["xx", "xx", "yy", "yy"],
    )  # fmt: skip
    ang = rng.uniform(0.0, 2 * math.pi, n)
    frame = feed_frame(np.stack([np.cos(ang), np.sin(ang), np.zeros(n)], axis=-1))
    m = tool_point_model(frame, ModalModel.from_shapes(w, z, shapes), tool)
    cond = CuttingConditions.from_immersion(0.5, "down")
    alpha = directional_factors(cond.phi_entry, cond.phi_exit, mat.kr)
    omega = m.frequency_grid(shared=False)
    frf = m.frf(omega)
    t0 = time.process_time()
    zoa_lobes(
        omega, frf, alpha=alpha, teeth=3, kt=mat.kt, rpm=np.linspace(6000.0, 24000.0, 700),
        jit=compiled,
    )  # fmt: skip
    return time.process_time() - t0, float(omega.shape[0] * omega.shape[1])


def _group(size: int, compiled: bool) -> tuple[float, float]:
    from robolobe.plan.lobes import DynamicsTolerance, group_features

    rng = np.random.default_rng(0)
    f = np.cumsum(rng.normal(scale=0.3, size=(size, 8)), axis=0)
    t0 = time.process_time()
    group_features(f, DynamicsTolerance(), compiled=compiled)
    return time.process_time() - t0, float(size)


_KERNELS = {"stock": _stock, "ik": _ik, "zoa": _zoa, "group": _group}


def _child(kernel: str, size: int, mode: str) -> None:
    if mode == "started":
        _start_numba()
    sec, units = _KERNELS[kernel](size, mode != "numpy")
    print(json.dumps({"sec": sec, "units": units, "numba": "numba" in sys.modules}))


def _measure(kernel: str, size: int, mode: str) -> dict[str, Any]:
    env = dict(os.environ)
    if mode == "numpy":
        env["ROBOLOBE_NO_JIT"] = "1"
    out = subprocess.run(
        [sys.executable, __file__, "--child", kernel, str(size), mode],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    return dict(json.loads(out.strip().splitlines()[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kernel", default="stock,ik,zoa,group")
    ap.add_argument("--sizes", default=None, help="comma-separated sizes (one kernel)")
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        _child(args.child[0], int(float(args.child[1])), args.child[2])
        return
    one, five = os.getloadavg()[:2]
    cores = os.cpu_count()
    print(f"CPU seconds per call, fresh process each; cores {cores}, load {one:.1f}/{five:.1f}")
    for kernel in args.kernel.split(","):
        sizes = [int(float(s)) for s in (args.sizes or SIZES[kernel]).split(",")]
        print(f"{kernel}: size -> units, numpy, cold, started")
        wins: dict[str, float | None] = {"cold": None, "started": None}
        for size in sizes:
            cells: dict[str, float] = {}
            units = 0.0
            for mode in ("numpy", "cold", "started"):
                runs = [_measure(kernel, size, mode) for _ in range(args.reps)]
                cells[mode] = min(r["sec"] for r in runs)
                units = runs[0]["units"]
            for mode in ("cold", "started"):
                if wins[mode] is None and cells[mode] <= cells["numpy"]:
                    wins[mode] = units
            print(
                f"  {size:>9,} {units:>13,.0f}  {cells['numpy']:7.3f}  {cells['cold']:7.3f}  "
                f"{cells['started']:7.3f}"
            )
        print(
            f"  compiled wins from (units): cold {wins['cold'] or 'not reached'}, "
            f"started {wins['started'] or 'not reached'}"
        )


if __name__ == "__main__":
    main()
