"""Built-in robots B and C against the seed paper's measured modes (Tables 4 and 7).

For each of B and C prints

1. the table's copy errors found from the tables alone
   (:func:`robolobe.twin.seed_tables.table_checks`);
2. the shipped robot file's FRAC and frequency errors against the table;
3. the table fit (:func:`robolobe.twin.calibration.fit_seed_table`, joint tilt
   and mount compliance, load-dependent stiffness of joints 2-6 by default,
   springs within :data:`~robolobe.twin.calibration.LITERATURE_K_BOUNDS`,
   from the prior :func:`seed_prior`): measured vs twin
   per posture and mode (frequency, damping, relative modal stiffness), FRAC
   of its yy receptance against the one rebuilt from the table (2-40 Hz), and
   a verdict per value;
4. leave-one-posture-out: the fit (:func:`robolobe.twin.calibration.fit_seed_table`)
   rerun from the prior (the robot file's kinematics and masses, prior joint
   stiffness, no compliance values) on two postures, predicting the third.

Run from the repository root (a few minutes; ``--starts`` trades time for
the chance of finding the best fit; ``--no-lopo`` skips step 3)::

    python studies/seed_tables.py [--starts 12] [--no-lopo] [--mass-bound 0.3] [--json out.json]
        [--load-joints 2,3,4,5,6] [--free-bounds] [--direction 1] [--robots B,C]
        [--shape-bodies 2,3,ee] [--com-bound-m 0.3] [--ee-com-bound-m 0.1] [--inertia-bound 1.0]
        [--tilt-joints 1,2,3,4,5] [--robot-out DIR] [--truth FILE]

``--shape-bodies`` also fits the mass distribution (centre-of-mass offset and
principal inertias, :attr:`~robolobe.twin.calibration.SeedFitForm.shape_bodies`) of
the named bodies (1-based links, ``ee`` the spindle and bracket); ``--robot-out``
writes each three-posture fit as a candidate robot file ``<DIR>/<robot>_seed_fit.toml``
(a study output: the shipped files are unchanged). ``--truth FILE`` replaces
the table with that robot file's own matched modes (exact data from a twin
inside the fit's form: what three postures can identify at best).

Before the fit it prints how close a twin must be for FRAC >= 0.8 (random modal
twins around the table) and the bound on a gravity balancer's axis-2 stiffness.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time

import numpy as np

from robolobe._atomic import atomic_write_text
from robolobe.robots import Robot, load_robot
from robolobe.robots.io import robot_to_toml
from robolobe.twin.calibration import (
    LITERATURE_K_BOUNDS,
    SEED_FIT_STARTS,
    SeedFitForm,
    compare_to_table,
    fit_seed_table,
    lopo_frequency_spread,
    seed_fit_parameter_count,
    seed_prior,
    value_verdicts,
)
from robolobe.twin.seed_tables import K_UNIT_N_PER_M, SEED_TABLES, SeedTable, table_checks


def _fmt_row(p: int, m: int, t, c) -> str:
    return (
        f"| {p + 1} | {m + 1} | {t.f_hz[p, m]:.2f} | {c.f_hz[p, m]:.2f} | "
        f"{100 * c.f_err[p, m]:+.1f} | {100 * t.zeta[p, m]:.2f} | {100 * c.zeta[p, m]:.2f} | "
        f"{t.ema[2, p, m]:.2f} | {c.k_N_per_m[p, m] / c.k_level / 1e5:.2f} |"
    )


def _frac_tolerance(t: SeedTable, rng: np.random.Generator, n: int = 1000) -> None:
    """How close a twin must be for FRAC >= 0.8: random modal twins around the table."""
    from robolobe.campaign.metrics import frac
    from robolobe.twin.frf import modal_receptance

    grid = np.arange(2.0, 40.0 + 1e-9, 0.25)
    l15 = np.log(1.5)
    for p in range(3):
        f, z, k = t.f_hz[p], t.zeta[p], t.k_N_per_m[p]
        ht = modal_receptance(f, z, k, grid)
        one = []
        for m in range(5):
            f1 = f.copy()
            f1[m] *= 1.01
            one.append(float(frac(modal_receptance(f1, z, k, grid), ht)))
        line = []
        for tol in (0.01, 0.03):
            ff = f * np.exp(rng.uniform(-tol, tol, (n, 5)))
            zz = z * np.exp(rng.uniform(-l15, l15, (n, 5)))
            kk = k * np.exp(rng.uniform(-l15, l15, (n, 5)))
            v = np.asarray(frac(modal_receptance(ff, zz, kk, grid), ht, axis=-1))
            line.append(f"f within {100 * tol:.0f} %: median {np.median(v):.2f}, "
                        f"P(FRAC >= 0.8) {np.mean(v >= 0.8):.2f}")  # fmt: skip
        print(f"  posture {p + 1}: " + "; ".join(line)
              + "; one mode 1 % high: FRAC " + " ".join(f"{v:.2f}" for v in one))  # fmt: skip


def _balancer_bound(name: str, robot: Robot, t: SeedTable) -> None:
    """Upper bound of what a gravity balancer on axis 2 can do to the axis-2 spring."""
    from robolobe.twin.dynamics import gravity_torques

    qs = np.repeat(t.postures_rad, 181, axis=0)
    qs[:, 1] = np.tile(np.radians(np.linspace(-90.0, 90.0, 181)), 3)
    tmax = float(np.abs(gravity_torques(robot, qs)[:, 1]).max())
    print(f"{name}: largest axis-2 gravity torque over q2 in -90..90 deg {tmax:.0f} N m: a "
          f"balancer that holds it (zero-length spring, torque ~ sin) has at most "
          f"{tmax:.0f} N m/rad, {100 * tmax / robot.stiffness[1]:.2f} % of the axis-2 spring "
          f"({robot.stiffness[1]:.3g}): <= {50 * tmax / robot.stiffness[1]:.2f} % in "
          "frequency")  # fmt: skip


def _synthetic_table(t: SeedTable, truth: Robot) -> SeedTable:
    """The table a twin in the fit's form would give: ``truth``'s modes matched to ``t``
    (frequency, damping, modal stiffness at its own level), exact, in ``t``'s units."""
    c = compare_to_table(truth, t)
    ema = np.stack([c.f_hz, 100.0 * c.zeta, c.k_N_per_m / c.k_level / K_UNIT_N_PER_M])
    return dataclasses.replace(
        t, ema=ema, tl=ema.copy(), err_pct=np.zeros_like(ema),
        source=f"synthetic: {truth.name} matched to {t.source}",
    )  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=SEED_FIT_STARTS // 2)
    ap.add_argument("--no-lopo", action="store_true")
    ap.add_argument("--json", default=None)
    ap.add_argument(
        "--mass-bound",
        type=float,
        default=0.3,
        help="bound on the log factors of link and spindle masses (0 keeps them; 0.3: x0.74-1.35)",
    )
    ap.add_argument(
        "--load-joints",
        default="2,3,4,5,6",
        help="1-based joints with load-dependent stiffness (comma list; '' for none)",
    )
    ap.add_argument(
        "--free-bounds",
        action="store_true",
        help="log-factor bounds only, no literature bounds on the springs",
    )
    ap.add_argument("--robots", default="B,C")
    ap.add_argument(
        "--shape-bodies",
        default="",
        help="bodies whose COM offset and principal inertias are fitted (1-6, ee; '' none)",
    )
    ap.add_argument("--com-bound-m", type=float, default=0.3, help="links' COM offset bound")
    ap.add_argument("--ee-com-bound-m", type=float, default=0.1, help="spindle's COM offset bound")
    ap.add_argument(
        "--tilt-joints", default="1,2,3,4,5", help="1-based joints with tilt compliance"
    )
    ap.add_argument("--inertia-bound", type=float, default=1.0)
    ap.add_argument("--robot-out", default=None, help="folder for the fitted robot files")
    ap.add_argument(
        "--truth",
        default=None,
        help="robot file whose own modes replace the table (exact data from a twin inside "
        "the fit's form: what three postures can identify); one robot only",
    )
    ap.add_argument(
        "--direction",
        type=int,
        default=1,
        help="TCP axis the table's Y is taken as (0 x, 1 y, 2 z): the tool frame is an estimate",
    )
    args = ap.parse_args()
    load = tuple(int(j) - 1 for j in args.load_joints.split(",") if j.strip())
    shape = tuple(
        6 if b.strip() == "ee" else int(b) - 1 for b in args.shape_bodies.split(",") if b.strip()
    )
    form = SeedFitForm(
        link_mass_bound=args.mass_bound,
        ee_mass_bound=args.mass_bound,
        load_joints=load,
        k_bounds_Nm_per_rad=None if args.free_bounds else LITERATURE_K_BOUNDS,
        direction=args.direction,
        shape_bodies=shape,
        com_bound_m=args.com_bound_m,
        ee_com_bound_m=args.ee_com_bound_m,
        tilt_joints=tuple(int(j) - 1 for j in args.tilt_joints.split(",") if j.strip()),
        inertia_bound=args.inertia_bound,
    )
    d = args.direction
    out: dict[str, object] = {}
    print("Copy errors visible in the tables alone:")
    for chk in table_checks():
        print(f"  {chk.robot} posture {chk.posture} mode {chk.mode} {chk.quantity}: "
              f"{chk.kind}: {chk.detail}")  # fmt: skip
    for name in args.robots.split(","):
        t = SEED_TABLES[name]
        if args.truth:
            t = _synthetic_table(t, load_robot(args.truth))
            print(f"\n{name}: table replaced by {t.source}")
        # where the posture variation of each mode sits: log f^2 = log k - log m, so a shift
        # with constant modal stiffness k is a modal-mass shift (not a spring's, e.g. a gear
        # stiffening with load, which moves k with f^2 for a mode local to that spring)
        lf2 = 2 * np.log(t.f_hz)
        lk = np.log(t.k_N_per_m)
        print(f"\n{name}: posture spread (max - min over postures 1-3) per mode of log f^2 / "
              "log k / log m (m = k / w^2):")  # fmt: skip
        for m in range(5):
            sp = [np.ptp(v[:, m]) for v in (lf2, lk, lk - lf2)]
            print(f"  mode {m + 1}: {sp[0]:.2f} / {sp[1]:.2f} / {sp[2]:.2f}")
        shipped = load_robot(name)
        print(f"\n{name}: FRAC of modal twins around the table (zeta and k within x1.5, "
              "uniform in log; 1000 each):")  # fmt: skip
        _frac_tolerance(t, np.random.default_rng(0))
        _balancer_bound(name, shipped, t)
        cs = compare_to_table(shipped, t, direction=d)
        print(f"\n## Robot {name} ({shipped.name}) vs {t.source}")
        print("shipped file: FRAC " + ", ".join(f"{v:.3f}" for v in cs.frac)
              + f"; |f err| median {100 * np.median(np.abs(cs.f_err)):.1f} %, "
              f"max {100 * np.max(np.abs(cs.f_err)):.1f} %")  # fmt: skip
        t0 = time.perf_counter()
        fit = fit_seed_table(seed_prior(name, shipped), t, form=form, starts=args.starts)
        robot = fit.robot
        c = compare_to_table(robot, t, direction=d)
        print(f"\ntable fit ({args.starts} starts, {time.perf_counter() - t0:.0f} s, "
              f"load {os.getloadavg()[0]:.1f}):")  # fmt: skip
        n_free = seed_fit_parameter_count(seed_prior(name, shipped), t, form)
        print(f"free parameters: {n_free} (table values: 45)")
        for b in shape:
            b0 = shipped.joints[b].body if b < 6 else shipped.end_effector
            b1 = robot.joints[b].body if b < 6 else robot.end_effector
            assert b0 is not None
            assert b1 is not None
            lab = f"link {b + 1}" if b < 6 else "end effector"
            print(f"{lab}: COM [m] {np.round(b0.com_m, 3).tolist()} -> "
                  f"{np.round(b1.com_m, 3).tolist()}; principal inertias [kg m^2] "
                  f"{np.round(np.linalg.eigvalsh(b0.inertia_kgm2), 1).tolist()} -> "
                  f"{np.round(np.linalg.eigvalsh(b1.inertia_kgm2), 1).tolist()}")  # fmt: skip
        if args.robot_out:
            path = os.path.join(args.robot_out, f"{name}_seed_fit.toml")
            os.makedirs(args.robot_out, exist_ok=True)
            atomic_write_text(
                path,
                f"# {shipped.name}: fit: seed Table {4 if name == 'B' else 7} "
                f"(studies/seed_tables.py {' '.join(sys.argv[1:])})\n" + robot_to_toml(robot),
            )
            load_robot(path)  # the loader's checks (triangle inequality, ranges)
            print(f"fitted robot file: {path}")
        print(f"twin modal stiffness / table (read as 1e5 N/m): {c.k_level:.2f}")
        print(
            "fitted springs [N m/rad]: joints "
            + ", ".join(f"{v:.3g}" for v in robot.stiffness)
            + "; tilt "
            + "; ".join(
                f"{j + 1}: {jt.tilt_stiffness_Nm_per_rad[0]:.3g}, "
                f"{jt.tilt_stiffness_Nm_per_rad[1]:.3g}"
                for j, jt in enumerate(robot.joints)
                if jt.tilt_stiffness_Nm_per_rad is not None
            )
            + f"; mount {robot.mount_stiffness_Nm_per_rad}"
            + "; load stiffening [per kN m] "
            + ", ".join(f"{1e3 * v:.3g}" for v in robot.load_stiffening)
        )
        m0 = [jt.body.mass_kg for jt in shipped.joints]
        m1 = [jt.body.mass_kg for jt in robot.joints]
        e0, e1 = shipped.end_effector, robot.end_effector
        assert e0 is not None  # B and C carry a spindle
        assert e1 is not None
        print(
            "link masses [kg] file -> fit: "
            + ", ".join(f"{a:.0f}->{b:.0f}" for a, b in zip(m0, m1, strict=True))
            + f"; total {sum(m0):.0f} -> {sum(m1):.0f}; spindle "
            f"{e0.mass_kg:.0f} -> {e1.mass_kg:.0f}"
        )
        print("\n| posture | mode | f table | f twin | err % | zeta table % | zeta twin % "
              "| k table | k twin (rel.) |")  # fmt: skip
        print("|---|---|---|---|---|---|---|---|---|")
        for p in range(3):
            for m in range(5):
                print(_fmt_row(p, m, t, c))
        ae = np.abs(c.f_err)
        print(f"\nfrequency error: median {100 * np.median(ae):.2f} %, max {100 * ae.max():.2f} %, "
              f"within 3 %: {int(np.sum(ae <= 0.03))}/15")  # fmt: skip
        zr = np.maximum(c.zeta_ratio, 1 / c.zeta_ratio)
        kr = np.maximum(c.k_ratio, 1 / c.k_ratio)
        print(f"damping within x1.5: {int(np.sum(zr <= 1.5))}/15; relative k within x1.5: "
              f"{int(np.sum(kr <= 1.5))}/15")  # fmt: skip
        print("FRAC yy per posture (2-40 Hz): " + ", ".join(f"{v:.3f}" for v in c.frac)
              + f"; extra twin peaks: {c.extra_modes.tolist()}")  # fmt: skip
        spread_t = t.f_hz.max(axis=0) / t.f_hz.min(axis=0) - 1
        spread_w = c.f_hz.max(axis=0) / c.f_hz.min(axis=0) - 1
        print("posture variation of f per mode (max/min - 1), table vs twin: "
              + ", ".join(f"{100 * a:.0f}/{100 * b:.0f} %"
                          for a, b in zip(spread_t, spread_w, strict=True)))  # fmt: skip
        spread = lopo_frequency_spread(seed_prior(name, shipped), t, fit.x, form=form)
        print("what two postures can tell of the third (linearised at this fit, exact data, "
              "prior x2.7 per factor): 1-sd f spread per held-out posture [%]: "
              + "; ".join(" ".join(f"{100 * v:.1f}" for v in row) for row in spread))  # fmt: skip
        print("\nverdicts (values flagged by the tables or the fit):")
        verdicts = value_verdicts(name, c)
        for v in verdicts:
            if v.verdict != "ok":
                print(f"  posture {v.posture} mode {v.mode} {v.quantity}: table {v.table:.4g}, "
                      f"twin {v.twin:.4g}: {v.verdict} ({v.reason})")  # fmt: skip
        res: dict[str, object] = {
            "f_err": c.f_err.tolist(),
            "zeta_ratio": c.zeta_ratio.tolist(),
            "k_ratio": c.k_ratio.tolist(),
            "frac": c.frac.tolist(),
            "k_level": c.k_level,
            "x": fit.x.tolist(),
            "lopo_f_spread": spread.tolist(),
            "verdicts": [v.__dict__ for v in verdicts],
        }
        if not args.no_lopo:
            print(f"\nleave-one-posture-out ({args.starts} starts per fit, from the prior):")
            prior = seed_prior(name, shipped)
            errs = []
            lopo: list[dict[str, object]] = []
            for held in range(3):
                keep = tuple(p for p in range(3) if p != held)
                t0 = time.perf_counter()
                fit = fit_seed_table(prior, t, keep, form=form, starts=args.starts)
                dt = time.perf_counter() - t0
                ch = compare_to_table(fit.robot, t, (held,), k_level=fit.k_level, direction=d)
                e = np.abs(ch.f_err[0])
                errs.append(e)
                print(f"  held-out posture {held + 1}: f error per mode "
                      + " ".join(f"{100 * x:.1f}" for x in ch.f_err[0])
                      + f" %; FRAC {ch.frac[0]:.3f}; fit {dt:.0f} s "
                      f"(load {os.getloadavg()[0]:.1f})")  # fmt: skip
                lopo.append({"held": held + 1, "f_err": ch.f_err[0].tolist(),
                             "frac": float(ch.frac[0])})  # fmt: skip
            ae = np.concatenate(errs)
            print(f"  LOPO frequency error: median {100 * np.median(ae):.2f} %, "
                  f"max {100 * ae.max():.2f} %")  # fmt: skip
            res["lopo"] = lopo
        out[name] = res
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main()
