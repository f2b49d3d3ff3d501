"""Benchmark: modal identification of one posture and of a whole campaign (issue 3).

Workload: robot A's shipped seed design (254 postures), each tested in
simulation (robolobe.twin.hammer, the seed paper's test: 1024 Hz, 4 s,
5 impacts, hits in x, y, z, triaxial response: 9 FRFs per posture), kept up
to 60 Hz (241 lines); the analysis band is 4-40 Hz. The simulation is not
timed.

Measured, side by side:
- ``posture 3x3``: :func:`robolobe.modal.posture.identify_posture` on the
  9 FRFs of one posture (median over postures);
- ``posture diag``: the same on the 3 driving points only;
- ``campaign j=1`` / ``campaign j=2``: :func:`robolobe.modal.identify.identify_frfs`
  on all 254 postures with 1 and 2 worker processes (2 cores), incl.
  tracking and neighbour recovery;
- reference: sdypy-EMA (LSCF over orders up to 60 + nearest-pole picking +
  LSFD) on the 3 driving points of a posture, when installed; ratio printed.

- ``reference`` (issue 17): the same campaign code as before issue 17
  (finite-difference Jacobians in the pole refinement, BLAS threads not
  limited) on the first ``--n-ref`` postures, alternated twice with the
  current code in this process: the ratio, and how far the written modes
  moved (they must not).

Every time is printed with the load average (``os.getloadavg``): on a
shared machine the absolute figures swing 3-6x with load, the ratios much
less.

Targets: issue 3: one posture well under a second; the 254-posture campaign
of robot A in under 2 minutes on 2 cores. Issue 17: the 254-posture
campaign under 5 s.

Run: ``python benchmarks/bench_modal.py [--n 254] [--repeat 20] [--n-ref 32]``.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import os
import time
import warnings

import numpy as np

from robolobe.modal.identify import identify_frfs, settings_from_test
from robolobe.modal.posture import identify_posture
from robolobe.modal.synthesis import poles_to_modal
from robolobe.robots import load_robot
from robolobe.twin.designs import design_arrays, load_seed_design
from robolobe.twin.hammer import HammerTestSettings, simulate_hammer_test
from robolobe.twin.model import Twin


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=254, help="postures of robot A")
    ap.add_argument("--repeat", type=int, default=20, help="postures timed one by one")
    ap.add_argument("--n-ref", type=int, default=32, help="postures of the reference comparison")
    args = ap.parse_args(argv)

    ids, q, _ = design_arrays(load_seed_design("A"))
    ids, q = ids[: args.n], q[: args.n]
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
        f"simulated {len(ids)} postures in {time.perf_counter() - t0:.1f} s (not timed below); "
        f"{os.cpu_count()} CPUs visible"
    )
    s = settings_from_test({"duration_s": hs.duration_s, "window_end": hs.window_end})

    reps = min(args.repeat, len(ids))
    identify_posture(f, H[0], coherence=coh[0], settings=s)  # warm-up
    t_full, t_diag = [], []
    Hd = np.full_like(H[:reps], np.nan)
    for d in range(3):
        Hd[:, :, d, d] = H[:reps, :, d, d]
    for p in range(reps):
        t0 = time.perf_counter()
        identify_posture(f, H[p], coherence=coh[p], settings=s)
        t_full.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        identify_posture(f, Hd[p], settings=s)
        t_diag.append(time.perf_counter() - t0)
    tf, td = float(np.median(t_full)), float(np.median(t_diag))

    t_peer = None
    try:
        import sdypy.EMA as EMA

        times = []
        for p in range(min(reps, 5)):
            pm = identify_posture(f, H[p], coherence=coh[p], settings=s)
            Hp = np.stack([H[p, (f >= 0) & (f <= 46), d, d] for d in range(3)])
            fp = f[(f >= 0) & (f <= 46)]
            t0 = time.perf_counter()
            with (
                warnings.catch_warnings(),
                contextlib.redirect_stdout(io.StringIO()),
                contextlib.redirect_stderr(io.StringIO()),
            ):
                warnings.simplefilter("ignore")
                m = EMA.Model(
                    frf=Hp, freq=fp, lower=4.0, upper=46.0, pol_order_high=60, frf_form="receptance"
                )
                m.get_poles(show_progress=False)
                m.select_closest_poles(list(poles_to_modal(pm.poles_measured)[0]), f_window=2)
                m.get_constants(whose_poles="own", f_lower=4.0, f_upper=46.0)
            times.append(time.perf_counter() - t0)
        t_peer = float(np.median(times))
    except ImportError:
        pass

    # ---- reference (code before issue 17) vs now, alternated, same process
    n_ref = min(args.n_ref, len(ids))
    s_fd = dataclasses.replace(s, refine_jacobian="fd")
    unlimited = identify_frfs.__wrapped__  # type: ignore[attr-defined]
    sub = (ids[:n_ref], q[:n_ref], [f] * n_ref, list(H[:n_ref]))
    t_ref, t_new = [], []
    for _ in range(2):
        t0 = time.perf_counter()
        ref_tab = unlimited(*sub, coherence=list(coh[:n_ref]), settings=s_fd).table
        t_ref.append((time.perf_counter() - t0, os.getloadavg()[0]))
        t0 = time.perf_counter()
        new_tab = identify_frfs(*sub, coherence=list(coh[:n_ref]), settings=s).table
        t_new.append((time.perf_counter() - t0, os.getloadavg()[0]))
    key = ["posture_id", "dir", "mode"]
    same_rows = len(ref_tab) == len(new_tab) and bool(
        (ref_tab[key].to_numpy() == new_tab[key].to_numpy()).all()
    )
    moved = {
        c: float(np.max(np.abs(new_tab[c].to_numpy() / ref_tab[c].to_numpy() - 1)))
        if same_rows
        else float("nan")
        for c in ("f_hz", "zeta", "k_N_per_m")
    }

    results = {}
    for jobs in (1, 2):
        t0 = time.perf_counter()
        cm = identify_frfs(
            ids, q, [f] * len(ids), list(H), coherence=list(coh), settings=s, n_jobs=jobs
        )
        results[jobs] = (
            time.perf_counter() - t0,
            len(cm.table),
            cm.n_recovered,
            os.getloadavg()[0],
        )

    print(f"\n{'workload':<34}{'time':>10}{'per posture':>14}{'note':>34}")
    print(f"{'posture 3x3 (9 FRFs), median':<34}{tf:>9.3f}s{tf:>13.3f}s")
    print(f"{'posture diag (3 FRFs), median':<34}{td:>9.3f}s{td:>13.3f}s")
    if t_peer is not None:
        print(
            f"{'sdypy-EMA diag (3 FRFs), median':<34}{t_peer:>9.3f}s{t_peer:>13.3f}s"
            f"{f'robolobe is {t_peer / td:.1f}x faster':>34}"
        )
    for jobs, (t, rows, rec, load) in results.items():
        note = f"{rows} rows, {rec} recovered, load {load:.1f}"
        print(
            f"{f'campaign {len(ids)} postures, j={jobs}':<34}{t:>9.1f}s"
            f"{t / len(ids):>13.3f}s{note:>34}"
        )
    print(f"\nreference (before issue 17) vs now, {n_ref} postures, j=1, same process:")
    for k in range(2):
        (tr, lr), (tn, ln) = t_ref[k], t_new[k]
        print(
            f"  run {k + 1}: reference {tr:.2f} s (load {lr:.1f}), now {tn:.2f} s "
            f"(load {ln:.1f}): {tr / tn:.1f}x"
        )
    ratio = float(np.median([a[0] / b[0] for a, b in zip(t_ref, t_new, strict=True)]))
    print(
        f"  same rows: {same_rows}; largest relative change f {moved['f_hz']:.1e}, "
        f"zeta {moved['zeta']:.1e}, k {moved['k_N_per_m']:.1e}"
    )
    t1, t2 = results[1][0], results[2][0]
    best = min(t1, t2)
    print(
        f"\nspeed-up with 2 workers: {t1 / t2:.2f}x; issue 3 target < 120 s on 2 cores: "
        f"{'met' if t2 < 120 else 'NOT met'} ({t2:.1f} s); issue 17 target < 5 s: "
        f"{'met' if best < 5 else 'NOT met'} ({best:.1f} s at load "
        f"{min(results[1][3], results[2][3]):.1f}; the reference would take ~{best * ratio:.0f} s "
        f"here, {ratio:.1f}x)"
    )


if __name__ == "__main__":
    main()
