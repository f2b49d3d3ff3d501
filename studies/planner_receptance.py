"""How far the planner's robot receptance is from the twin's exact one.

The planner builds the robot's receptance from the twin's modes in the
real-mode (modal stiffness) form, ``sum_r u_r u_r^T / (w_r^2 - w^2 + 2 i
zeta_r w_r w)``, with an overdamped mode kept at the frequency and damping
ratio of its real poles. The truth here is the twin's receptance solved
directly, ``J (K - w^2 M + i w C)^-1 J^T`` (:func:`robolobe.twin.frf.receptance`),
at random postures within the joint limits (seed 1), on 1-1500 Hz plus the
planner's own frequency grid.
Printed per robot, for the postures with and without an overdamped mode: the
ratio model / exact of the most negative real part of each driving-point FRF
(what sets a chatter limit; below 1 the model allows more depth than the
exact receptance), its range, median, and the share of postures below 0.9.

    python studies/planner_receptance.py                       # A, B, C, example robot
    python studies/planner_receptance.py --robots A --postures 400
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from robolobe.plan.modes import TwinSource
from robolobe.robots import load_robot
from robolobe.twin import Twin
from robolobe.twin.frf import receptance

EXAMPLE = str(Path(__file__).resolve().parents[1] / "examples" / "robots" / "my_robot.toml")


def ratios(robot_name: str, n: int, chunk: int = 25) -> tuple[np.ndarray, np.ndarray]:
    """(ratio per posture and driving point (n, 3), overdamped flag per posture (n,))."""
    robot = load_robot(robot_name)
    twin = Twin(robot)
    q = np.random.default_rng(1).uniform(robot.q_min, robot.q_max, (n, 6))
    src = TwinSource(robot)
    out, over = [], []
    for a in range(0, n, chunk):  # chunks: each holds two (chunk, n_freq, 3, 3) receptances
        qq = q[a : a + chunk]
        md = twin.modes(qq, overdamped="keep")
        rm = src.predict(qq)
        f = np.union1d(np.linspace(1.0, 1500.0, 3000), rm.model.frequency_grid() / (2 * np.pi))
        w = 2 * np.pi * f
        s = twin.system(qq)
        exact = receptance(s.M, s.K, s.C, s.J, f)
        model = rm.model.frf(w)
        out.append(
            np.stack(
                [model[:, :, d, d].real.min(1) / exact[:, :, d, d].real.min(1) for d in range(3)],
                axis=1,
            )
        )
        over.append((md.zeta >= 1.0).any(axis=-1))
    return np.concatenate(out), np.concatenate(over)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", default=f"A,B,C,{EXAMPLE}")
    ap.add_argument("--postures", type=int, default=150)
    args = ap.parse_args()
    for name in args.robots.split(","):
        r, over = ratios(name, args.postures)
        for label, sel in (("overdamped", over), ("underdamped", ~over)):
            if not sel.any():
                continue
            x = r[sel]
            print(
                f"{Path(name).name}: {label} postures {int(sel.sum())}: model / exact "
                f"{x.min():.2f} .. {x.max():.2f}, median {np.median(x):.3f}, "
                f"postures below 0.9: {np.mean(x.min(axis=1) < 0.9):.0%}"
            )


if __name__ == "__main__":
    main()
