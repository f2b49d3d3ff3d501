"""The limits an engineer checks first: cutting speed, chip load and robot path speed.

One place for the process limits a plan keeps besides stability, power and
torque, each with the reason it holds:

- **Cutting speed** vc = pi D n [m/min]: the material table's range for
  carbide cutters (``robolobe/data/materials.csv``, column
  ``cutting_source``) or the job's ``cut.vc_min_m_per_min`` /
  ``cut.vc_max_m_per_min``. With the tool diameter it is a speed range
  vc / (pi D) [rpm], intersected with the spindle's ``rpm_min``-``rpm_max``.
- **Chip load** f_z: the program's own, F / (S N) on every move that states
  both F and S, kept unless the job says ``cut.feed_per_tooth_from = "job"``
  (then ``cut.feed_per_tooth_mm``). The optimizer plans one chip load for the
  whole path (power, torque and the feed cap grow with it): the largest the
  program states on a lateral cutting move (plunges and ramps along the tool
  axis excluded: they do not load the cutter sideways and are usually fed
  slower), so it never under-states the load; each move keeps its own in
  :attr:`ProcessLimits.fz_program_m`. A range (table or
  ``cut.feed_per_tooth_min_mm`` / ``_max_mm``) is checked, not enforced: the
  plan says when a chip load lies outside it.
- **Robot path speed**: the smaller of the job's ``cut.max_feed_mm_per_min``
  and the robot file's ``max_path_speed_mm_per_s``; neither given:
  :data:`DEFAULT_MAX_PATH_SPEED_M_PER_S`, with a note. A plan never asks a
  feed above it.

:func:`process_limits` builds them (refusing contradictions with one line
naming the key); :func:`binding_notes` turns the optimizer's ``limiting``
label of each waypoint into the physical limit that binds there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from robolobe._text import count
from robolobe.errors import InputError
from robolobe.plan.job import Job
from robolobe.robots.io import load_robot
from robolobe.robots.model import Robot
from robolobe.sld.material import Material, get_material

__all__ = [
    "DEFAULT_MAX_PATH_SPEED_M_PER_S",
    "FZ_DISAGREE",
    "ProcessLimits",
    "binding_limit",
    "binding_notes",
    "brief_source",
    "process_limits",
    "rpm_from_vc",
    "vc_from_rpm",
]

FloatArray = NDArray[np.float64]

#: Robot path speed [m/s] when neither the job (``cut.max_feed_mm_per_min``) nor the
#: robot file (``max_path_speed_mm_per_s``) gives one: 1 m/s (60 m/min), below the
#: 2 m/s CP ceiling of common industrial controllers (KUKA KSS ``$VEL.CP``) and far
#: above robot milling feeds.
DEFAULT_MAX_PATH_SPEED_M_PER_S = 1.0
#: Relative difference of the program's and the job's chip load that the plan reports.
FZ_DISAGREE = 0.10


def vc_from_rpm(rpm: ArrayLike, diameter_m: float) -> FloatArray:
    """Cutting speed vc = pi D n [m/min] of a spindle speed ``rpm`` [rpm], ``diameter_m`` [m]."""
    return np.asarray(math.pi * diameter_m * np.asarray(rpm, dtype=np.float64))


def rpm_from_vc(vc_m_per_min: float, diameter_m: float) -> float:
    """Spindle speed n = vc / (pi D) [rpm] of a cutting speed [m/min], ``diameter_m`` [m]."""
    return vc_m_per_min / (math.pi * diameter_m)


@dataclass(frozen=True, eq=False)
class ProcessLimits:
    """The limits a plan keeps besides stability, power and torque (module docstring).

    Attributes
    ----------
    rpm_min, rpm_max : float
        Spindle range intersected with the vc range for the tool diameter [rpm].
    rpm_min_why, rpm_max_why : str
        Which limit sets each end, e.g. ``"spindle.rpm_min 800 rpm"``,
        ``"vc_max 300 m/min (material table: steel, carbide; estimate: ...)"``.
    vc_min_m_per_min, vc_max_m_per_min : float
        Cutting-speed range [m/min] (0 and inf where none is known).
    vc_source : str
        Where the vc range comes from.
    feed_per_tooth_m : float
        The one chip load [m] the optimizer plans power, torque and the feed
        cap at.
    feed_per_tooth_source : {"program", "job"}
        Whose chip load that is.
    fz_program_m : ndarray, shape (n,)
        Per waypoint, the program's F / (S N) [m] on every feed move (air
        moves too); NaN where the program states no F or no S, and on rapids.
    max_feed_m_per_s : float
        Robot path speed cap [m/s].
    max_feed_why : str
        Which key (or default) sets it.
    notes : tuple of str
        Sentences for the plan summary: disagreements, the value kept,
        defaults used.
    fz_min_m, fz_max_m : float
        Chip-load range [m] (0 and inf where none is known); checked, not
        enforced.
    fz_range_source : str
        Where that range comes from.
    """

    rpm_min: float
    rpm_max: float
    rpm_min_why: str
    rpm_max_why: str
    vc_min_m_per_min: float
    vc_max_m_per_min: float
    vc_source: str
    feed_per_tooth_m: float
    feed_per_tooth_source: str
    fz_program_m: FloatArray
    max_feed_m_per_s: float
    max_feed_why: str
    notes: tuple[str, ...] = ()
    fz_min_m: float = 0.0
    fz_max_m: float = math.inf
    fz_range_source: str = "none"


# ----------------------------------------------------------------- tables
def _table_material(job: Job) -> Material | None:
    name = job.material.name
    if name is None:
        return None
    try:
        return get_material(name)
    except InputError:
        return None


def _where(job: Job) -> str:
    return Path(job.source).name if job.source not in ("<code>", "<dict>") else job.source


def _ranges(
    job: Job, mat: Material | None
) -> tuple[float, float, str, str, str, float, float, str]:
    """vc range [m/min] with each end's reason and the source; fz range [m] and its source."""
    table = f"material table: {mat.name}, carbide; {mat.cutting_source}" if mat else ""
    vc_job = [None if v is None else v * 60.0 for v in job.cut.vc_range_m_per_s]
    vc_tab = mat.vc_range_m_per_min if mat is not None else None
    ends: list[tuple[float, str]] = []
    for i, (key, none) in enumerate((("vc_min_m_per_min", 0.0), ("vc_max_m_per_min", math.inf))):
        jv = vc_job[i]
        if jv is not None:
            ends.append((jv, f"cut.{key}"))
        elif vc_tab is not None:
            ends.append((vc_tab[i], table))
        else:
            ends.append((none, ""))
    (lo, lo_src), (hi, hi_src) = ends
    srcs = [s for s in dict.fromkeys((lo_src, hi_src)) if s]
    if not srcs:
        vc_source = "none (no material table entry and no cut.vc_min/max_m_per_min)"
    elif len(srcs) == 1:
        vc_source = srcs[0] if srcs[0] == table else "job " + " and ".join(srcs)
    else:
        lo_b, hi_b = brief_source(lo_src) or "none", brief_source(hi_src) or "none"
        vc_source = f"vc_min from {lo_b}; vc_max from {hi_b}"
    if not lo < hi:
        key = "cut.vc_min_m_per_min" if lo_src.startswith("cut.") else "cut.vc_max_m_per_min"
        lo_why, hi_why = brief_source(lo_src) or "none", brief_source(hi_src) or "none"
        raise InputError(
            f"{key}: expected vc_min < vc_max, found vc_min {lo:g} m/min ({lo_why}) "
            f">= vc_max {hi:g} m/min ({hi_why})",
            source=_where(job),
        )
    fz_job = job.cut.feed_per_tooth_range_m
    fz_tab = mat.fz_range_mm if mat is not None else None
    fz: list[float] = []
    fz_srcs: list[str] = []
    for i, (key, none) in enumerate(
        (("feed_per_tooth_min_mm", 0.0), ("feed_per_tooth_max_mm", math.inf))
    ):
        jf = fz_job[i]
        if jf is not None:
            fz.append(jf)
            fz_srcs.append(f"job cut.{key}")
        elif fz_tab is not None:
            fz.append(fz_tab[i] * 1e-3)
            fz_srcs.append(table)
        else:
            fz.append(none)
    if not fz[0] < fz[1]:
        raise InputError(
            f"cut.feed_per_tooth_min_mm: expected below the chip-load maximum "
            f"{fz[1] * 1e3:g} mm ({fz_srcs[-1] if fz_srcs else 'none'}), found {fz[0] * 1e3:g}",
            source=_where(job),
        )
    fz_source = "; ".join(dict.fromkeys(fz_srcs)) or "none"
    return lo, hi, lo_src, hi_src, vc_source, fz[0], fz[1], fz_source


