"""Benchmark: modal identification of one posture and of a whole campaign (issues 3, 17).

Workload: robot A's shipped seed design (254 postures), each tested in
simulation (robolobe.twin.hammer, the seed paper's test: 1024 Hz, 4 s,
5 impacts, hits in x, y, z, triaxial response: 9 FRFs per posture), kept up
to 60 Hz (241 lines); the analysis band is 4-40 Hz. The simulation is not
timed. The campaign is identified as ``robolobe identify`` does with a
``frf.csv`` campaign (no coherence: weights proportional across the FRFs) and,
once, with the simulated coherence as weights (per-FRF weights).

Every figure is a ratio to a reference run in this process, alternated with
the current code: the reference is the ``robolobe.modal`` package of an earlier
commit (``--ref``, default ``8d7442a``: the last one before issue 17; e.g.
``ff42868`` for the state before the latest changes), read from git into a
private module name. Without git or that commit the script says so and times
the current code only. Each line prints the load average (``os.getloadavg``)
and both wall and CPU time (this process and its worker processes): on a
shared machine wall time swings 3-6x with load; CPU time and the ratios much
less.

Measured:
- ``posture 3x3`` / ``posture diag``: :func:`identify_posture` on the 9 FRFs
  (the 3 driving points) of one posture, median over ``--repeat`` postures;
- ``campaign j=1``: :func:`identify_frfs` on ``--n`` postures, one process,
  incl. tracking and neighbour recovery (reference, now, reference, now);
- ``campaign j=2``: two worker processes (2 cores); the first call starts
  the workers (cold), the second reuses them (warm);
- ``sdypy-EMA``: LSCF + nearest-pole picking + LSFD on a posture's driving
  points, when installed (the field's open-source peer);
- agreement: rows and largest relative change of f, zeta, k between the
  reference's and the current modal tables (they must not move).

Targets: issue 3: one posture well under a second; the campaign under
2 minutes on 2 cores. Issue 17: robot A's 254 postures under 5 s.

Run: ``python benchmarks/bench_modal.py [--n 254] [--repeat 20] [--ref 8d7442a]``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import os
import resource
import subprocess
import sys
import tarfile
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from robolobe._threads import one_blas_thread
from robolobe.modal.identify import identify_frfs, settings_from_test
from robolobe.modal.posture import identify_posture
from robolobe.modal.synthesis import poles_to_modal
from robolobe.robots import load_robot
from robolobe.twin.designs import design_arrays, load_seed_design
from robolobe.twin.hammer import HammerTestSettings, simulate_hammer_test
from robolobe.twin.model import Twin

REPO = Path(__file__).resolve().parents[1]
#: imports of an older robolobe.modal whose targets have moved since
_MOVED = (
    (
        "from robolobe.twin.uff import frf_value_problem",
        "from robolobe._frf_checks import frf_value_problem",
    ),
)


def cpu_s() -> float:
    """CPU seconds of this process and of its children (finished and running workers)."""
    t = 0.0
    for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN):
        r = resource.getrusage(who)
        t += r.ru_utime + r.ru_stime
    try:
        import psutil

        for c in psutil.Process().children(recursive=True):
            with contextlib.suppress(psutil.Error):
                ct = c.cpu_times()
                t += ct.user + ct.system
    except ImportError:  # workers still alive are then not counted
        pass
    return t


def timed(fn: Callable[[], Any]) -> tuple[Any, float, float, float]:
    """``fn()`` with its wall time, CPU time (incl. workers) and the load average after."""
    c0, t0 = cpu_s(), time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0, cpu_s() - c0, os.getloadavg()[0]


def load_reference(commit: str) -> tuple[ModuleType | None, str]:
    """The ``robolobe.modal`` package of ``commit`` as a private package, or None and why."""
    name = f"_modal_ref_{commit}"
    tmp = Path(tempfile.mkdtemp(prefix="bench_modal_ref_"))
    try:
        blob = subprocess.run(
            ["git", "-C", str(REPO), "archive", commit, "src/robolobe/modal"],
            capture_output=True,
            check=True,
        ).stdout
    except (OSError, subprocess.CalledProcessError) as exc:
        why = exc.stderr.decode(errors="replace").strip() if hasattr(exc, "stderr") else str(exc)
        return None, f"no reference: git archive {commit} failed ({why})"
    with tarfile.open(fileobj=io.BytesIO(blob)) as tf:
        tf.extractall(tmp, filter="data")
    src = tmp / "src" / "robolobe" / "modal"
    dst = tmp / name
    src.rename(dst)
    for p in dst.glob("*.py"):
        text = p.read_text().replace("robolobe.modal", name)
        for was, now in _MOVED:
            text = text.replace(was, now)
        p.write_text(text)
    sys.path.insert(0, str(tmp))
    try:
        return importlib.import_module(name), f"reference: robolobe.modal of commit {commit}"
    except Exception as exc:  # an old package that no longer imports here
        return None, f"no reference: commit {commit}'s robolobe.modal does not import ({exc})"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--n", type=int, default=254, help="postures of robot A")
    ap.add_argument("--repeat", type=int, default=20, help="postures timed one by one")
    ap.add_argument("--ref", default="8d7442a", help="git commit of the reference code")
    args = ap.parse_args(argv)

    ids, q, _ = design_arrays(load_seed_design("A"))
    ids, q = ids[: args.n], q[: args.n]
    n = len(ids)
    twin = Twin(load_robot("A"))
    hs = HammerTestSettings()
    t0 = time.perf_counter()
    res = simulate_hammer_test(
        lambda f: twin.receptance(q, f, method="modal"), rng=np.random.default_rng(0), settings=hs
    )
    keep = res.freq_hz <= 60.0
    f = res.freq_hz[keep]
    H = np.asarray(res.H1)[:, keep]
    coh = np.asarray(res.coherence)[:, keep]
    print(
        f"simulated {n} postures of robot A in {time.perf_counter() - t0:.1f} s (not timed); "
        f"{os.cpu_count()} CPUs visible; load average at start {os.getloadavg()[0]:.1f}"
    )
    test = {"duration_s": hs.duration_s, "window_end": hs.window_end}
    s = settings_from_test(test)
    ref, why = load_reference(args.ref)
    print(why)
    s_ref = ref.identify.settings_from_test(test) if ref is not None else None

    def campaign(mod: Any, settings: Any, jobs: int = 1, coherence: bool = False) -> Any:
        """The modal table of the campaign by ``mod.identify_frfs`` (None: the current code)."""
        fn = identify_frfs if mod is None else mod.identify_frfs
        c = list(coh) if coherence else None
        return fn(ids, q, [f] * n, list(H), coherence=c, settings=settings, n_jobs=jobs).table

    rows: list[tuple[str, float, float, float, str]] = []  # name, wall, cpu, load, note

    def line(name: str, wall: float, cpu: float, load: float, note: str = "") -> None:
        rows.append((name, wall, cpu, load, note))
        print(f"  {name:<40}{wall:>9.3f} s wall{cpu:>9.3f} s CPU   load {load:5.1f}  {note}")

    # ---- one posture at a time (alternated with the reference, posture by posture)
    reps = min(args.repeat, n)
    Hd = np.full_like(H[:reps], np.nan)
    for d in range(3):
        Hd[:, :, d, d] = H[:reps, :, d, d]
    impls: list[tuple[str, Any, Any]] = [("now", identify_posture, s)]
    if ref is not None:
        impls.append(("ref", ref.posture.identify_posture, s_ref))
    per: dict[tuple[str, str], list[float]] = {}

    with one_blas_thread():
        for _tag, fn, st in impls:
            fn(f, H[0], coherence=coh[0], settings=st)  # warm-up
        for p in range(reps):
            for tag, fn, st in impls:
                for kind, h, c in (("3x3", H[p], coh[p]), ("diag", Hd[p], None)):
                    c0 = time.process_time()
                    fn(f, h, coherence=c, settings=st)
                    per.setdefault((tag, kind), []).append(time.process_time() - c0)
    print(f"\none posture (CPU time, median of {reps}; load {os.getloadavg()[0]:.1f}):")
    for kind in ("3x3", "diag"):
        now = float(np.median(per[("now", kind)]))
        note = ""
        if ref is not None:
            r = float(np.median(per[("ref", kind)]))
            note = f"reference {r * 1e3:.1f} ms: {r / now:.2f}x"
        print(f"  posture {kind:<5} now {now * 1e3:6.1f} ms   {note}")

    t_peer = None
    try:
        import sdypy.EMA as EMA

        times, ours = [], []
        for p in range(min(reps, 5)):
            pm = identify_posture(f, H[p], coherence=coh[p], settings=s)
            band = (f >= 0) & (f <= 46)
            Hp = np.stack([H[p, band, d, d] for d in range(3)])
            t0 = time.process_time()
            with (
                warnings.catch_warnings(),
                contextlib.redirect_stdout(io.StringIO()),
                contextlib.redirect_stderr(io.StringIO()),
            ):
                warnings.simplefilter("ignore")
                m = EMA.Model(
                    frf=Hp, freq=f[band], lower=4.0, upper=46.0, pol_order_high=60,
                    frf_form="receptance",
                )  # fmt: skip
                m.get_poles(show_progress=False)
                m.select_closest_poles(list(poles_to_modal(pm.poles_measured)[0]), f_window=2)
                m.get_constants(whose_poles="own", f_lower=4.0, f_upper=46.0)
            times.append(time.process_time() - t0)
            t0 = time.process_time()
            identify_posture(f, Hd[p], settings=s)
            ours.append(time.process_time() - t0)
        t_peer = float(np.median(times))
        print(
            f"  sdypy-EMA diag {t_peer:.3f} s CPU vs ours {np.median(ours):.3f} s "
            f"(same postures, alternated): ours {t_peer / np.median(ours):.0f}x faster"
        )
    except ImportError:
        print("  sdypy-EMA not installed: no peer timing")

    # ---- the campaign, one process: reference, now, reference, now
    print(f"\ncampaign of {n} postures, one process (as `robolobe identify` reads frf.csv):")
    tabs: dict[str, Any] = {}
    pairs = []
    for k in range(2):
        pair = []
        runs: list[tuple[str, Any, Any]] = [("now", None, s)]
        if ref is not None:
            runs.insert(0, ("ref", ref.identify, s_ref))
        for tag, mod, st in runs:
            tab, wall, cpu, load = timed(lambda m=mod, x=st: campaign(m, x))  # type: ignore[misc]
            tabs[tag] = tab
            line(f"{tag} j=1 run {k + 1}", wall, cpu, load, f"{len(tab)} rows")
            pair.append((wall, cpu))
        pairs.append(pair)
    now_cpu = float(np.median([p[-1][1] for p in pairs]))
    now_wall = float(np.median([p[-1][0] for p in pairs]))
    if ref is not None:
        rc = [p[0][1] / p[1][1] for p in pairs]
        rw = [p[0][0] / p[1][0] for p in pairs]
        print(
            f"  now / reference: {np.median(rc):.2f}x less CPU (runs {rc[0]:.2f}, {rc[1]:.2f}), "
            f"{np.median(rw):.2f}x less wall time (runs {rw[0]:.2f}, {rw[1]:.2f})"
        )
        a, b = tabs["ref"], tabs["now"]
        key = ["posture_id", "dir", "mode"]
        same = len(a) == len(b) and bool((a[key].to_numpy() == b[key].to_numpy()).all())
        moved = ", ".join(
            f"{c} {np.max(np.abs(b[c].to_numpy() / a[c].to_numpy() - 1)):.1e}"
            for c in ("f_hz", "zeta", "k_N_per_m")
        ) if same else "n/a"  # fmt: skip
        print(f"  agreement: same rows {same}; largest relative change {moved}")

    print("\nwith the simulated coherence as weights (per-FRF weights), one process:")
    c_now = timed(lambda: campaign(None, s, coherence=True))
    if ref is not None:
        c_ref = timed(lambda: campaign(ref.identify, s_ref, coherence=True))
        line("ref j=1", *c_ref[1:])
    line("now j=1", *c_now[1:])
    if ref is not None:
        print(
            f"  now / reference: {c_ref[2] / c_now[2]:.2f}x less CPU, "
            f"{c_ref[1] / c_now[1]:.2f}x less wall time"
        )

    print("\ntwo worker processes (2 cores), current code:")
    best = now_wall
    for label in ("cold (starts the workers)", "warm (workers reused)"):
        tab, wall, cpu, load = timed(lambda: campaign(None, s, jobs=2))
        line(f"now j=2 {label}", wall, cpu, load, f"{len(tab)} rows")
        print(f"    vs now j=1: {now_wall / wall:.2f}x wall, {cpu / now_cpu:.2f}x the CPU")
        best = min(best, wall)
    print(
        f"\nissue 3 target (< 120 s on 2 cores): {'met' if best < 120 else 'NOT met'}; "
        f"issue 17 target (< 5 s for robot A's 254 postures): "
        f"{('met' if best < 5 else 'NOT met') if n >= 254 else f'not judged ({n} postures)'} "
        f"here: best {best:.2f} s wall at "
        f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; one process needs "
        f"{now_cpu:.2f} s of CPU"
    )


if __name__ == "__main__":
    main()
