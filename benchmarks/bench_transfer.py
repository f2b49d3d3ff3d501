"""CPU time of the default transfer on the out-of-form study's campaigns (issue 27).

    python benchmarks/bench_transfer.py                        # B8, C18, B7, B1
    python benchmarks/bench_transfer.py --draws B8 --reference /tmp/base/src --busy 1

Workload: the 20-test campaigns of ``studies/out_of_form.py`` (a concealed
robot outside robolobe's model form, simulated and identified as the study
does; not timed), each transferred as ``robolobe transfer modal.csv --robot
R`` does it (:func:`robolobe.transfer`, method corrected-twin) in a fresh
process. The draws are the study's slowest transfers (B8 took 15.0 s CPU
there on a loaded machine, C18, B7 and B1 about 10 s).

Printed per draw: the transfer's CPU time (``time.process_time`` of its
process, which starts no workers) and its ratio to the goal. With
``--reference SRC`` (another checkout's ``src``, e.g. the main branch's) the
same campaign is transferred by that code too, in turn with this one (the
order alternating), and the two models are compared: the largest relative
difference of f, zeta and k predicted at the campaign's postures and at 200
random postures within the joint limits, and of the predicted spread. With
``--busy N`` every run is repeated beside N CPU-bound processes (on a shared
machine an optimisation must not lose under load).

Goal (issue 27): under 15 s on 2 cores for a 20-test campaign. CPU time is
what to compare on a shared machine; compare the ratio to the reference
within one run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "studies"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

GOAL_S = 15.0

#: Transfers one campaign in a fresh process: argv modal.csv, robot, out.npz;
#: prints the transfer's CPU seconds as JSON.
_RUNNER = """
import json, sys, time, warnings
import numpy as np
warnings.simplefilter("ignore")
from robolobe.modal.modal_csv import read_modal_csv
from robolobe.robots import load_robot
from robolobe.tl.transfer import transfer
csv, key, out = sys.argv[1:4]
t = time.process_time()
model = transfer(csv, robot=key)
cpu = time.process_time() - t
rob = load_robot(key)
df = read_modal_csv(csv)
cols = [f"q{i}_deg" for i in range(1, 7)]
q_tests = np.deg2rad(df.groupby("posture_id")[cols].first().to_numpy())
u = np.random.default_rng(12345).random((200, 6))
q_new = rob.q_min + (rob.q_max - rob.q_min) * (0.1 + 0.8 * u)
p, r = model.predict(q_tests, warn=False), model.predict(q_new, warn=False)
np.savez(out, tests=p.center, tests_std=p.std, new=r.center, new_std=r.std)
print(json.dumps({"cpu_s": cpu}))
"""


def campaign(tag: str, folder: Path) -> tuple[Path, str]:
    """The study's campaign of draw ``tag`` (e.g. ``"B8"``) as ``modal.csv``; its robot key."""
    from out_of_form import draw_truth, hammer_tests
    from plan_safety import robot_file

    from robolobe.modal.modal_csv import write_modal_csv

    key, draw = tag[0], int(tag[1:])
    spec, base = robot_file(key, folder)
    csv = folder / f"{tag}.csv"
    write_modal_csv(csv, hammer_tests(draw_truth(base, key, draw), base, key, draw))
    return csv, spec


def transfer_cpu(src: Path, csv: Path, key: str, out: Path) -> float:
    """CPU seconds of one transfer by the robolobe in ``src``, in a fresh process."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    res = subprocess.run(
        [sys.executable, "-c", _RUNNER, str(csv), key, str(out)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if res.returncode != 0:
        raise RuntimeError(f"transfer of {csv.name} by {src} failed:\n{res.stderr[-2000:]}")
    return float(json.loads(res.stdout.strip().splitlines()[-1])["cpu_s"])


def differences(a: Path, b: Path) -> dict[str, float]:
    """Largest relative differences of f, zeta, k (and of the spread) between two runs."""
    x, y = np.load(a), np.load(b)
    out: dict[str, float] = {}
    for part in ("tests", "new"):
        if not np.array_equal(np.isfinite(x[part]), np.isfinite(y[part])):
            out[f"{part} nan"] = float("inf")
            continue
        d = np.abs(np.expm1(np.nan_to_num(x[part] - y[part])))  # logs: relative
        for c, name in enumerate(("f", "zeta", "k")):
            out[f"{part} {name}"] = float(d[..., c].max())
        out[f"{part} spread"] = float(np.nanmax(np.abs(x[f"{part}_std"] - y[f"{part}_std"])))
    return out


def run(tags: list[str], reference: Path | None, busy: int, tmp: Path) -> None:
    from bench_load import busy_processes

    here = REPO / "src"
    cases = {}
    for tag in tags:
        t = time.perf_counter()
        cases[tag] = campaign(tag, tmp)
        print(f"{tag}: campaign made ({time.perf_counter() - t:.0f} s, not timed)", flush=True)
    phases = [("as the machine is", 0)] + ([(f"beside {busy} busy", busy)] if busy else [])
    for label, n_busy in phases:
        load = os.getloadavg()[0]
        print(f"--- {label} (load {load:.1f} at the start)", flush=True)
        with busy_processes(n_busy):
            for k, tag in enumerate(tags):
                csv, key = cases[tag]
                srcs = [("this", here)] + ([("reference", reference)] if reference else [])
                if k % 2:
                    srcs.reverse()
                cpu = {}
                for name, src in srcs:
                    cpu[name] = transfer_cpu(src, csv, key, tmp / f"{tag}-{name}.npz")
                line = (
                    f"{tag}: {cpu['this']:.2f} s CPU ({cpu['this'] / GOAL_S:.2f} of {GOAL_S:g} s)"
                )
                if reference:
                    line += (
                        f"; reference {cpu['reference']:.2f} s, ratio "
                        f"{cpu['this'] / cpu['reference']:.2f}"
                    )
                print(line, flush=True)
                if reference:
                    diff = differences(tmp / f"{tag}-this.npz", tmp / f"{tag}-reference.npz")
                    print(
                        "    largest difference to the reference: "
                        + ", ".join(f"{k} {v:.1e}" for k, v in diff.items()),
                        flush=True,
                    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--draws", default="B8,C18,B7,B1", help="study draws, e.g. B8,C18")
    ap.add_argument("--reference", type=Path, default=None, help="another checkout's src")
    ap.add_argument("--busy", type=int, default=0, help="repeat beside N busy processes")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        run([t.strip() for t in a.draws.split(",") if t.strip()], a.reference, a.busy, Path(tmp))


if __name__ == "__main__":
    main()
