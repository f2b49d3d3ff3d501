"""Benchmark: inverse kinematics of a long path (closed form, chunked, compiled).

Workload: a smooth random path of robot B through its joint space (``--n``
poses, default 200,000), solved with ``ik_batch(continuity=True)``. Every
figure is printed beside a reference measured in the same process, on the
first ``--loop`` poses:

- continuity: the per-waypoint Python loop of the nearest-branch choice
  (:func:`robolobe.robots.ik._continuity_numpy`, the reference), the
  speculate-and-check numpy version (``_continuity_vectorized``, taken
  below ``JIT_MIN_POSES``) and the compiled kernel;
- branches: the numpy closed form with the FK check of all 8 branches (the
  previous ``ik_branches`` inside ``ik_batch``), without the check, and
  compiled (taken from ``JIT_MIN_POSES`` on; ``ik_batch`` checks only the
  chosen branch by FK);
- ``ik_batch`` end to end against the previous pipeline (all branches
  checked + loop), and its peak memory (tracemalloc), flat in ``n`` (chunks).

Run: ``python benchmarks/bench_ik.py [--n 200000] [--loop 5000] [--robot B]``.
"""

from __future__ import annotations

import argparse
import os
import time
import tracemalloc

import numpy as np

from robolobe.robots import ik_batch, load_robot, tcp_pose
from robolobe.robots.ik import (
    _branches_unchecked,
    _continuity,
    _continuity_numpy,
    _continuity_vectorized,
    _turn_base,
    ik_branches,
    pose_error,
)
from robolobe.robots.limits import sample_postures


def make_path(robot_name: str, n: int, seed: int = 0) -> tuple[object, np.ndarray, np.ndarray]:
    robot = load_robot(robot_name)
    rng = np.random.default_rng(seed)
    knots = sample_postures(robot, 12, rng)
    t = np.linspace(0.0, 1.0, n)
    q = np.stack([np.interp(t, np.linspace(0, 1, 12), knots[:, j]) for j in range(6)], -1)
    return robot, q, tcp_pose(robot, q)


def _timed(fn, *args, **kw):  # type: ignore[no-untyped-def]
    t0 = time.process_time()
    out = fn(*args, **kw)
    return out, time.process_time() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=200_000)
    ap.add_argument("--loop", type=int, default=5000)
    ap.add_argument("--robot", default="B")
    args = ap.parse_args()
    robot, q, poses = make_path(args.robot, args.n)
    print(f"workload: robot {args.robot}, {args.n} poses; load average {os.getloadavg()[0]:.2f}")
    print("times: CPU seconds of this process (time.process_time)")

    # compile / load the kernels' cache outside the timings
    q8, ok = _branches_unchecked(robot, poses[:10], q[0], compiled=True)
    base, count = _turn_base(robot, q8, ok)
    _continuity(robot, base, count, ok & np.all(count >= 1, -1), np.ones(6), q[0].copy())
    got, t_all = _timed(ik_batch, robot, poses, q[0], continuity=True)

    nl = min(args.loop, args.n)
    pl = poses[:nl]
    (q8, ok), t_br = _timed(ik_branches, robot, pl, q[0])
    _, t_unchecked = _timed(_branches_unchecked, robot, pl, q[0])
    (q8c, okc), t_cf = _timed(_branches_unchecked, robot, pl, q[0], compiled=True)
    base, count = _turn_base(robot, q8, ok)
    exists = ok & np.all(count >= 1, axis=-1)
    ref, t_loop = _timed(_continuity_numpy, robot, base, count, exists, np.ones(6), q[0].copy())
    vec, t_vec = _timed(_continuity_vectorized, robot, base, count, exists, np.ones(6), q[0].copy())
    comp, t_comp = _timed(_continuity, robot, base, count, exists, np.ones(6), q[0].copy())
    same_vec = bool(np.array_equal(vec[0], ref[0]))
    diff = float(np.max(np.abs(comp[0] - ref[0])))
    d_cf = np.abs(np.mod(q8c - q8 + np.pi, 2 * np.pi) - np.pi)[ok]
    dp, da = pose_error(tcp_pose(robot, got), poses)

    tracemalloc.start()
    ik_batch(robot, poses[: min(args.n, 50_000)], q[0])
    _, peak_small = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    ik_batch(robot, poses, q[0])
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    us = 1e6 / nl
    prev = t_br + t_loop
    print(f"\n{'':50s} {'us/pose':>9s} {'ratio':>8s}")
    print(f"{'continuity: per-pose loop (numpy, reference)':50s} {t_loop * us:9.2f} {1.0:7.1f}x")
    print(
        f"{'continuity: speculate and check (numpy)':50s} {t_vec * us:9.2f} {t_loop / t_vec:7.1f}x"
    )
    print(f"{'continuity: compiled':50s} {t_comp * us:9.2f} {t_loop / t_comp:7.1f}x")
    print(f"{'branches: numpy, FK check of all 8 (reference)':50s} {t_br * us:9.2f} {1.0:7.1f}x")
    print(f"{'branches: numpy, unchecked':50s} {t_unchecked * us:9.2f} {t_br / t_unchecked:7.1f}x")
    print(f"{'branches: compiled, unchecked':50s} {t_cf * us:9.2f} {t_br / t_cf:7.1f}x")
    print(f"{'previous ik_batch (checked branches + loop)':50s} {prev * us:9.2f} {1.0:7.1f}x")
    print(
        f"{'ik_batch end to end, ' + str(args.n) + ' poses':50s} {t_all / args.n * 1e6:9.2f} "
        f"{prev / nl / (t_all / args.n):7.1f}x ({t_all:.2f} s)"
    )
    print(
        f"\nspeculate and check = loop exactly: {same_vec}; max |compiled - loop| = {diff:.1e} "
        f"rad; compiled closed form vs numpy {float(d_cf.max()):.1e} rad (mod 2 pi), same "
        f"existing branches: {bool(np.array_equal(okc, np.all(np.isfinite(q8c), -1)))}; "
        f"pose error of the {args.n} solutions {float(dp.max()):.1e} m, {float(da.max()):.1e} rad"
    )
    print(
        f"peak memory allocated by ik_batch (tracemalloc; the (n, 6) result, 48 B/pose, "
        f"included; the input poses, 128 B/pose, not): {peak / 2**20:.0f} MB for {args.n} "
        f"poses, {peak_small / 2**20:.0f} MB for {min(args.n, 50_000)}"
    )
    print(f"load average now {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