def brief_source(src: str) -> str:
    """A reason without its long citation: ``material table: steel, carbide; estimate``."""
    if not src.startswith("material table"):
        return src
    head, _, rest = src.partition(";")
    return head + ("; estimate" if rest.strip().startswith("estimate") else "")


# ------------------------------------------------------------------ limits
def _unreachable_vc(
    end: str, vc: float, rpm: float, src: str, spindle_rpm: float, d: float, where: str
) -> InputError:
    """The refusal of a vc range end the spindle cannot reach with a tool of diameter ``d`` [m].

    ``end`` is ``"min"`` (``vc`` above pi D ``spindle_rpm`` = rpm_max) or ``"max"``
    (below pi D rpm_min); ``src`` names where ``vc`` [m/min] came from.
    """
    key = src if src.startswith("cut.") else f"vc_{end} ({brief_source(src)})"
    bound = "at most" if end == "min" else "at least"
    spindle = "spindle.rpm_max" if end == "min" else "spindle.rpm_min"
    return InputError(
        f"{key}: expected a cutting speed the spindle reaches with the {d * 1e3:g} mm tool "
        f"({bound} pi D {spindle} = {vc_from_rpm(spindle_rpm, d):.4g} m/min), found "
        f"vc_{end} {vc:g} m/min ({rpm:.0f} rpm)"
        + ("" if src.startswith("cut.") else f"; set cut.vc_{end}_m_per_min to override"),
        source=where,
    )


