"""The bundled plans' stated limits against an independent ZOA at every waypoint (issue 25).

Each cutting waypoint's feed-frame model (the planner's robot modes at its
posture plus the job's tool modes, :func:`robolobe.plan.pipeline.cut_lobes`
with every waypoint on its own) is handed to the test's own textbook ZOA
(``tests/sld/zoa_reference.py``: the boundary solved per speed, no frequency
grid of the production code), at the waypoint's planned speed. The stated
``a_lim_mm`` (the plan's shared lobes, steep-wall split included) must lie
within [0.99, 1.005] of it. The fast run checks a few waypoints of the
contour on B (where a fixed grid stated 1.95x); ``-m slow`` every waypoint of
the three bundled plans.

The plans are made at each move's own engagement (entry/exit angles from the
stock, depth in passes, issue 26): the reference takes each waypoint's own
angles (its own directional factors, ``zoa_reference.alphas``), and every
engaged move's depth per pass (its programmed depth over its section's
passes) must leave the reference limit at least the safety factor (to the
0.5 % lobe tolerance).
"""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.plan.job import load_job
from robolobe.plan.modes import TwinSource
from robolobe.plan.pipeline import _tool_model, cut_lobes, material_from_job, plan_path
from robolobe.sld.conditions import engagement_angles
from robolobe.sld.directional import directional_factors

from ..sld.zoa_reference import alphas, reference_envelope
from .conftest import example

PLANS = {
    "pocket": ("pocket.nc", "job_A_pocket.toml"),
    "contour": ("contour.apt", "job_B_contour.toml"),
    "face": ("face.mod", "job_C_face_steel.toml"),
}


def _ratios(name: str, every: int) -> tuple[np.ndarray, list[str]]:
    path, job = PLANS[name]
    j = load_job(example(job))
    res = plan_path(example(path), j)
    sub = res.table[(res.table["motion"] == "cut").to_numpy()]
    q = np.radians(sub[[f"q{k}_deg" for k in range(1, 7)]].to_numpy(np.float64))
    fa = np.radians(sub["feed_angle_deg"].to_numpy(np.float64))
    f_tcp = np.stack([np.cos(fa), np.sin(fa), np.zeros_like(fa)], axis=1)
    plunge_rec = (sub["limiting"] == "plunge").to_numpy()
    f_tcp[plunge_rec] = [0.0, 0.0, 1.0]
    mat = material_from_job(j)
    rpm_grid = np.linspace(j.spindle.rpm_min, j.spindle.rpm_max, j.plan.n_rpm)
    model, plunge, *_ = cut_lobes(
        j, TwinSource(res.robot).predict(q), f_tcp, mat, _tool_model(j), rpm_grid,
        dynamics_tol=0.0, robust=False,
    )  # fmt: skip
    alpha_job = directional_factors(*engagement_angles(j.radial_immersion, j.cut.milling), mat.kr)
    own = "phi_entry_deg" in sub.columns
    rpm = sub["rpm"].to_numpy(np.float64)
    stated = sub["a_lim_mm"].to_numpy(np.float64) * 1e-3
    ratios, where = [], []
    for i in range(0, len(sub), every):
        if plunge[i] or not np.isfinite(stated[i]):
            continue
        alpha = alpha_job
        if own:
            pe, px = np.radians(sub[["phi_entry_deg", "phi_exit_deg"]].iloc[i].to_numpy(float))
            alpha = alphas(float(pe), float(px), mat.kr)
            per_pass = sub["program_depth_mm"].iloc[i] / sub["passes"].iloc[i] * 1e-3
        m = model.take(i)
        on = np.any(m.residues != 0.0, axis=(-1, -2))
        ref = reference_envelope(
            m.f_hz[on], m.zeta[on], m.residues[on], alpha, teeth=j.tool.teeth, kt=mat.kt,
            rpm=[rpm[i]],
        )[0]  # fmt: skip
        ratios.append(stated[i] / ref)
        where.append(f"{sub['source'].iloc[i]}:{sub['line'].iloc[i]}")
        if own:
            # the move's own depth per pass against the reference limit
            assert ref / per_pass >= j.plan.safety_factor * (1 - 0.005), (where[-1], ref, per_pass)
    return np.asarray(ratios), where


