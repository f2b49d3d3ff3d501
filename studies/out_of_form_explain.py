"""Why a plan on an out-of-form robot goes beyond the true limit (issue 27).

For one (robot, draw, job) of ``studies/out_of_form.py``: the draw's hammer
tests, the default transfer and the default (robust) plan are made again, the
plan is verified on the truth, and at the waypoints beyond the true limit the
model's modes are replaced by the truth's, mode by mode and part by part
(frequency, damping, the driving-point residues ``xx, yy, zz``, the cross
terms), with the planner's own limit (:func:`robolobe.plan.verify.verify_plan`,
every waypoint its own lobes). The modes whose swap closes the miss are the
error that matters; the robust bound's corners are evaluated at the same
waypoints (without their speed windows, which do not reach these limits:
they are set at the speed grid's end, the job's cutting-speed cap) together
with the per-mode standardized errors of those modes (the bound's region is
the disk of radius ``k_sigma`` in them).

Run: ``nice python studies/out_of_form_explain.py --robot C --draw 14 --job
job_C_face_ti_lowspeed.toml`` (the held-back failure of the joint-region bound;
its output is quoted in ``studies/out_of_form.json`` ``meta.explained``).
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

sys.path.insert(0, str(Path(__file__).resolve().parent))

from out_of_form import TruthSource, draw_truth, hammer_tests
from plan_safety import EX, JOBS, default_transfer, robot_file

from robolobe._directions import DRIVING
from robolobe._modal_parameters import ModalParameters
from robolobe.plan import load_job, plan_path, write_outputs
from robolobe.plan.modes import (
    INVISIBLE_K,
    MAX_LOG_STD,
    CorrectedTwinSource,
    RobotModes,
    region_corners,
)
from robolobe.plan.verify import read_plan, verify_plan
from robolobe.sld.frf import ModalModel
from robolobe.tl.models import load_model

FloatArray = NDArray[np.float64]
#: Parts of a mode that :func:`swap_modes` can take from the truth.
PARTS = ("f", "zeta", "diag", "off")


def peak_compliance(m: ModalModel) -> FloatArray:
    """Each mode's peak compliance ``|trace R| / (2 zeta omega^2)`` [m/N], shape (n, m)."""
    return np.abs(np.trace(m.residues, axis1=-2, axis2=-1)) / (2.0 * m.zeta * m.omega**2)


def match_modes(model: ModalModel, truth: ModalModel) -> NDArray[np.intp]:
    """The truth's mode paired with each model mode, per posture (-1: none).

    One-to-one (an assignment) of least ``|log f_true / f| + 0.1 min(|log c_true
    / c|, 3)`` (``c`` the peak compliance; the study's matching cost).

    Parameters
    ----------
    model, truth : ModalModel
        Same batch (n,), dim 3.

    Returns
    -------
    ndarray of int, shape (n, m_model)
    """
    n, m = model.omega.shape
    out = np.full((n, m), -1, dtype=np.intp)
    cm, ct = peak_compliance(model), peak_compliance(truth)
    for r in range(n):
        with np.errstate(divide="ignore", invalid="ignore"):
            cost = np.abs(np.log(truth.omega[r][None, :] / model.omega[r][:, None]))
            lc = np.abs(np.log(ct[r][None, :] / cm[r][:, None]))
        cost = cost + 0.1 * np.minimum(np.nan_to_num(lc, nan=3.0, posinf=3.0), 3.0)
        cost = np.where(np.isfinite(cost), cost, 1e6)
        rows, cols = linear_sum_assignment(cost)
        out[r, rows] = cols
    return out


