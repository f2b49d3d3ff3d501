"""Where robust plans on out-of-form robots lose productivity (issue 27).

For one (robot, draw, job) of ``studies/out_of_form.py``: the default
(robust) plan is made on the draw's default transfer and verified on the
truth; at its binding waypoints (the model's margin within 2 % of the
smallest) the plan's own limit is split into its terms, each with the
planner's own code path (:func:`robolobe.plan.verify.verify_plan`, every
waypoint its own lobes, the term's speed window): the nominal modes over the
safety factor and each scenario of the robust bound
(:meth:`robolobe.plan.modes.RobotModes.robust`: three corners of the joint
region, each with the modes that do not lead shifted down and up). The term
with the smallest limit binds. For each mode that is shifted there: its
frequency spread per TCP direction, the spread the bound takes, the share
with which the cut sees it, and the model's actual frequency error against
the truth's paired mode (in the spread's units), and the limit with that mode
alone shifted (its sensitivity).

Run: ``nice python studies/out_of_form_mrr.py --robot C --draw 1 --job
job_C_face_steel.toml --cache DIR`` (``DIR`` as ``out_of_form.py --cache``
leaves it: the draw's transfer ``{robot}{draw}/R_pred.npz``; without it the
hammer tests and the transfer are made again).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent))

from out_of_form import TruthSource, draw_truth, hammer_tests
from out_of_form_explain import match_modes, peak_compliance
from plan_safety import EX, JOBS, default_transfer, robot_file

import robolobe.plan.pipeline as pipeline
import robolobe.plan.verify as verify
from robolobe.plan import load_job, plan_path, write_outputs
from robolobe.plan.lobes import LOBE_TOL
from robolobe.plan.modes import (
    INVISIBLE_K,
    MAX_LOG_STD,
    WINDOW_SHARE,
    CorrectedTwinSource,
    RobotModes,
    RobustBound,
    _can_meet,
    joint_sigma,
    region_corners,
)
from robolobe.plan.verify import read_plan, verify_plan
from robolobe.tl.models import load_model

FloatArray = NDArray[np.float64]


def term_limits(
    plan_dir: Path, job: Any, source: Any, bound_of: Callable[[RobotModes], RobustBound | None]
) -> FloatArray:
    """Limit [mm] per cut waypoint of ``min(nominal / SF, bound_of(modes))`` (own lobes).

    ``bound_of`` None: the nominal modes alone at margin 1 (a plain verify).
    """
    if bound_of is None:
        v = verify_plan(plan_dir, source=source, job=job, dynamics_tol=0.0)
        return np.asarray(v.table["a_lim_mm"].to_numpy(), dtype=np.float64)
    orig_cut, orig_bound = verify.cut_lobes, pipeline.plan_bound

    def forced(*a: Any, **k: Any) -> Any:
        k["robust"] = True
        return orig_cut(*a, **k)

    verify.cut_lobes = forced  # type: ignore[assignment]
    pipeline.plan_bound = lambda plan, modes, robust=None: (bound_of(modes), True)  # type: ignore[assignment]
    try:
        v = verify_plan(plan_dir, source=source, job=job, dynamics_tol=0.0)
    finally:
        verify.cut_lobes = orig_cut  # type: ignore[assignment]
        pipeline.plan_bound = orig_bound
    return np.asarray(v.table["a_lim_mm"].to_numpy(), dtype=np.float64)


def only(b: RobustBound | None, j: int) -> RobustBound | None:
    """The bound with its scenario ``j`` alone."""
    if b is None:
        return None
    return dataclasses.replace(b, scenarios=(b.corners()[j],))


def with_f_spread(rm: RobotModes, keep: NDArray[np.bool_]) -> RobotModes:
    """The modes with the frequency spread of the modes not in ``keep`` (n, m) set to 0."""
    std = np.array(rm.log_std, dtype=np.float64)
    std[..., 0] = np.where(keep[:, None, :], std[..., 0], 0.0)
    return dataclasses.replace(rm, parameters=dataclasses.replace(rm.parameters, log_std=std))


def analyse(key: str, draw: int, job_name: str, cache: Path | None, tmp: Path) -> list[str]:
    """The figures of the module docstring for one (robot, draw, job), as lines."""
    path = next(p for p, j, _ in JOBS if j == job_name)
    spec, base = robot_file(key, tmp)
    truth = draw_truth(base, key, draw)
    model_file = None if cache is None else cache / f"{key}{draw}" / "R_pred.npz"
    if model_file is None or not model_file.is_file():
        modal = hammer_tests(truth, base, key, draw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model_file = default_transfer(modal, spec, tmp)
    job = load_job(EX / job_name).replace(robot=spec, model=str(model_file))
    job = job.replace(plan=dataclasses.replace(job.plan, robust=None))
    res = plan_path(EX / path, job, robot=base, source=None)
    d = tmp / "plan"
    write_outputs(res, d, plots=False, html_report=False)
    tsrc = TruthSource(truth)
    vt = verify_plan(d, source=tsrc, job=job, dynamics_tol=0.0)
    sf = float(job.plan.safety_factor)
    lines = [
        f"{key}{draw} {job_name}: robust plan MRR {res.summary.mrr_cm3_per_min:.3f} cm3/min, "
        f"true min margin {vt.min_margin:.3f}, beyond {vt.n_beyond}"
    ]
    table, _, _ = read_plan(d, job)
    cut = table[table["motion"] == "cut"]
    depth = cut["depth_mm"].to_numpy(dtype=np.float64)
    a_plan = cut["a_lim_mm"].to_numpy(dtype=np.float64)
    ratio = depth / a_plan
    bind = ratio >= 0.98 * np.nanmax(ratio)
    rpm = cut["rpm"].to_numpy(dtype=np.float64)
    lines.append(
        f"binding waypoints {int(bind.sum())} of {bind.size} at rpm "
        f"{sorted(set(np.round(rpm[bind], 0)))}; depth {depth[bind].min():.4f} mm, "
        f"plan limit {a_plan[bind].min():.4f} mm, truth limit "
        f"{vt.table['a_lim_mm'].to_numpy()[bind].min():.4f} mm"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        src = CorrectedTwinSource(load_model(model_file))
    nominal = term_limits(d, job, src, None)  # type: ignore[arg-type]
    lines.append(f"  nominal / SF ({sf:g}): {np.min(nominal[bind]) / sf:.4f} mm")
    corners = region_corners() * 2.0
    for shifts in (True, False):
        for j in range(6 if shifts else 3):
            lim = term_limits(
                d, job, src, lambda m, j=j, s=shifts: only(m.robust(2.0, mode_shifts=s), j)
            )
            c = corners[j // 2] if shifts else corners[j]
            name = f"corner (t, u) = ({c[0]:.2f}, {c[1]:.2f})" + (
                f", other modes {'down' if j % 2 == 0 else 'up'}" if shifts else ", no shifts"
            )
            lines.append(f"  {name}: {np.min(lim[bind]):.4f} mm")
    # the modes at the first binding waypoint
    first = int(np.flatnonzero(bind)[0])
    q = np.radians(cut[[f"q{k}_deg" for k in range(1, 7)]].to_numpy(dtype=np.float64))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rm = src.predict(q)
    tm = tsrc.predict(q).model
    mm = rm.model
    match = match_modes(mm, tm)
    std = np.clip(np.nan_to_num(rm.log_std, nan=0.0, posinf=0.0), 0.0, MAX_LOG_STD)
    k = rm.k_N_per_m
    visible = np.isfinite(k) & (np.abs(k) < INVISIBLE_K)
    s_dir = np.where(visible, std[..., 0], 0.0)  # (n, 3, m)
    peak = peak_compliance(mm)
    share = peak / peak.max(axis=1, keepdims=True)
    lead = share >= WINDOW_SHARE
    # with which share the cut sees a mode per TCP direction: |R_dd| in x and y
    # (the tool axis z does not enter a flat end mill's cut)
    rdd = np.abs(np.stack([mm.residues[..., a, a] for a in range(2)], axis=1))  # (n, 2, m)
    w = rdd / np.maximum(rdd.sum(axis=1, keepdims=True), 1e-300)
    s_seen = np.sum(w * s_dir[:, :2], axis=1)
    # the bound's pair test (MODE_SHIFT_SPREAD = "pairs"): 2-sigma cut spreads
    cut2 = 2.0 * np.sqrt(np.sum(w * s_dir[:, :2] ** 2, axis=1))
    meets = _can_meet(mm.omega, cut2, share >= 0.05)
    f_err = np.log(tm.omega[np.arange(len(q))[:, None], np.maximum(match, 0)] / mm.omega)
    lines.append(
        "  modes at the first binding waypoint: f [Hz], peak share, lead, f spread xx/yy/zz, "
        "taken (largest), seen by the cut (|R_dd|-weighted x, y), true error |log f_t/f|, "
        "in units of taken / seen; whether it can meet another mode within 2 cut spreads; "
        "cross residue R_xy of the model / the truth's paired mode; limit with it alone "
        "shifted down / up at corner 0 [mm]"
    )
    base_lim = None
    for i in np.argsort(mm.omega[first]):
        f0 = mm.omega[first, i] / (2 * np.pi)
        if f0 > 200:
            continue
        taken = float(np.max(s_dir[first, :, i]))
        seen = float(s_seen[first, i])
        e = abs(float(f_err[first, i]))
        sens = ""
        if not lead[first, i] and taken > 0:
            keep = np.zeros(mm.omega.shape, dtype=bool)
            keep[:, i] = True
            keep |= lead
            if base_lim is None:
                nolead = lead.copy()
                base_lim = [
                    float(
                        np.min(
                            term_limits(
                                d,
                                job,
                                src,
                                lambda m, j=j, nolead=nolead: only(
                                    with_f_spread(m, nolead).robust(2.0), j
                                ),
                            )[bind]
                        )
                    )
                    for j in (0,)
                ]
            vals = []
            for j in (0, 1):
                lim = term_limits(
                    d,
                    job,
                    src,
                    lambda m, j=j, keep=keep: only(with_f_spread(m, keep).robust(2.0), j),
                )
                vals.append(float(np.min(lim[bind])))
            sens = f"  alone {vals[0]:.4f} / {vals[1]:.4f} (no shift {base_lim[0]:.4f})"
        lines.append(
            f"    {f0:7.2f} Hz  share {share[first, i]:.2f}  {'lead' if lead[first, i] else '    '}"
            f"  {' / '.join(f'{100 * v:4.1f}' for v in s_dir[first, :, i])} %  taken "
            f"{100 * taken:4.1f} %  seen {100 * seen:4.1f} %  error {100 * e:4.1f} % = "
            f"{e / taken if taken else np.inf:.2f} / {e / seen if seen else np.inf:.2f}"
            f"  {'meets' if meets[first, i] else 'apart'}  R_xy {mm.residues[first, i, 0, 1]:.2e}"
            f" / {tm.residues[first, max(int(match[first, i]), 0), 0, 1]:.2e}{sens}"
        )
    return lines


def coverage_table(first: int, last: int, cache: Path) -> None:
    """Print :func:`shift_coverage` per draw and pooled over the draws, per rule."""
    res = []
    with tempfile.TemporaryDirectory() as tmp:
        for key in ("B", "C"):
            for draw in range(first, last):
                if not (cache / f"{key}{draw}" / "R_pred.npz").is_file():
                    continue
                r = shift_coverage(key, draw, cache, Path(tmp))
                res.append(r)
                print(
                    f"{key}{draw}: {r['n']} shifted modes; "
                    + ", ".join(f"{k} {100 * r[k]:.0f} %" for k in _RULES)
                    + f"; {r['n_meet']} can meet another ({r['shape_off_meet']} of them "
                    f"with a shape off, MAC < {MAC_OFF}; {r['shape_off_apart']} of the others)",
                    flush=True,
                )
    w = np.array([r["n"] for r in res], dtype=np.float64)
    for k in _RULES:
        v = np.array([r[k] for r in res])
        med = np.median([r[k + "_med_spread"] for r in res])
        print(
            f"{k}: true f errors within 2 of its spreads {100 * float(w @ v / w.sum()):.1f} % "
            f"(pooled over {len(res)} robots, {int(w.sum())} modes; stated 95.4 %), median "
            f"spread {100 * med:.1f} %",
            flush=True,
        )
    n_meet = sum(r["n_meet"] for r in res)
    off_meet = sum(r["shape_off_meet"] for r in res)
    off_apart = sum(r["shape_off_apart"] for r in res)
    print(
        f"shapes: {n_meet} of {int(w.sum())} shifted modes can meet another mode that matters "
        f"within 2 cut spreads; tool-plane shape off (MAC < {MAC_OFF}) in {off_meet} of them "
        f"({100 * off_meet / max(n_meet, 1):.0f} %) and in {off_apart} of the "
        f"{int(w.sum()) - n_meet} others ({100 * off_apart / max(int(w.sum()) - n_meet, 1):.0f} %)",
        flush=True,
    )


#: The rules :func:`shift_coverage` reports.
_RULES = ("largest", "most", "cut", "cut_joint", "cut_amp", "cut_max", "pairs")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robot", default="C")
    ap.add_argument("--draw", type=int, default=1)
    ap.add_argument("--job", default="job_C_face_steel.toml")
    ap.add_argument("--cache", type=Path, default=None)
    ap.add_argument(
        "--coverage",
        default="",
        help="FIRST,LAST: shift_coverage of draws FIRST..LAST-1 of B and C (from --cache)",
    )
    ap.add_argument(
        "--passes",
        action="store_true",
        help="pass_scan: passes, speeds and a constant-speed scan of the three plans",
    )
    a = ap.parse_args()
    if a.passes:
        assert a.cache is not None, "--passes reads the draw's transfer in --cache"
        with tempfile.TemporaryDirectory() as tmp:
            for line in pass_scan(a.robot, a.draw, a.job, a.cache, Path(tmp)):
                print(line, flush=True)
        return
    if a.coverage:
        assert a.cache is not None, "--coverage reads the transfers in --cache"
        first, last = (int(v) for v in a.coverage.split(","))
        coverage_table(first, last, a.cache)
        return
    with tempfile.TemporaryDirectory() as tmp:
        for line in analyse(a.robot, a.draw, a.job, a.cache, Path(tmp)):
            print(line, flush=True)


def pass_scan(key: str, draw: int, job_name: str, cache: Path, tmp: Path) -> list[str]:
    """Where the MRR goes: passes, pass depth and speed of the oracle, plain and robust plans.

    Each plan (on the truth, on the draw's transfer plain, and robust, as
    ``out_of_form.py`` makes them) is listed with its pass counts, depth per
    pass, speeds and the limits that bind; then each plan's own lobes are
    scanned at 1201 constant speeds over the spindle range: the largest depth
    per pass of the deepest move stable at every cutting move there (``a_lim /
    (SF (1 + LOBE_TOL)) / share``, the headroom the planner's own pass check
    takes) and the passes it needs. A plan whose passes equal the fewest any
    constant speed allows on its own lobes lost nothing to its speed search or
    pass split: its MRR is set by the limit it plans on.
    """
    spec, base = robot_file(key, tmp)
    truth = draw_truth(base, key, draw)
    path = next(p for p, j, _ in JOBS if j == job_name)
    job = load_job(EX / job_name).replace(robot=spec, model="twin")
    sf = job.plan.safety_factor
    on_model = job.replace(model=str(cache / f"{key}{draw}" / "R_pred.npz"))
    runs = (
        ("oracle", job, False, TruthSource(truth)),
        ("plain", on_model, False, None),
        ("robust", on_model, None, None),
    )
    out = [f"{key}{draw} {job_name}: {truth.describe()}"]
    for tag, jj, robust, src in runs:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = plan_path(
                EX / path,
                jj.replace(plan=dataclasses.replace(jj.plan, robust=robust)),
                robot=base,
                source=src,
            )
        t = res.table[(res.table["motion"] == "cut").to_numpy()]
        secs = list(res.summary.passes or [])
        n_pass = sorted({int(r["passes"]) for r in secs}) or [1]
        rpm = res.outcome.best.rpm
        out.append(
            f"  {tag:6s} MRR {res.summary.mrr_cm3_per_min:8.3f} cm3/min, passes {n_pass}, "
            f"depth per pass {res.outcome.best.depth_m * 1e3:.4g} mm, rpm {rpm.min():.0f}-"
            f"{rpm.max():.0f}, binding {t['limiting'].value_counts().to_dict()}"
        )
        table = res.lobes.table
        prog = t["program_depth_mm"].to_numpy() if "program_depth_mm" in t else None
        speeds = np.linspace(table.rpm[0], table.rpm[-1], 1201)
        best = (0.0, 0.0, 0, 0.0)  # (rate ~ rpm / passes, rpm, passes, depth)
        fewest = (np.inf, 0.0)
        for n in speeds:
            a = table.query(np.full(table.group.size, n)) / (sf * (1 + LOBE_TOL)) * 1e3
            if prog is None:  # one depth, no passes
                d = float(np.min(a[np.isfinite(a)]))
                p = 1
            else:
                share = np.where(np.isfinite(prog) & (prog > 0), prog / np.nanmax(prog), 0.0)
                b = (share > 0) & np.isfinite(a)
                d = float(np.min(a[b] / share[b]))
                p = math.ceil(np.nanmax(prog) / d - 1e-9)
            rate = n * (d if prog is None else 1.0 / p)
            if rate > best[0]:
                best = (rate, float(n), p, d)
            if p < fewest[0]:
                fewest = (p, float(n))
        out.append(
            f"  {tag:6s} scan: best constant speed {best[1]:.0f} rpm, {best[2]} passes of at "
            f"most {best[3]:.4g} mm; fewest passes at any speed {fewest[0]} ({fewest[1]:.0f} rpm)"
        )
    return out


#: Frequency spreads a shifted (coupled) mode can be given, per posture and mode, from
#: its per-direction spreads ``s`` (n, 3, m) and TCP driving-point residues ``r`` (n, 3, m).
def _rules(s: FloatArray, r: FloatArray) -> dict[str, FloatArray]:
    rxy = r[:, :2]
    tot = rxy.sum(axis=1, keepdims=True)
    w = np.divide(rxy, tot, out=np.zeros_like(rxy), where=tot > 0)
    a = np.sqrt(rxy)
    ta = a.sum(axis=1, keepdims=True)
    wa = np.divide(a, ta, out=np.zeros_like(a), where=ta > 0)
    most = np.argmax(r, axis=1)
    return {
        "largest": np.max(s, axis=1),
        "most": np.take_along_axis(s, most[:, None], axis=1)[:, 0],
        "cut": np.sqrt(np.sum(w * s[:, :2] ** 2, axis=1)),
        "cut_amp": np.sqrt(np.sum(wa * s[:, :2] ** 2, axis=1)),
        "cut_max": np.max(np.where(w > 0.0, s[:, :2], 0.0), axis=1),
    }


def shift_coverage(key: str, draw: int, cache: Path, tmp: Path, n: int = 60) -> dict[str, Any]:
    """True frequency errors of the modes a robust bound shifts, in each rule's spread.

    At ``n`` random postures in the tested ranges (as ``out_of_form.spread_coverage``):
    every model mode that matters (peak compliance at least 5 % of the largest) and
    does not lead (below :data:`WINDOW_SHARE`), paired with the truth's mode
    (:func:`out_of_form_explain.match_modes`); ``|log f_true / f| / s`` per rule.
    """
    from robolobe.tl.design import design_postures
    from robolobe.twin.designs import TESTED_RANGES_DEG

    _spec, base = robot_file(key, tmp)
    truth = draw_truth(base, key, draw)
    q = design_postures(
        base, n, rng=np.random.default_rng(99), ranges_deg=TESTED_RANGES_DEG.get(key)
    ).q_rad
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rm = CorrectedTwinSource(load_model(cache / f"{key}{draw}" / "R_pred.npz")).predict(q)
    tm = TruthSource(truth).predict(q).model
    mm = rm.model
    match = match_modes(mm, tm)
    std = np.clip(np.nan_to_num(rm.log_std, nan=0.0, posinf=0.0), 0.0, MAX_LOG_STD)
    k = rm.k_N_per_m
    visible = np.isfinite(k) & (np.abs(k) < INVISIBLE_K)
    s = np.where(visible, std[..., 0], 0.0)
    r = np.abs(np.stack([mm.residues[..., a, a] for a in range(3)], axis=1))
    peak = peak_compliance(mm)
    share = peak / peak.max(axis=1, keepdims=True)
    sel = (share >= 0.05) & (share < WINDOW_SHARE) & (match >= 0)
    e = np.abs(np.log(tm.omega[np.arange(n)[:, None], np.maximum(match, 0)] / mm.omega))
    out: dict[str, Any] = {"robot": key, "draw": draw, "n": int(sel.sum())}
    rules = _rules(s, r)
    # the "cut" rule as the bound takes it: widened for the m shifted modes together
    m_sh = np.maximum(np.sum((share >= 0.05) & (share < WINDOW_SHARE), axis=1, keepdims=True), 1)
    rules["cut_joint"] = rules["cut"] * joint_sigma(2.0, m_sh) / 2.0
    # the bound's "pairs" rule: the largest spread for a mode that can meet another mode
    # that matters within their 2-sigma cut spreads (plan.modes._can_meet), else cut_joint
    meet = _can_meet(mm.omega, 2.0 * rules["cut"], share >= 0.05)
    rules["pairs"] = np.where(meet, rules["largest"], rules["cut_joint"])
    for name, sp in rules.items():
        z = np.divide(e, sp, out=np.full_like(e, np.inf), where=sp > 0)[sel]
        out[name] = float(np.mean(z <= 2.0))
        out[name + "_med_spread"] = float(np.median(sp[sel]))
    # does the pair test find the modes whose shape the model has wrong? MAC of the
    # model's and the truth's tool-plane (x, y) shapes, from each mode's residues
    mac = _xy_mac(mm.residues, tm.residues[np.arange(n)[:, None], np.maximum(match, 0)])
    out["n_meet"] = int((sel & meet).sum())
    out["shape_off_meet"] = int((sel & meet & (mac < MAC_OFF)).sum())
    out["shape_off_apart"] = int((sel & ~meet & (mac < MAC_OFF)).sum())
    return out


#: A mode's tool-plane shape counts as off the truth's below this MAC.
MAC_OFF = 0.9


def _xy_mac(rm: FloatArray, rt: FloatArray) -> FloatArray:
    """MAC of two modes' tool-plane shapes from their residues, shape (n, m).

    A real mode's residue is ``phi phi^T``: its x/y shape is the column of its larger
    diagonal entry over that entry's square root (sign and scale do not enter the MAC).
    """

    def shape(r: FloatArray) -> FloatArray:
        rxy = r[..., :2, :2]
        a = np.argmax(np.abs(np.stack([rxy[..., 0, 0], rxy[..., 1, 1]], axis=-1)), axis=-1)
        return np.take_along_axis(rxy, a[..., None, None], axis=-1)[..., 0]

    pm, pt = shape(rm), shape(rt)
    num = np.sum(pm * pt, axis=-1) ** 2
    den = np.sum(pm**2, axis=-1) * np.sum(pt**2, axis=-1)
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


if __name__ == "__main__":
    main()
