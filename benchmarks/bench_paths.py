"""Benchmark: reading a 1e6-line G-code program (issue 14).

Workload: a generated 3-axis finishing program (written to a temporary
file, not timed): 1,000,000 blocks, about one in 21 a G2 arc of 1 mm
radius (linearised within 0.01 mm), the rest G1 moves; ~1.5 million
waypoints. Timed: :func:`robolobe.plan.paths.read_toolpath` end to end
(decode, parse, arcs, the waypoint table), wall clock and CPU time of this
process (the CPU figure is the one to compare under load), with the load
average beside it.

Target (issue 14): "seconds, not minutes" for 1e6 lines.

Also timed (``--others N``, default 200,000 lines each): the APT/CL, KRL and
RAPID readers on straight-line programs of N moves (one move per line), to
state their per-line cost; 0 skips them.

Run: ``python benchmarks/bench_paths.py [--lines 1000000] [--others 200000]``.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
import time
from pathlib import Path

from robolobe.plan.paths import read_toolpath


def write_program(path: Path, n_lines: int) -> int:
    """Write the benchmark program; return the number of motion blocks."""
    n = 0
    x = 0.0
    with path.open("w") as f:
        f.write("%\nO1000 (BENCH)\nG21 G90 G17\nS12000 M3\nG0 X0 Y0 Z5\nG1 Z-1 F1200\n")
        while n < n_lines:
            for _ in range(20):
                x += 0.5
                f.write(f"G1 X{x:.3f} Y{10 * math.sin(x / 7):.3f}\n")
                n += 1
            f.write(f"G2 X{x + 2:.3f} Y{10 * math.sin(x / 7):.3f} I1. J0.\n")
            n += 1
            x += 2
            if x > 500:
                x = 0.0
                f.write("G0 X0 Y0\n")
                n += 1
        f.write("M30\n%\n")
    return n


def write_others(folder: Path, n: int) -> dict[str, Path]:
    """Straight-line programs of ``n`` moves in the APT, KRL and RAPID formats."""
    tail = "[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
    rows = [(k * 0.01, 10 * math.sin(k * 0.01)) for k in range(n)]
    apt = folder / "bench.cls"
    with apt.open("w") as f:
        f.write("UNITS/MM\nFEDRAT/MMPM,1200\nRAPID\nGOTO/0,0,5\n")
        f.writelines(f"GOTO/{x:.4f},{y:.4f},-1.0000,0.0,0.0,1.0\n" for x, y in rows)
        f.write("FINI\n")
    krl = folder / "bench.src"
    with krl.open("w") as f:
        f.write("DEF bench()\n$VEL.CP=0.1\n")
        f.writelines(
            f"LIN {{X {x:.4f}, Y {y:.4f}, Z -1, A 0, B 0, C 180}} C_DIS\n" for x, y in rows
        )
        f.write("END\n")
    mod = folder / "bench.mod"
    with mod.open("w") as f:
        f.write("MODULE M\nPROC main()\n")
        f.writelines(
            f"MoveL [[{x:.3f},{y:.3f},-1],[0,0,1,0],{tail},v100,z1,tool0;\n" for x, y in rows
        )
        f.write("ENDPROC\nENDMODULE\n")
    return {"APT/CL": apt, "KRL": krl, "RAPID": mod}


def timed(path: Path) -> tuple[int, float, float]:
    """Waypoints, wall and CPU seconds of one read."""
    w0, c0 = time.perf_counter(), time.process_time()
    df = read_toolpath(path)
    return len(df), time.perf_counter() - w0, time.process_time() - c0


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lines", type=int, default=1_000_000)
    ap.add_argument("--others", type=int, default=200_000)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.nc"
        n = write_program(path, args.lines)
        load0 = os.getloadavg()
        n_wp, wall, cpu = timed(path)
        load1 = os.getloadavg()
        print(f"G-code read: {n} blocks -> {n_wp} waypoints")
        print(f"  wall {wall:.2f} s, CPU {cpu:.2f} s ({1e6 * cpu / n:.2f} us CPU per block)")
        print(f"  load average before/after: {load0[0]:.2f} / {load1[0]:.2f} (1 min)")
        if args.others > 0:
            for name, p in write_others(Path(tmp), args.others).items():
                n_wp, wall, cpu = timed(p)
                print(
                    f"{name} read: {args.others} moves -> {n_wp} waypoints: wall {wall:.2f} s, "
                    f"CPU {cpu:.2f} s ({1e6 * cpu / args.others:.1f} us CPU per line)"
                )
            print(f"  load average now: {os.getloadavg()[0]:.2f} (1 min)")


if __name__ == "__main__":
    main()