def _check(r: np.ndarray, where: list[str]) -> None:
    assert r.size > 0
    bad = [(w, x) for w, x in zip(where, r, strict=True) if not 0.99 <= x <= 1.005]
    assert not bad, bad[:5]


def test_contour_on_b_states_converged_limits() -> None:
    r, where = _ratios("contour", every=12)
    _check(r, where)


@pytest.mark.slow
@pytest.mark.parametrize("name", list(PLANS))
def test_every_waypoint_of_the_bundled_plans(name: str) -> None:
    r, where = _ratios(name, every=1)
    _check(r, where)


@pytest.mark.slow
def test_lobe_sharing_on_the_benchmark_zigzag_keeps_its_promise(tmp_path) -> None:
    """The 10k zig-zag of ``benchmarks/bench_plan.py --part path`` (on the default stock,
    each move at its own engagement): every cutting waypoint's stated limit against its
    own converged lobes at its own angles (``cut_lobes(dynamics_tol=0)``: no sharing) at
    its planned speed, within [0.99, 1.005]. Before the cut's factors had a tolerance of
    their own (:data:`robolobe.plan.lobes.CUT_TOL`), the moves entering at 89.56 deg
    where the path meets the stock's edge shared lobes made at 90.06 deg: 1.0094."""
    passes, per = 31, 323  # 400 x 300 mm, 10 mm step-over, evenly spaced points
    lines = ["%", "O3001", "G90 G21 G17", "S18000 M3", "G0 X0. Y0. Z5.", "G1 Z-1. F1000."]
    for k in range(passes):
        xs = np.linspace(0.0, 400.0, per)[:: -1 if k % 2 else 1]
        lines += [f"Y{10.0 * k:.3f}"] if k else []
        lines += [f"X{x:.3f} F4000." if i == 0 else f"X{x:.3f}" for i, x in enumerate(xs)]
    path = tmp_path / "zigzag.nc"
    path.write_text("\n".join([*lines, "G0 Z5.", "M30", "%"]) + "\n", encoding="utf-8")
    j = load_job(example("job_A_pocket.toml"))
    pl = j.placement.copy()
    pl[:3, 3] = [1.55, -0.15, 0.30]
    j = j.replace(placement=pl)
    res = plan_path(path, j)
    sub = res.table[(res.table["motion"] == "cut").to_numpy()]
    assert len(sub) > 9_000
    q = np.radians(sub[[f"q{k}_deg" for k in range(1, 7)]].to_numpy(np.float64))
    fa = np.radians(sub["feed_angle_deg"].to_numpy(np.float64))
    f_tcp = np.stack([np.cos(fa), np.sin(fa), np.zeros_like(fa)], axis=1)
    f_tcp[(sub["limiting"] == "plunge").to_numpy()] = [0.0, 0.0, 1.0]
    eng = tuple(np.radians(sub[c].to_numpy(np.float64)) for c in ("phi_entry_deg", "phi_exit_deg"))
    rpm_grid = np.linspace(j.spindle.rpm_min, j.spindle.rpm_max, j.plan.n_rpm)
    _, plunge, own, *_ = cut_lobes(
        j, TwinSource(res.robot).predict(q), f_tcp, material_from_job(j), _tool_model(j),
        rpm_grid, dynamics_tol=0.0, robust=False, engagement=eng, air=~np.isfinite(eng[0]),
    )  # fmt: skip
    stated = sub["a_lim_mm"].to_numpy(np.float64) * 1e-3
    ref = own.table.query(sub["rpm"].to_numpy(np.float64))
    ok = np.isfinite(stated) & ~plunge
    assert ok.sum() > 9_000
    assert np.all(np.isfinite(ref[ok]))
    r = stated[ok] / ref[ok]
    where = sub["line"].to_numpy()[ok]
    _check(r, [f"zigzag.nc:{w}" for w in where])
