"""Benchmark: inverse kinematics of a long path (closed form, chunked, compiled continuity).

Workload: a smooth random path of robot B through its joint space (``--n``
poses, default 200,000), solved with ``ik_batch(continuity=True)``. Every
figure is printed with a reference measured in the same process:

- ``loop``: today's per-waypoint Python loop of the nearest-branch choice
  (:func:`robolobe.robots.ik._continuity_numpy`, the reference the compiled
  kernel is tested against) on the first ``--loop`` poses;
- ``branches``: the batch closed-form IK alone (all 8 branches), the part
  that the compiled continuity does not touch;
- peak memory (tracemalloc) per pose, which stays flat with ``n`` (chunks).

Run: ``python benchmarks/bench_ik.py [--n 200000] [--loop 5000] [--robot B]``.
"""

from __future__ import annotations

import argparse
import os
import time
import tracemalloc

import numpy as np

from robolobe.robots import ik_batch, load_robot, tcp_pose
from robolobe.robots.ik import _continuity, _continuity_numpy, _turn_base, ik_branches, pose_error
from robolobe.robots.limits import sample_postures


def make_path(robot_name: str, n: int, seed: int = 0) -> tuple[object, np.ndarray, np.ndarray]:
    robot = load_robot(robot_name)
    rng = np.random.default_rng(seed)
    knots = sample_postures(robot, 12, rng)
    t = np.linspace(0.0, 1.0, n)
    q = np.stack([np.interp(t, np.linspace(0, 1, 12), knots[:, j]) for j in range(6)], -1)
    return robot, q, tcp_pose(robot, q)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=200_000)
    ap.add_argument("--loop", type=int, default=5000)
    ap.add_argument("--robot", default="B")
    args = ap.parse_args()
    robot, q, poses = make_path(args.robot, args.n)
    load = os.getloadavg()[0]
    print(f"workload: robot {args.robot}, {args.n} poses; load average {load:.2f}")

    q8, ok = ik_branches(robot, poses[:10], q[0])  # compile / load the kernel cache
    base, count = _turn_base(robot, q8, ok)
    _continuity(robot, base, count, ok & np.all(count >= 1, -1), np.ones(6), q[0].copy())
    t0 = time.perf_counter()
    got = ik_batch(robot, poses, q[0], continuity=True)
    t_all = time.perf_counter() - t0

    nl = min(args.loop, args.n)
    t0 = time.perf_counter()
    q8, ok = ik_branches(robot, poses[:nl], q[0])
    base, count = _turn_base(robot, q8, ok)
    exists = ok & np.all(count >= 1, axis=-1)
    t_br = time.perf_counter() - t0
    t0 = time.perf_counter()
    ref, _, _ = _continuity_numpy(robot, base, count, exists, np.ones(6), q[0].copy())
    t_loop = time.perf_counter() - t0
    t0 = time.perf_counter()
    comp, _, _ = _continuity(robot, base, count, exists, np.ones(6), q[0].copy())
    t_comp = time.perf_counter() - t0
    diff = float(np.max(np.abs(comp - ref)))
    dp, da = pose_error(tcp_pose(robot, got), poses)

    tracemalloc.start()
    ik_batch(robot, poses[: min(args.n, 50_000)], q[0])
    _, peak_small = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    ik_batch(robot, poses, q[0])
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    us = 1e6
    print(f"\n{'':44s} {'us/pose':>9s} {'vs loop':>8s}")
    print(f"{'nearest-branch loop (numpy, reference)':44s} {t_loop / nl * us:9.2f} {1.0:7.1f}x")
    print(f"{'compiled continuity':44s} {t_comp / nl * us:9.2f} {t_loop / t_comp:7.1f}x")
    print(f"{'closed-form branches (8 per pose)':44s} {t_br / nl * us:9.2f}")
    print(f"{'branches + loop (the previous ik_batch)':44s} {(t_br + t_loop) / nl * us:9.2f}")
    print(
        f"{'ik_batch end to end, ' + str(args.n) + ' poses':44s} {t_all / args.n * us:9.2f} "
        f"{(t_br + t_loop) / nl / (t_all / args.n):7.1f}x vs branches + loop ({t_all:.2f} s)"
    )
    print(
        f"\nmax |compiled - loop| = {diff:.1e} rad over {nl} poses; "
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