def swap_modes(
    model: ModalModel,
    truth: ModalModel,
    match: NDArray[np.intp],
    which: NDArray[np.bool_],
    parts: tuple[str, ...] = PARTS,
) -> ModalModel:
    """The model with the chosen modes' parts taken from their truth's pairs.

    Parameters
    ----------
    model, truth : ModalModel
        Same batch (n,), dim 3.
    match : ndarray of int, shape (n, m_model)
        :func:`match_modes`.
    which : ndarray of bool, shape (m_model,) or (n, m_model)
        Model modes to swap (unmatched ones are kept).
    parts : tuple of str
        Of :data:`PARTS`: ``"f"`` the frequency, ``"zeta"`` the damping,
        ``"diag"`` the driving-point residues, ``"off"`` the cross terms.
        Residues are swapped at equal modal stiffness: without ``"f"`` the
        truth's residue is scaled to the model's frequency (``R ~ omega^2 / k``).

    Returns
    -------
    ModalModel
    """
    bad = [p for p in parts if p not in PARTS]
    if bad:
        raise ValueError(f"parts: expected some of {PARTS}, found {bad}")
    om, zz, rr = model.omega.copy(), model.zeta.copy(), model.residues.copy()
    sel = np.broadcast_to(which, om.shape) & (match >= 0)
    r_i, m_i = np.nonzero(sel)
    t_i = match[r_i, m_i]
    rt = truth.residues[r_i, t_i]
    if "f" in parts:
        scale = (truth.omega[r_i, t_i] / om[r_i, m_i]) ** 2
        rr[r_i, m_i] *= scale[:, None, None]  # the model's own residues at its k
        om[r_i, m_i] = truth.omega[r_i, t_i]
    else:
        rt = rt * ((om[r_i, m_i] / truth.omega[r_i, t_i]) ** 2)[:, None, None]
    if "zeta" in parts:
        zz[r_i, m_i] = truth.zeta[r_i, t_i]
    d = model.dim
    diag = np.eye(d, dtype=bool)
    for part, mask in (("diag", diag), ("off", ~diag)):
        if part in parts:
            cur = rr[r_i, m_i]
            cur[:, mask] = rt[:, mask]
            rr[r_i, m_i] = cur
    return ModalModel(om, zz, rr)


def modes_of(m: ModalModel, name: str) -> RobotModes:
    """A :class:`RobotModes` of a TCP-frame model (driving-point parameters from it)."""
    w = m.omega
    with np.errstate(divide="ignore"):
        k = np.stack([w**2 / np.abs(m.residues[..., a, a]) for a in range(3)], axis=1)
    f = np.broadcast_to((w / (2 * np.pi))[:, None], k.shape)
    z = np.broadcast_to(m.zeta[:, None], k.shape)
    return RobotModes(
        parameters=ModalParameters.from_stacked(np.stack([f, z, k], -1), DRIVING),
        model=m,
        extrapolation=None,
        source=name,
        shapes_coupled=True,
    )


class _Fixed:
    def __init__(self, m: ModalModel, name: str) -> None:
        self.m, self.name = m, name

    def predict(self, q_rad: Any) -> RobotModes:
        return modes_of(self.m, self.name)


def standardized_errors(
    rm: RobotModes, truth: ModalModel, match: NDArray[np.intp], k_sigma: float = 2.0
) -> tuple[FloatArray, FloatArray]:
    """Per model mode: ``t`` (frequency) and ``u`` (peak compliance) errors in the bound's spread.

    The spread is the one :meth:`RobotModes.robust` takes (capped at
    :data:`MAX_LOG_STD`, the direction that sees the mode most); ``u > 0``:
    the truth is more compliant. Shapes (n, m).
    """
    std = np.clip(np.nan_to_num(rm.log_std, nan=0.0, posinf=0.0), 0.0, MAX_LOG_STD)
    k = rm.k_N_per_m
    visible = np.isfinite(k) & (np.abs(k) < INVISIBLE_K)
    kv = np.where(visible, np.abs(k), np.inf)
    most = np.argmin(kv, axis=1)
    sm = np.take_along_axis(std, most[:, None, :, None], axis=1)[:, 0]  # (n, m, 3)
    m = rm.model
    r_i = np.arange(match.shape[0])[:, None]
    t_i = np.where(match >= 0, match, 0)
    lf = np.log(truth.omega[r_i, t_i] / m.omega)
    lc = np.log(peak_compliance(truth)[r_i, t_i] / peak_compliance(m))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = lf / sm[..., 0]
        u = lc / np.hypot(sm[..., 1], sm[..., 2])
    return t, u


