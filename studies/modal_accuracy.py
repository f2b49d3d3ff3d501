"""Accuracy study of robolobe.modal on simulated hammer-test campaigns of robots A, B, C.

For each robot the shipped seed design (A: 254 postures, B: 25, C: 29) is
tested in simulation (robolobe.twin.hammer: 1024 Hz, 4 s records, 5 impacts,
H1, exponential window to 5 %, force and accelerometer noise; ``--noise``
scales the noise), the campaign is identified with the defaults of
``robolobe identify`` and the result is compared with the twin's true modes
(``Twin.modes``: f_hz, zeta, undamped driving-point modal stiffness).

Definitions (robolobe.modal.validation and below): a true mode is *visible* at a
driving point when the peak of its term in the measured (windowed) FRF is at
least 5 % of the FRF's largest value in 4-40 Hz; identified rows are paired
with true modes per posture and direction by frequency (within 5 %);
*missed* = visible true modes without a partner, *spurious* = rows without
any true partner. FRAC / NRMSE: the FRF synthesized from the written rows
(damping as seen through the window) against the measured one, 4-40 Hz.

Optionally (``--peer``) the same FRFs of some postures are also identified
with sdypy-EMA (LSCF + LSFD with nearest-pole picking at the poles we found)
to compare.

Run: ``python studies/modal_accuracy.py [--robots ABC] [--n N] [--noise 1 3] [--jobs 2]
[--peer 10]``.
"""

from __future__ import annotations

import argparse
import time
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from robolobe.modal.validation import AccuracyReport, compare_with_truth, true_visibility

_AX = "xyz"


@dataclass(frozen=True)
class StudyResult:
    """Outcome of :func:`accuracy_study` for one robot.

    Attributes
    ----------
    robot : str
    n_postures : int
    report : AccuracyReport
    fit : pandas.DataFrame
        FRAC / NRMSE per posture and direction (``CampaignModal.fit``).
    seconds_identify : float
        Wall time of the identification.
    n_recovered : int
    issues : int
        Number of data-quality findings (warnings and errors).
    """

    robot: str
    n_postures: int
    report: AccuracyReport
    fit: pd.DataFrame
    seconds_identify: float
    n_recovered: int
    issues: int


def accuracy_study(
    robot: str,
    *,
    n_postures: int | None,
    rng: np.random.Generator,
    noise: float = 1.0,
    n_jobs: int = 1,
    excite: str = "xyz",
    use_coherence: bool = True,
) -> StudyResult:
    """Simulate a hammer-test campaign of a built-in robot and identify it.

    The postures are the robot's shipped seed design (the first
    ``n_postures`` of it, or all); each is tested with
    :func:`robolobe.twin.hammer.simulate_hammer_test` (seed paper's test:
    1024 Hz, 4 s, 5 impacts, exponential window to 5 %, noise scaled by
    ``noise``) on the twin's receptance; the identified table is compared
    with the twin's true modes (:meth:`Twin.modes`: ``f_hz``, ``zeta`` and
    the undamped driving-point modal stiffness ``k_N_per_m``).

    Parameters
    ----------
    robot : {"A", "B", "C"}
    n_postures : int or None
    rng : numpy.random.Generator
    noise : float
        Multiplier of the default force and acceleration noise.
    n_jobs : int
        Workers of the identification.
    excite : str
        Directions hit.
    use_coherence : bool
        Give the coherence to the identification (a campaign read from
        ``frf.csv`` has none; ``robolobe identify`` then weights without it).

    Returns
    -------
    StudyResult
    """
    from robolobe.modal.identify import identify_frfs, settings_from_test
    from robolobe.robots import load_robot
    from robolobe.twin.designs import design_arrays, load_seed_design
    from robolobe.twin.hammer import HammerTestSettings, simulate_hammer_test
    from robolobe.twin.model import Twin

    ids, q, _ = design_arrays(load_seed_design(robot))
    if n_postures is not None:
        ids, q = ids[:n_postures], q[:n_postures]
    twin = Twin(load_robot(robot))
    hs = HammerTestSettings(force_noise_n=0.2 * noise, accel_noise_m_per_s2=2e-3 * noise)
    res = simulate_hammer_test(
        lambda f: twin.receptance(q, f, method="modal"), rng=rng, settings=hs, excite=excite
    )
    keep = res.freq_hz <= 60.0
    freq = res.freq_hz[keep]
    H = np.asarray(res.H1)[:, keep]
    coh = np.asarray(res.coherence)[:, keep]
    s = settings_from_test({"duration_s": hs.duration_s, "window_end": hs.window_end})
    t0 = time.perf_counter()
    cm = identify_frfs(
        ids,
        q,
        [freq] * len(ids),
        list(H),
        coherence=list(coh) if use_coherence else None,
        settings=s,
        n_jobs=n_jobs,
    )
    seconds = time.perf_counter() - t0
    modes = twin.modes(q)
    vis = true_visibility(
        modes.poles,
        modes.residues,
        freq,
        band_hz=(s.fmin_hz, s.fmax_hz),
        window_decay_per_s=s.window_decay_per_s,
    )
    report = compare_with_truth(
        cm.table,
        ids,
        modes.f_hz,
        modes.zeta,
        modes.k_N_per_m,
        vis,
        dirs=[_AX[d] * 2 for d in range(3) if _AX[d] in excite],
    )
    n_issues = sum(1 for i in cm.issues if i.severity != "info")
    return StudyResult(robot, len(ids), report, cm.fit, seconds, cm.n_recovered, n_issues)