def process_limits(
    job: Job,
    wp: pd.DataFrame | None = None,
    cut: NDArray[np.bool_] | None = None,
    path_name: str = "",
    *,
    robot: Robot | None = None,
) -> ProcessLimits:
    """The process limits of a job and (optionally) its program.

    Parameters
    ----------
    job : Job
    wp : pandas.DataFrame, optional
        The program's waypoint table (:func:`robolobe.plan.paths.read_toolpath`:
        ``feed_mm_per_min``, ``rpm_programmed``, ``fx fy fz``, ``i j k``,
        ``source``, ``line``); None: the job's limits alone (chip load from
        the job).
    cut : ndarray of bool, shape (n,), optional
        The cutting moves (default: ``wp["motion"] == "cut"``); pass the
        engaged ones where the stock is known, so that air moves do not
        count.
    path_name : str
        The program's name, for messages.
    robot : Robot, optional
        The robot (its ``max_path_speed_m_per_s``); default ``job.robot``.

    Returns
    -------
    ProcessLimits

    Raises
    ------
    InputError
        One line naming the key or the program's ``file:line``: a vc range
        whose speeds the spindle does not reach with this tool, vc_min >=
        vc_max, a zero or negative F or S on a cutting move, a path speed
        too low for the lowest spindle speed at the kept chip load.
    """
    where = _where(job)
    d = job.tool.diameter_m
    d_mm = d * 1e3
    teeth = job.tool.teeth
    notes: list[str] = []
    mat = _table_material(job)
    vc_lo, vc_hi, lo_src, hi_src, vc_source, fz_lo, fz_hi, fz_src = _ranges(job, mat)

    # --- speed: spindle range and vc range
    sp = job.spindle
    r_lo, r_hi = rpm_from_vc(vc_lo, d), rpm_from_vc(vc_hi, d)
    if r_lo >= sp.rpm_max:
        raise _unreachable_vc("min", vc_lo, r_lo, lo_src, sp.rpm_max, d, where)
    if r_hi <= sp.rpm_min:
        raise _unreachable_vc("max", vc_hi, r_hi, hi_src, sp.rpm_min, d, where)
    if r_lo > sp.rpm_min:
        rpm_min = r_lo
        rpm_min_why = (
            f"vc_min {vc_lo:g} m/min ({brief_source(lo_src)}) = {r_lo:.0f} rpm at D {d_mm:g} mm"
        )
    else:
        rpm_min, rpm_min_why = sp.rpm_min, f"spindle.rpm_min {sp.rpm_min:g} rpm"
    if r_hi < sp.rpm_max:
        rpm_max = r_hi
        rpm_max_why = (
            f"vc_max {vc_hi:g} m/min ({brief_source(hi_src)}) = {r_hi:.0f} rpm at D {d_mm:g} mm"
        )
    else:
        rpm_max, rpm_max_why = sp.rpm_max, f"spindle.rpm_max {sp.rpm_max:g} rpm"
    if math.isfinite(vc_hi) or vc_lo > 0:
        notes.append(
            f"cutting speed kept within vc {vc_lo:g}-{vc_hi:g} m/min ({brief_source(vc_source)}): "
            f"{rpm_min:.0f}-{rpm_max:.0f} rpm for the {d_mm:g} mm cutter"
            + (
                ""
                if (rpm_min, rpm_max) == (sp.rpm_min, sp.rpm_max)
                else f" (the spindle's {sp.rpm_min:g}-{sp.rpm_max:g} rpm narrowed)"
            )
        )
    else:
        notes.append(
            "no cutting-speed range: the material has no table entry and the job sets no "
            "cut.vc_min_m_per_min / cut.vc_max_m_per_min; only the spindle's range limits speed"
        )

    # --- chip load: the program's, the job's
    fz_job = job.cut.feed_per_tooth_m
    n = 0 if wp is None else len(wp)
    fz_prog = np.full(n, np.nan)
    kept, kept_src = fz_job, "job"
    if wp is not None:
        cutm = (wp["motion"] == "cut").to_numpy() if cut is None else np.asarray(cut, bool)
        if cutm.shape != (n,):
            raise InputError(f"cut: expected a mask of shape ({n},), found shape {cutm.shape}")
        fz_prog, lateral = _program_chip_load(wp, cutm, teeth, path_name)
        states = lateral & np.isfinite(fz_prog)
        kept, kept_src = _chip_load_notes(job, wp, fz_prog, states, cutm, notes)
    if (fz_lo > 0 or math.isfinite(fz_hi)) and not fz_lo <= kept <= fz_hi:
        notes.append(
            f"the chip load the plan keeps, {kept * 1e3:.3g} mm per tooth, lies outside "
            f"{fz_lo * 1e3:g}-{fz_hi * 1e3:g} mm ({brief_source(fz_src)})"
        )

    # --- robot path speed
    rob = robot if robot is not None else load_robot(job.robot)
    caps: list[tuple[float, str]] = []
    if job.cut.max_feed_m_per_s is not None:
        caps.append(
            (
                job.cut.max_feed_m_per_s,
                f"cut.max_feed_mm_per_min {job.cut.max_feed_m_per_s * 6e4:g}",
            )
        )
    if rob.max_path_speed_m_per_s is not None:
        caps.append(
            (
                rob.max_path_speed_m_per_s,
                f"robot file ({rob.source}) max_path_speed_mm_per_s "
                f"{rob.max_path_speed_m_per_s * 1e3:g} mm/s",
            )
        )
    if not caps:
        caps.append(
            (
                DEFAULT_MAX_PATH_SPEED_M_PER_S,
                f"default robot path speed {DEFAULT_MAX_PATH_SPEED_M_PER_S * 1e3:g} mm/s",
            )
        )
        notes.append(
            f"robot path speed: neither cut.max_feed_mm_per_min nor the robot file's "
            f"max_path_speed_mm_per_s is given; the plan keeps feeds below the default "
            f"{DEFAULT_MAX_PATH_SPEED_M_PER_S * 6e4:g} mm/min"
        )
    max_feed, max_why = min(caps)
    if len(caps) == 2 and caps[0][0] > caps[1][0]:
        notes.append(
            f"the job's cut.max_feed_mm_per_min {caps[0][0] * 6e4:g} exceeds the robot's path "
            f"speed {caps[1][0] * 6e4:g} mm/min (max_path_speed_mm_per_s): the plan keeps the "
            "robot's"
        )
    rpm_feed = max_feed * 60.0 / (kept * teeth)
    if rpm_feed < rpm_min:
        key = "cut.max_feed_mm_per_min" if max_why.startswith("cut.") else "max_path_speed"
        raise InputError(
            f"{key}: expected a path speed of at least {rpm_min * kept * teeth * 1e3:.4g} mm/min "
            f"(the lowest speed {rpm_min:.0f} rpm, {rpm_min_why}, at {kept * 1e3:.3g} mm per "
            f"tooth ({kept_src}) and {teeth} teeth), found {max_why} ({max_feed * 6e4:.4g} "
            "mm/min)",
            source=where,
        )
    fz_prog.setflags(write=False)
    return ProcessLimits(
        rpm_min=float(rpm_min),
        rpm_max=float(rpm_max),
        rpm_min_why=rpm_min_why,
        rpm_max_why=rpm_max_why,
        vc_min_m_per_min=float(vc_lo),
        vc_max_m_per_min=float(vc_hi),
        vc_source=vc_source,
        feed_per_tooth_m=float(kept),
        feed_per_tooth_source=kept_src,
        fz_program_m=fz_prog,
        max_feed_m_per_s=float(max_feed),
        max_feed_why=max_why,
        notes=tuple(notes),
        fz_min_m=float(fz_lo),
        fz_max_m=float(fz_hi),
        fz_range_source=fz_src,
    )


