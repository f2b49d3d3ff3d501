"""Calibration of robots A, B and C: re-run the fit and print the check table.

Usage::

    python studies/calibration.py            # table for the shipped robot files
    python studies/calibration.py --fit      # re-run the fit, print the fitted values
                                             # (TOML lines) and the table for them

The procedure is documented in :mod:`robolobe.twin.calibration`; the shipped
values in ``src/robolobe/data/robots/{A,B,C}.toml`` are the ``--fit`` output,
rounded to three significant digits. The table is checked on 200 postures
(seed 7) that the fit did not see (seed 2024).
"""

from __future__ import annotations

import argparse

import numpy as np

from robolobe.robots import RigidBody, load_robot, sample_postures
from robolobe.twin.calibration import TARGETS, TOOLS, calibrate_builtin, calibration_report
from robolobe.twin.designs import TESTED_RANGES_DEG

CHECK_SEED = 7
CHECK_POSTURES = 200


def _toml(name: str, k: np.ndarray, c: np.ndarray, ee: RigidBody | None) -> str:
    xyz, zyx = TOOLS[name]
    lines = [f"# {name}: [tool] xyz_m = {list(xyz)}, zyx_deg = {list(zyx)}; joints 1..6"]
    for i in range(6):
        lines.append(
            f"  joint {i + 1}: stiffness_Nm_per_rad = {k[i]:.3g}   damping_Nms_per_rad = {c[i]:.3g}"
        )
    if ee is not None:
        inertia = ee.inertia_kgm2
        comps = [
            inertia[0, 0],
            inertia[1, 1],
            inertia[2, 2],
            inertia[0, 1],
            inertia[0, 2],
            inertia[1, 2],
        ]
        com = [round(float(x), 4) for x in ee.com_m]
        lines.append(
            f"  [end_effector] mass_kg = {ee.mass_kg:g}, com_m = {com}, "
            f"inertia_kgm2 = {[round(float(x), 4) for x in comps]}"
        )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fit", action="store_true", help="re-run the fit first")
    args = parser.parse_args()
    for name in ("A", "B", "C"):
        robot = load_robot(name)
        if args.fit:
            robot = calibrate_builtin(name, robot)
            print(_toml(name, robot.stiffness, robot.damping, robot.end_effector))
            print()
        q = sample_postures(
            robot, CHECK_POSTURES, np.random.default_rng(CHECK_SEED), TESTED_RANGES_DEG[name]
        )
        print(f"## Robot {name}")
        print()
        print(calibration_report(robot, q, TARGETS[name]).to_markdown())
        print()


if __name__ == "__main__":
    main()