def explain(key: str, draw: int, job_name: str, folder: Path, k_sigma: float = 2.0) -> list[str]:
    """The study's pipeline for one (robot, draw, job), then the swaps (see the module)."""
    path = next(p for p, j, _ in JOBS if j == job_name)
    spec, base = robot_file(key, folder)
    truth = draw_truth(base, key, draw)
    modal = hammer_tests(truth, base, key, draw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model_file = default_transfer(modal, spec, folder)
    job = load_job(EX / job_name).replace(robot=spec, model=str(model_file))
    job = job.replace(plan=dataclasses.replace(job.plan, robust=None))
    res = plan_path(EX / path, job, robot=base, source=None)
    d = folder / "plan"
    write_outputs(res, d, plots=False, html_report=False)
    v = verify_plan(d, source=TruthSource(truth), job=job, dynamics_tol=0.0)
    lines = [f"{key}{draw} {job_name}: {truth.describe()}"]
    lines.append(
        f"robust plan: {v.n_beyond} waypoints beyond the true limit, min margin {v.min_margin:.3f}"
    )
    if v.n_beyond == 0:
        return lines
    bad = (v.table["status"] == "chatter").to_numpy()
    table, _, _ = read_plan(d, None)
    cut = table[table["motion"] == "cut"]
    q = np.radians(cut[[f"q{k}_deg" for k in range(1, 7)]].to_numpy(dtype=np.float64))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rm = CorrectedTwinSource(load_model(model_file)).predict(q)
    tm = TruthSource(truth).predict(q).model
    mm = rm.model
    match = match_modes(mm, tm)

    def lim(m: ModalModel) -> FloatArray:
        a = verify_plan(d, source=_Fixed(m, "swap"), job=job, dynamics_tol=0.0).table
        return np.asarray(a["a_lim_mm"].to_numpy()[bad], dtype=np.float64)

    a_true = np.asarray(v.table["a_lim_mm"].to_numpy()[bad], dtype=np.float64)
    a_model = lim(mm)
    miss = np.log(a_model / a_true)
    wp = v.table[bad]
    lines.append(
        f"beyond at rpm {sorted(set(np.round(wp['rpm'], 1)))}, depth "
        f"{wp['depth_mm'].min():.4f}-{wp['depth_mm'].max():.4f} mm; limit on the truth "
        f"{a_true.min():.4f}-{a_true.max():.4f} mm, on the model {a_model.min():.4f}-"
        f"{a_model.max():.4f} mm (the model's limit {np.exp(miss.mean()):.2f}x the truth's)"
    )
    b = rm.robust(k_sigma)
    assert b is not None
    for c, (cm, w) in enumerate(b.corners()):
        lines.append(
            f"bound scenario {c} (t, u) = "
            f"{np.round(region_corners()[c // 2 if b.mode_shifts else c] * k_sigma, 2).tolist()}"
            + (f", other modes {('down', 'up')[c % 2]}" if b.mode_shifts else "")
            + " "
            f"without its window (largest {100 * float(w.max()):.1f} %): "
            f"{lim(cm).min():.4f}-{lim(cm).max():.4f} mm"
        )
    order = np.argsort(mm.omega[np.flatnonzero(bad)[0]])
    first = np.flatnonzero(bad)[0]
    f0 = mm.omega[first] / (2 * np.pi)
    ft = tm.omega[first][match[first]] / (2 * np.pi)
    t, u = standardized_errors(rm, tm, match, k_sigma)
    share = peak_compliance(mm)[first] / peak_compliance(mm)[first].max()
    lines.append("at the first waypoint beyond: model mode -> truth's pair, standardized errors")
    for i in order:
        if f0[i] > 200:
            continue
        lines.append(
            f"  {f0[i]:7.2f} Hz -> {ft[i]:7.2f} Hz  t {t[first, i]:+.2f}  u {u[first, i]:+.2f}  "
            f"peak share {share[i]:.2f}"
        )
    # single modes, then pairs, that close at least 90 % of the log miss
    m_all = mm.omega.shape[1]
    found: list[tuple[int, ...]] = []
    for size in (1, 2, 3):
        for combo in itertools.combinations(range(m_all), size):
            which = np.zeros(m_all, dtype=bool)
            which[list(combo)] = True
            a = lim(swap_modes(mm, tm, match, which))
            closed = 1.0 - np.log(a / a_true).mean() / miss.mean()
            if closed >= 0.9:
                found.append(combo)
                names = ", ".join(f"{f0[i]:.2f}" for i in combo)
                lines.append(
                    f"the truth's modes paired with the model's {names} Hz close "
                    f"{100 * closed:.0f} % of the miss (limit {a.min():.4f}-{a.max():.4f} mm)"
                )
                for parts in (("f",), ("zeta",), ("diag",), ("off",), ("f", "diag"), PARTS):
                    ap = lim(swap_modes(mm, tm, match, which, parts))
                    cl = 1.0 - np.log(ap / a_true).mean() / miss.mean()
                    lines.append(f"    only {'+'.join(parts)}: closes {100 * cl:.0f} %")
        if found:
            break
    if not found:
        lines.append("no set of up to 3 modes closes 90 % of the miss")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robot", default="C")
    ap.add_argument("--draw", type=int, default=14)
    ap.add_argument("--job", default="job_C_face_ti_lowspeed.toml")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for line in explain(a.robot, a.draw, a.job, Path(tmp)):
            print(line, flush=True)


if __name__ == "__main__":
    main()