def _label(wp: pd.DataFrame, k: int) -> str:
    return f"{wp['source'].iloc[k]}:{int(wp['line'].iloc[k])}"


def _program_chip_load(
    wp: pd.DataFrame, cut: NDArray[np.bool_], teeth: int, path_name: str
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """The program's F / (S N) [m] per waypoint (every feed move, air moves too; NaN on
    rapids or where unstated), and the lateral cutting moves (not along the tool axis)."""
    from robolobe.plan.pipeline import PLUNGE_LATERAL  # pipeline imports this module

    f = wp["feed_mm_per_min"].to_numpy(dtype=np.float64)
    s = wp["rpm_programmed"].to_numpy(dtype=np.float64)
    for what, v in (("feed F", f), ("spindle speed S", s)):
        bad = cut & np.isfinite(v) & (v <= 0)
        if np.any(bad):
            k = int(np.argmax(bad))
            raise InputError(
                f"expected a positive {what} on this cutting move, found {v[k]:g}",
                _label(wp, k) if "source" in wp else Path(path_name).name,
            )
    with np.errstate(invalid="ignore", divide="ignore"):
        fed = (wp["motion"] == "cut").to_numpy() | cut
        ok = fed & np.isfinite(f) & np.isfinite(s) & (s > 0)
        fz = np.where(ok, f * 1e-3 / (s * teeth), np.nan)
    fdir = wp[["fx", "fy", "fz"]].to_numpy(dtype=np.float64)
    axis = wp[["i", "j", "k"]].to_numpy(dtype=np.float64)
    along = np.einsum("ij,ij->i", fdir, axis)
    lat = np.linalg.norm(fdir - along[:, None] * axis, axis=1)
    lateral = cut & np.isfinite(lat) & (lat >= PLUNGE_LATERAL)
    return fz, lateral


def _chip_load_notes(
    job: Job,
    wp: pd.DataFrame,
    fz_prog: FloatArray,
    states: NDArray[np.bool_],
    cut: NDArray[np.bool_],
    notes: list[str],
) -> tuple[float, str]:
    """The chip load kept and whose it is; the notes that say so."""
    fz_job = job.cut.feed_per_tooth_m
    frm = job.cut.feed_per_tooth_from
    teeth = job.tool.teeth
    if not np.any(states):
        f = wp["feed_mm_per_min"].to_numpy(dtype=np.float64)
        with_f = cut & np.isfinite(f)
        prs = job.cut.programmed_rpm
        hint = ""
        if prs and np.any(with_f):
            fz_alt = f[with_f] * 1e-3 / (prs * teeth)
            hint = (
                f"; at the job's cut.programmed_rpm {prs:g} its F would be "
                f"{np.nanmin(fz_alt) * 1e3:.3g}-{np.nanmax(fz_alt) * 1e3:.3g} mm per tooth"
            )
        notes.append(
            "the program states no chip load on its lateral cutting moves (F and S on the "
            f"same move): the plan keeps the job's cut.feed_per_tooth_mm {fz_job * 1e3:g} mm" + hint
        )
        return fz_job, "job"
    vals = fz_prog[states]
    largest = float(vals.max())
    distinct = np.unique(np.round(vals * 1e9))  # to 1 nm: one chip load printed several ways
    kept, src = (largest, "program") if frm == "program" else (fz_job, "job")
    off = states & (np.abs(np.where(states, fz_prog, fz_job) / fz_job - 1.0) > FZ_DISAGREE)
    if np.any(off):
        k = int(np.argmax(off))
        f_k, s_k = float(wp["feed_mm_per_min"].iloc[k]), float(wp["rpm_programmed"].iloc[k])
        which = (
            'the program\'s (cut.feed_per_tooth_from = "program"; "job" keeps the job\'s)'
            if src == "program"
            else 'the job\'s (cut.feed_per_tooth_from = "job")'
        )
        notes.append(
            f"the program's chip load differs from the job's cut.feed_per_tooth_mm "
            f"{fz_job * 1e3:g} mm by more than {FZ_DISAGREE * 100:g} % on "
            f"{count(int(off.sum()), 'cutting move')} (first {_label(wp, k)}: "
            f"F{f_k:g} / (S{s_k:g} x {teeth}) = {fz_prog[k] * 1e3:.3g} mm); the plan keeps {which}"
        )
    if src == "program" and distinct.size > 1:
        notes.append(
            f"the program states {distinct.size} chip loads on its lateral cutting moves "
            f"({float(vals.min()) * 1e3:.3g}-{largest * 1e3:.3g} mm): power, torque and the "
            f"feed cap are planned at the largest, {largest * 1e3:.3g} mm; each move keeps its own"
        )
    n_none = int(np.sum(cut & ~np.isfinite(fz_prog)))
    if src == "program" and n_none:
        notes.append(
            f"{count(n_none, 'cutting move')} without F and S in the program: the job's "
            f"cut.feed_per_tooth_mm {fz_job * 1e3:g} mm there"
        )
    return kept, src


# ----------------------------------------------------------------- binding
def binding_limit(label: str, limits: ProcessLimits, job: Job) -> str:
    """The physical limit behind one of the optimizer's ``limiting`` labels.

    Parameters
    ----------
    label : str
        ``"stability"``, ``"power"``, ``"torque"``, ``"depth_max"``,
        ``"rpm_min"``, ``"rpm_max"``, ``"feed_max"`` or ``"plunge"``
        (:func:`robolobe.plan.optimize.optimize_schedule`); ``"air"`` and
        ``"schedule"`` (nothing binds at the move) from a plan in passes.
    limits : ProcessLimits
    job : Job

    Returns
    -------
    str
        E.g. ``"the highest speed: vc_max 300 m/min (material table: steel,
        carbide) = 3820 rpm at D 25 mm"``.
    """
    sp = job.spindle
    if label == "stability":
        return f"stability (depth at a_lim / safety factor {job.plan.safety_factor:g})"
    if label == "power":
        return f"spindle power (spindle.power_kW {sp.power_W * 1e-3:g})"
    if label == "torque":
        return f"spindle torque (spindle.torque_Nm {sp.torque_Nm:g})"
    if label == "depth_max":
        return f"the depth cap (plan.depth_max_mm {job.plan.depth_max_m * 1e3:g})"
    if label == "rpm_min":
        return f"the lowest speed: {limits.rpm_min_why}"
    if label == "rpm_max":
        return f"the highest speed: {limits.rpm_max_why}"
    if label == "feed_max":
        return (
            f"the robot path speed: {limits.max_feed_why} at "
            f"{limits.feed_per_tooth_m * 1e3:.3g} mm per tooth"
        )
    if label == "plunge":
        return "none (a plunge: no lateral stability limit)"
    if label == "air":
        return "none (a feed move in air: no stability limit)"
    if label == "schedule":
        return (
            "the speed schedule: none binds at the move itself (its speed is held by the "
            "stability of the moves around it at the speeds the rate limit lets it reach)"
        )
    return label


def binding_notes(
    limiting: ArrayLike,
    source: Any,
    line: ArrayLike,
    limits: ProcessLimits,
    job: Job,
) -> list[str]:
    """One sentence per binding limit: what binds, at how many waypoints, where first.

    Parameters
    ----------
    limiting : array_like of str, shape (n_cut,)
        The optimizer's label of each cutting waypoint.
    source, line : array_like, shape (n_cut,)
        Their file and line (for ``file:line``); ``source`` may be any
        sequence indexed by position (only the named waypoints' are read).
    limits : ProcessLimits
    job : Job

    Returns
    -------
    list of str
        Most frequent first (ties in path order); plunges left out (the
        summary counts them).
    """
    codes, names = pd.factorize(np.asarray(limiting))
    n = codes.size
    counts = np.bincount(codes, minlength=len(names))
    _, first = np.unique(codes, return_index=True)  # factorize numbers in order of appearance
    # entries are read one at a time: a sequence that makes them when read stays one
    src: Any = source if hasattr(source, "__getitem__") else np.asarray(source)
    ln = np.asarray(line)
    out: list[str] = []
    for j in sorted(range(len(names)), key=lambda j: (-counts[j], first[j])):
        name = str(names[j])
        if name == "plunge":
            continue
        k = int(first[j])
        out.append(
            f"binding limit at {int(counts[j])} of {count(n, 'cutting waypoint')} (first "
            f"{src[k]}:{int(ln[k])}): {binding_limit(name, limits, job)}"
        )
    return out