def _row(robot: str, noise: float, res) -> str:  # type: ignore[no-untyped-def]
    rep = res.report
    m = rep.matched
    p90 = rep.percentile(90)
    p50 = rep.percentile(50)
    return (
        f"{robot:>2} {noise:5.1f} {res.n_postures:4d} {rep.n_visible:5d} {len(m):5d} "
        f"{len(rep.missed):4d} {len(rep.spurious):4d} | "
        f"{100 * p50['f']:.3f} {100 * p90['f']:.3f} {100 * m['err_f'].max():.3f} | "
        f"{100 * p50['zeta']:.2f} {100 * p90['zeta']:.2f} {100 * m['err_zeta'].max():.1f} | "
        f"{100 * p50['k']:.2f} {100 * p90['k']:.2f} {100 * m['err_k'].max():.1f} | "
        f"{res.fit['frac'].min():.3f} {res.fit['frac'].median():.3f} "
        f"{res.fit['nrmse'].median():.3f} {res.fit['nrmse'].max():.3f} | "
        f"{res.seconds_identify:6.1f}"
    )


def peer_comparison(robot: str, n: int, seed: int) -> None:
    """Identify ``n`` postures with robolobe and sdypy-EMA and compare with the truth."""
    try:
        import sdypy.EMA as EMA
    except ImportError:
        print("sdypy-EMA not installed: pip install sdypy-EMA")
        return
    import contextlib
    import io

    from robolobe.modal.identify import settings_from_test
    from robolobe.modal.lsfd import modal_stiffness
    from robolobe.modal.posture import identify_posture
    from robolobe.modal.synthesis import modal_to_poles, poles_to_modal
    from robolobe.robots import load_robot
    from robolobe.twin.designs import design_arrays, load_seed_design
    from robolobe.twin.hammer import HammerTestSettings, simulate_hammer_test
    from robolobe.twin.model import Twin

    _ids, q, _ = design_arrays(load_seed_design(robot))
    q = q[:n]
    twin = Twin(load_robot(robot))
    hs = HammerTestSettings()
    res = simulate_hammer_test(
        lambda f: twin.receptance(q, f, method="modal"),
        rng=np.random.default_rng(seed),
        settings=hs,
    )
    s = settings_from_test({"duration_s": hs.duration_s, "window_end": hs.window_end})
    modes = twin.modes(q)
    f = res.freq_hz[:185]
    rows = []
    t_ours = t_peer = 0.0
    for p in range(q.shape[0]):
        t0 = time.perf_counter()
        pm = identify_posture(f, res.H1[p][:185], coherence=res.coherence[p][:185], settings=s)
        t_ours += time.perf_counter() - t0
        Hd = np.stack([res.H1[p][:185, d, d] for d in range(3)])
        t0 = time.perf_counter()
        with (
            warnings.catch_warnings(),
            contextlib.redirect_stdout(io.StringIO()),
            contextlib.redirect_stderr(io.StringIO()),
        ):
            warnings.simplefilter("ignore")
            model = EMA.Model(
                frf=Hd, freq=f, lower=4.0, upper=46.0, pol_order_high=60, frf_form="receptance"
            )
            model.get_poles(show_progress=False)
            model.select_closest_poles(list(poles_to_modal(pm.poles_measured)[0]), f_window=2)
            _, A = model.get_constants(whose_poles="own", f_lower=4.0, f_upper=46.0)
        t_peer += time.perf_counter() - t0
        lam = modal_to_poles(np.asarray(model.nat_freq), np.asarray(model.nat_xi))
        lam = lam + s.window_decay_per_s
        fp, zp = poles_to_modal(lam)
        kp = modal_stiffness(lam, np.asarray(A).T)
        for r in range(pm.n_modes):
            j = int(np.argmin(np.abs(modes.f_hz[p] - pm.f_hz[r])))
            d = int(np.argmax(pm.visibility[:, r]))
            kt = modes.k_N_per_m[p, d, j]
            rows.append(
                (
                    abs(pm.f_hz[r] / modes.f_hz[p, j] - 1),
                    abs(fp[r] / modes.f_hz[p, j] - 1),
                    abs(pm.zeta[r] / modes.zeta[p, j] - 1),
                    abs(zp[r] / modes.zeta[p, j] - 1),
                    abs(pm.k_N_per_m[d, r] / kt - 1),
                    abs(kp[r, d] / kt - 1),
                    abs(fp[r] / pm.f_hz[r] - 1) > 0.005,
                )
            )
    e = np.array(rows, dtype=float)
    merged = int(e[:, 6].sum())
    ok = e[:, 6] == 0
    print(
        f"\npeer cross-check, robot {robot}, {q.shape[0]} postures, {len(e)} modes "
        f"(strongest driving point each):"
    )
    print(
        f"  sdypy-EMA picked another pole than ours (>0.5 % away; merged close modes): "
        f"{merged} of {len(e)}"
    )
    for name, a, b in (("f", 0, 1), ("zeta", 2, 3), ("k", 4, 5)):
        print(
            f"  {name:>4}: 90th pct |error| robolobe {100 * np.percentile(e[:, a], 90):.2f} %, "
            f"sdypy-EMA {100 * np.percentile(e[:, b], 90):.2f} % "
            f"(same-pole subset: {100 * np.percentile(e[ok, b], 90):.2f} %)"
        )
    print(
        f"  time per posture: robolobe {t_ours / q.shape[0]:.3f} s, "
        f"sdypy-EMA {t_peer / q.shape[0]:.3f} s"
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", default="ABC")
    ap.add_argument("--n", type=int, default=None, help="postures per robot (default: all)")
    ap.add_argument("--noise", type=float, nargs="+", default=[1.0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--peer", type=int, default=0, help="postures of B for the sdypy check")
    ap.add_argument(
        "--no-coherence",
        action="store_true",
        help="identify without the coherence (as robolobe identify on a frf.csv campaign)",
    )
    args = ap.parse_args(argv)

    print(
        "relative errors in %: p50 / p90 / max; FRAC min / median; NRMSE median / max; "
        "identification wall time [s]"
    )
    print(
        "rb noise post   vis match miss spur |   f p50  p90   max | zeta p50 p90 max |"
        "    k p50 p90  max | FRAC        NRMSE       |   time"
    )
    for robot in args.robots:
        for noise in args.noise:
            t0 = time.perf_counter()
            res = accuracy_study(
                robot,
                n_postures=args.n,
                rng=np.random.default_rng(args.seed),
                noise=noise,
                n_jobs=args.jobs,
                use_coherence=not args.no_coherence,
            )
            print(_row(robot, noise, res), f"(total {time.perf_counter() - t0:.0f} s)", flush=True)
            if len(res.report.missed):
                print("   missed:", res.report.missed.round(3).to_dict("records")[:5])
            if len(res.report.spurious):
                print("   spurious:", res.report.spurious.round(3).to_dict("records")[:5])
    if args.peer:
        peer_comparison("B", args.peer, args.seed)


if __name__ == "__main__":
    main()
