"""Hand the program back: a plan's speeds, feeds and passes written into the program it read.

:func:`write_program` turns a plan into the program's own dialect (G-code,
APT/CL, KUKA KRL, ABB RAPID; or a CSV waypoint table with rpm and feed
columns from any of them) and checks the result before it keeps it: the
written text is read back with robolobe's own reader and must reproduce
every move of :func:`~robolobe.plan.paths._edit.expected_table` to 1e-6 mm
with its S and F; anything else is an internal error, never a file.

The per-move values (:func:`program_edit`):

- **S**: the plan's speed at the move (for a linearised arc, the speed at
  its tightest point), rounded to whole rpm, held across moves while the
  plan's speed stays within ``hysteresis_pct`` of it or less than
  ``min_segment_mm`` of cutting has run since the last change, unless
  holding it would take a move below the safety factor by the plan's own
  lobes (then the plan's speed is taken there). Job section ``[program]``.
- **F**: the program's feed per tooth kept: ``F_new = F_old * S_new /
  S_old`` (the program's F and S at the move; ``cut.programmed_rpm`` where
  the program has no S); where the program has no F or S the plan's feed
  (``feed_per_tooth_mm * teeth * S_new``); capped by
  ``cut.max_feed_mm_per_min`` (the robot's path-speed limit) where given.
- **Passes**: the plan table's ``passes`` column (and ``depth_mm`` per pass)
  where it has one, else ``passes=`` given here; one pass otherwise. Each
  section (a run of cutting moves) is cut whole once per pass, pass ``k`` of
  ``n`` at ``(n - k) * depth_mm`` above the programmed depth along the tool
  axis, with rapid links (:func:`robolobe.plan.paths._edit.pass_layout`).

Translations (:data:`TRANSLATIONS`): G-code and APT into each other (the
plan's moves as cutter-location records), any dialect into the CSV table;
others are refused with what the target needs (:data:`UNDEFINED`). A
program without its end (M30/M2 or a closing %, FINI, END, ENDPROC/
ENDMODULE) is not written back (:class:`IncompleteProgramError`).
"""

from __future__ import annotations

import hashlib
import logging
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe._atomic import atomic_path, not_a_file
from robolobe._memory import release_free_memory
from robolobe.errors import InputError
from robolobe.plan.job import Job
from robolobe.plan.limits import process_limits
from robolobe.plan.paths import detect_format, read_toolpath, reader_options
from robolobe.plan.paths._edit import ProgramEdit, expected_table
from robolobe.plan.paths._table import segment_lengths
from robolobe.plan.paths._text import TRUNCATED
from robolobe.plan.pipeline import PlanResult

__all__ = [
    "EXTENSIONS",
    "PROGRAM_DEFAULTS",
    "TRANSLATIONS",
    "UNDEFINED",
    "WRITERS",
    "FolderPlan",
    "IncompleteProgramError",
    "ProgramText",
    "check_program_format",
    "program_changes",
    "program_edit",
    "program_text",
    "read_folder_plan",
    "write_program",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
ArrayLikeInt = Any
ArrayLikeFloat = Any

#: ``[program]`` job keys and their defaults (see the module docstring).
PROGRAM_DEFAULTS: dict[str, Any] = {
    "min_segment_mm": 10.0,
    "hysteresis_pct": 2.0,
    "retract_mm": 5.0,
    "analog_output": None,
    "analog_rpm_full_scale": None,
    "analog_full_scale": 1.0,
    "rapid_sync": "triggio",
}

#: File extension of the written program per dialect.
EXTENSIONS: dict[str, str] = {
    "gcode": ".nc",
    "apt": ".apt",
    "krl": ".src",
    "rapid": ".mod",
    "table": ".csv",
}

#: Dialects a program may be written in, per dialect read. G-code and APT
#: translate into each other (both are cutter-location data with F and S: the
#: plan's moves, passes included, written as the other's moves); any dialect
#: writes the waypoint table. Other translations are refused (:data:`UNDEFINED`).
TRANSLATIONS: dict[str, tuple[str, ...]] = {
    "gcode": ("gcode", "apt", "table"),
    "apt": ("apt", "gcode", "table"),
    "krl": ("krl", "table"),
    "rapid": ("rapid", "table"),
    "table": ("table",),
}

#: Why a translation is not defined, by the dialect asked for (robot programs
#: out of CNC data) or read (CNC data out of robot programs).
UNDEFINED: dict[str, str] = {
    "krl": "a KRL program needs the robot's targets (orientation A, B, C and status/turn "
    "per point, $BASE and $TOOL), which {read} does not hold",
    "rapid": "a RAPID module needs robtargets (orientation quaternion and robot "
    "configuration per point, tool and work object data), which {read} does not hold",
    "robot": "{read} holds the robot's TCP path in its base, with the tool's turn about "
    "its axis; CNC data of it is not defined",
    "table": "a waypoint table holds no program to write {fmt} into",
}


#: Dialects a program can be written in (--program-format).
WRITERS: tuple[str, ...] = ("gcode", "apt", "krl", "rapid", "table")


@dataclass(frozen=True, eq=False)
class _Record:
    plan_record: dict[str, Any]


@dataclass(frozen=True, eq=False)
class FolderPlan:
    """A plan read back from its folder (``robolobe plan -o DIR``), for :func:`write_program`.

    Holds what the writer needs: the job, the source program's path and its
    waypoint table (read again), the plan's per-waypoint table and its
    record. Without the lobes, the written speed follows the plan's at every
    move (a held speed could not be checked against the lobes).
    """

    job: Job
    path: str
    waypoints: pd.DataFrame
    table: pd.DataFrame
    summary: _Record
    lobes: None = None


#: What the writer takes: a plan in memory or one read from its folder.
AnyPlan = PlanResult | FolderPlan


class IncompleteProgramError(InputError):
    """The program has no end (M30/M2 or %...%, FINI, END, ENDPROC/ENDMODULE): not written back."""


def check_program_format(fmt: str | None, path: str | os.PathLike[str] | None = None) -> None:
    """Refuse an unknown ``--program-format``, or one not defined from ``path``'s dialect.

    Called before any work (the plan is not computed to be refused after).
    """
    if fmt is not None and fmt not in WRITERS:
        raise InputError(f"--program-format: expected one of {', '.join(WRITERS)}, found {fmt!r}")
    if fmt is not None and path is not None and Path(path).is_file():
        _check_translation(detect_format(path), fmt, Path(path).name)


def _check_translation(read_fmt: str, fmt: str, source: str) -> None:
    if fmt not in TRANSLATIONS.get(read_fmt, ()):
        why = UNDEFINED.get(fmt) or UNDEFINED["robot" if read_fmt in ("krl", "rapid") else read_fmt]
        raise InputError(
            f"--program-format: a translation from {read_fmt} to {fmt!r} is not defined: "
            f"{why.format(read=read_fmt, fmt=fmt)}; expected one of "
            f"{list(TRANSLATIONS.get(read_fmt, ()))}",
            source=source,
        )


def _options(res: AnyPlan) -> dict[str, Any]:
    return {**PROGRAM_DEFAULTS, **res.job.program_options}


def _blocks(wp: pd.DataFrame, cut: NDArray[np.bool_]) -> tuple[IntArray, IntArray]:
    """Block id per row (-1 off the cut) and each block's first row.

    A block is a run of cutting rows from one source line (one program block).
    """
    n = len(wp)
    line = wp["line"].to_numpy()
    src = pd.factorize(wp["source"], use_na_sentinel=False)[0]  # not a str per row
    new = np.zeros(n, bool)
    new[0] = cut[0]
    if n > 1:
        new[1:] = cut[1:] & (~cut[:-1] | (line[1:] != line[:-1]) | (src[1:] != src[:-1]))
    bid = np.cumsum(new) - 1
    bid[~cut] = -1
    return bid.astype(np.int64, copy=False), np.flatnonzero(new).astype(np.int64)


def _margin_at(res: AnyPlan, rows: IntArray, rpm: FloatArray) -> FloatArray:
    """Margin of ``rows`` at speeds ``rpm`` by the plan's own lobes (NaN: no lateral limit).

    The exact limit (the lobes' own boundary, as the planner verifies) over each
    move's own depth per pass (``cut_depth_mm`` of a plan in passes, else
    ``depth_mm``).
    """
    tab = res.table
    if res.lobes is None:
        return np.full(len(rows), np.nan)
    lt = res.lobes.table
    g = tab["dynamics_group"].to_numpy()[rows]
    col = "cut_depth_mm" if "cut_depth_mm" in tab.columns else "depth_mm"
    depth = tab[col].to_numpy(dtype=np.float64)[rows] * 1e-3
    out = np.full(len(rows), np.nan)
    ok = (g >= 0) & (depth > 0)
    if np.any(ok):
        al = lt.rows(np.asarray(rpm, dtype=np.float64)[ok][:, None], g[ok])[:, 0]
        out[ok] = np.where(np.isfinite(al), al / depth[ok], np.nan)
    return out


def _whole_rpm(res: AnyPlan, rows: IntArray, w: float, sf: float) -> float:
    """``w`` [rpm] to whole rpm: the neighbour that keeps ``rows`` at the safety factor.

    Rounding to the nearest can cross a lobe wall by a fraction of a rpm at a
    move planned right at the safety factor; of the two whole neighbours the
    nearer one that keeps every move of ``rows`` at ``sf`` is taken, else the
    one with the larger smallest margin (a plan read from its folder: the nearest).
    """
    near = float(round(w))
    if res.lobes is None or float(w).is_integer():
        return near
    cands = sorted((math.floor(w), math.ceil(w)), key=lambda c: abs(c - w))
    mins = []
    for c in cands:
        mg = _margin_at(res, rows, np.full(len(rows), float(c)))
        mg = mg[np.isfinite(mg)]
        mins.append(float(mg.min()) if mg.size else math.inf)
    for c, m in zip(cands, mins, strict=True):
        if m >= sf * (1 - 1e-12):
            return float(c)
    return float(cands[int(np.argmax(mins))])


def _block_speeds(res: AnyPlan, rows: IntArray, bid: IntArray, opts: dict[str, Any]) -> FloatArray:
    """The S [rpm] of each block (module docstring): held, changed, or the plan's own.

    Parameters
    ----------
    res : PlanResult or FolderPlan
    rows : ndarray of int, shape (m,)
        The cutting rows, ascending.
    bid : ndarray of int, shape (m,)
        Each one's block (0 .. nb - 1, non-decreasing).
    opts : dict
        The ``[program]`` options.

    Returns
    -------
    ndarray, shape (nb,)

    Apart from :func:`program_edit` so that its per-block arrays are gone before
    the per-row S, F and margins are made (a long program's peak).
    """
    tab = res.table
    rpm_plan = tab["rpm"].to_numpy(dtype=np.float64)
    margin = tab["margin"].to_numpy(dtype=np.float64)
    nb = int(bid[-1]) + 1 if len(bid) else 0
    # the tightest row of each block sets the block's wanted speed
    m = np.where(np.isfinite(margin[rows]), margin[rows], np.inf)
    order = np.lexsort((m, bid))
    del m
    starts = np.searchsorted(bid[order], np.arange(nb))
    want = rpm_plan[rows[order[starts]]]
    del order, starts
    seg_mm = segment_lengths(res.waypoints, rows) * 1e3  # the table's columns: no (n, 3) copy
    length = np.bincount(bid, weights=seg_mm, minlength=nb)
    del seg_mm
    # the rows of block b: rows[b_start[b] : b_start[b + 1]] (not a million small arrays)
    b_start = np.concatenate([[0], np.flatnonzero(np.diff(bid)) + 1, [len(rows)]])
    hyst = float(opts["hysteresis_pct"]) / 100.0
    min_seg = float(opts["min_segment_mm"])
    sf = res.job.plan.safety_factor
    s_block = np.empty(nb)
    held = math.nan
    since = 0.0
    # runs of blocks whose wanted speed rounds to one value: while the held speed is
    # that value nothing is decided there (a million blocks, few decisions)
    whole = np.round(want)  # round half to even, as round() below
    skip = bool(np.all(np.isfinite(want)))  # round(NaN) raises below, as it did
    if skip and nb:
        ends = np.flatnonzero(np.diff(whole)) + 1
        run_end = np.repeat(np.append(ends, nb), np.diff(np.concatenate([[0], ends, [nb]])))
    b = 0
    while b < nb:
        e = int(run_end[b]) if skip else b
        if e - b > 16 and whole[b] == held:  # (short runs: the loop below is quicker)
            # s_block and the distance since the last change as the loop below makes them
            s_block[b:e] = held
            since = float(np.add.accumulate(np.concatenate([[since], length[b:e]]))[-1])
            b = e
            continue
        w = float(want[b])
        r_b = rows[b_start[b] : b_start[b + 1]]
        if math.isnan(held):
            held, since = _whole_rpm(res, r_b, w, sf), 0.0
        elif held != round(w):
            rel = abs(w - held) / held
            change = rel > hyst and since >= min_seg
            if not change:
                if res.lobes is None:  # a plan read from its folder: a hold cannot be checked
                    change = True
                else:
                    mg = _margin_at(res, r_b, np.full(len(r_b), held))
                    change = bool(np.any(mg < sf))
            if change:
                held, since = _whole_rpm(res, r_b, w, sf), 0.0
        s_block[b] = held
        since += float(length[b])
        b += 1
    return s_block


def program_edit(
    res: AnyPlan,
    *,
    passes: ArrayLikeInt | None = None,
    depth_mm: ArrayLikeFloat | None = None,
) -> ProgramEdit:
    """The per-move S, F and passes the written program carries (module docstring).

    Parameters
    ----------
    res : PlanResult
    passes : int or array of int, shape (n,), optional
        Passes per waypoint; default: the plan table's ``passes`` column, else 1.
    depth_mm : float or array, shape (n,), optional
        Total depth [mm] the passes divide; default: ``passes * depth_mm`` of
        the plan table (its depth per pass).

    Returns
    -------
    ProgramEdit
    """
    opts = _options(res)
    wp = res.waypoints
    tab = res.table
    n = len(wp)
    cut = (wp["motion"] == "cut").to_numpy()
    rows = np.flatnonzero(cut)
    bid = _blocks(wp, cut)[0][rows]  # each cutting row's block
    rpm_plan = tab["rpm"].to_numpy(dtype=np.float64)
    margin = tab["margin"].to_numpy(dtype=np.float64)
    s_block = _block_speeds(res, rows, bid, opts)
    rpm = np.full(n, np.nan)
    rpm[rows] = s_block[bid]
    del s_block, bid
    mg = np.full(n, np.nan)
    same = np.abs(rpm[rows] - rpm_plan[rows]) < 1.0
    mg[rows[same]] = margin[rows[same]]
    if np.any(~same) and res.lobes is not None:
        r = rows[~same]
        mg[r] = _margin_at(res, r, rpm[r])
    # feed: the program's feed per tooth kept, else the plan's
    f_old = wp["feed_mm_per_min"].to_numpy(dtype=np.float64)
    s_old = wp["rpm_programmed"].to_numpy(dtype=np.float64)
    if res.job.cut.programmed_rpm is not None:
        s_old = np.where(np.isfinite(s_old), s_old, res.job.cut.programmed_rpm)
    with np.errstate(invalid="ignore", divide="ignore"):
        # where(own, f_old * rpm / s_old, per_rev_plan * rpm), made in place (a long path's peak)
        feed = tab["feed_mm_per_min"].to_numpy(dtype=np.float64) / rpm_plan
        feed *= rpm
        kept = f_old * rpm
        kept /= s_old
        np.copyto(feed, kept, where=np.isfinite(f_old) & np.isfinite(s_old) & (s_old > 0))
        del kept
    # the robot's path speed (the job's key, else the robot file's, else the stated default)
    np.minimum(feed, process_limits(res.job).max_feed_m_per_s * 6e4, out=feed)
    feed[~cut] = np.nan
    bad = cut & ~(np.isfinite(feed) & (feed > 0) & np.isfinite(rpm) & (rpm > 0))
    if np.any(bad):
        i = int(np.argmax(bad))
        raise InputError(
            f"expected a spindle speed and feed for every cutting move, found S = {rpm[i]:g}, "
            f"F = {feed[i]:g} mm/min",
            source=f"{wp['source'].iloc[i]}:{wp['line'].iloc[i]}",
        )
    # passes
    if passes is None and "passes" in tab.columns:
        passes = tab["passes"].to_numpy()
        if depth_mm is None:
            depth_mm = passes * tab["depth_mm"].to_numpy(dtype=np.float64)
    p = np.broadcast_to(np.asarray(1 if passes is None else passes), (n,)).astype(np.int64)
    if np.any(p < 1):
        raise InputError(f"passes: expected integers >= 1, found {int(p.min())}")
    d = np.broadcast_to(
        np.asarray(math.nan if depth_mm is None else depth_mm, dtype=np.float64), (n,)
    ).copy()
    d[p <= 1] = math.nan
    p = np.where(cut, p, 1)
    return ProgramEdit(
        waypoints=wp,
        rpm=rpm,
        feed_mm_per_min=feed,
        margin=mg,
        passes=p,
        depth_mm=d,
        retract_mm=float(opts["retract_mm"]),
        options=opts,
    )


class ProgramText(dict[str, str]):
    """The written program: file name -> text (two files for KRL: ``.src`` and ``.dat``)."""


def read_folder_plan(
    plan_dir: str | os.PathLike[str], job: str | os.PathLike[str] | Job | None = None
) -> FolderPlan:
    """A plan folder with its source program, checked to belong together.

    Raises
    ------
    InputError
        No plan there (:func:`robolobe.plan.verify.read_plan`), its source
        program missing, or a program whose moves are not the plan's.
    """
    from robolobe.plan.verify import read_plan

    table, summary, j = read_plan(plan_dir, job)
    d = Path(plan_dir)
    given = str(summary.get("path") or "")
    cands = [Path(given), d / Path(given).name, d.parent / Path(given).name] if given else []
    src = next((c for c in cands if c.is_file()), None)
    if src is None:
        raise InputError(
            f"the plan's source program {given or '(none recorded)'} is not found (looked at "
            f"{', '.join(str(c) for c in cands) or 'nothing'}): the program is written from it",
            str(d / "summary.json"),
        )
    wp = read_toolpath(src, applicable_only=True, **j.path_options)
    same = len(wp) == len(table) and bool(
        np.array_equal(wp["line"].to_numpy(), table["line"].to_numpy())
    )
    if not same:
        raise InputError(
            f"the program reads to {len(wp)} moves, the plan's table has {len(table)} (thinned "
            "with --waypoints-every, or another program): plan it again",
            str(src),
        )
    return FolderPlan(j, str(src), wp, table, _Record(summary["plan_record"]))


def _source_path(res: AnyPlan) -> Path:
    """The plan's source program, checked against the hash the plan recorded."""
    if res.path in ("<table>", "") or not Path(res.path).is_file():
        where = res.path if res.path not in ("<table>", "") else "the plan"
        raise InputError(
            "write_program: expected the plan's source program, found "
            + (not_a_file(Path(res.path)) if res.path not in ("<table>", "") else "none"),
            source=where,
        )
    p = Path(res.path)
    want = res.summary.plan_record.get("path_sha256")
    got = hashlib.sha256(p.read_bytes()).hexdigest()
    if want is not None and got != want:
        raise InputError(
            f"the program changed since the plan: sha256 {got[:12]}..., the plan recorded "
            f"{want[:12]}... (plan it again)",
            source=str(p),
        )
    return p


def program_text(
    res: AnyPlan,
    fmt: str | None = None,
    *,
    edit: ProgramEdit | None = None,
    name: str = "program",
) -> ProgramText:
    """The program text ``write_program`` writes, checked by reading it back.

    Parameters
    ----------
    res : PlanResult
    fmt : {"gcode", "apt", "krl", "rapid", "table"}, optional
        Dialect to write; default: the one read.
    edit : ProgramEdit, optional
        Default: :func:`program_edit` of ``res``.
    name : str
        Stem of the written file(s).

    Returns
    -------
    ProgramText
        File name -> text.

    Raises
    ------
    InputError
        No source program, a changed one, an undefined translation, missing
        analog scaling keys (KRL/RAPID), passes the dialect cannot hold.
    """
    check_program_format(fmt)
    src = _source_path(res)
    read_fmt = detect_format(src)
    fmt = fmt or read_fmt
    _check_translation(read_fmt, fmt, src.name)
    if edit is None:
        edit = program_edit(res)
        release_free_memory(len(res.table))  # the edit's temporaries: not under the writer's peak
    opts = reader_options(read_fmt, res.job.path_options) if read_fmt != "table" else {}
    files = _write(fmt, read_fmt, src, edit, name, opts)
    release_free_memory(len(res.table))  # the writer's lines: not under the check's peak
    # a translation states its units and frame itself: read back without the source's options
    _check(files, fmt, name, edit, opts if fmt == read_fmt else {}, src.name)
    return files


def _write(
    fmt: str, read_fmt: str, src: Path, edit: ProgramEdit, name: str, opts: dict[str, Any]
) -> ProgramText:
    from robolobe.plan.paths import _text

    out = ProgramText()
    if fmt == "table":
        from robolobe.plan.paths._table import program_table

        out[name + ".csv"] = program_table(edit)
        return out
    text = _text.read_text(src)
    if fmt != read_fmt:
        out[name + EXTENSIONS[fmt]] = _translate(fmt, read_fmt, src, text, edit)
        return out
    if fmt == "gcode":
        from robolobe.plan.paths.gcode import write_gcode

        out[name + ".nc"] = write_gcode(text, src.name, edit)
    elif fmt == "apt":
        from robolobe.plan.paths.apt import write_apt

        coords = str(opts.get("coordinates", "workpiece"))
        out[name + ".apt"] = write_apt(text, src.name, edit, coordinates=coords)
    elif fmt == "krl":
        from robolobe.plan.paths.krl import write_krl

        dat = next(
            (q for q in (src.with_suffix(".dat"), src.with_suffix(".DAT")) if q.is_file()), None
        )
        dat_text = _text.read_text(dat) if dat is not None else None
        src_out, dat_out = write_krl(text, src.name, edit, name=name, dat=dat_text, options=opts)
        out[name + ".src"] = src_out
        if dat_out is not None:
            out[name + ".dat"] = dat_out
    elif fmt == "rapid":
        from robolobe.plan.paths.rapid import write_rapid

        coords = str(opts.get("coordinates", "workpiece"))
        out[name + ".mod"] = write_rapid(text, src.name, edit, coordinates=coords)
    return out


def _translate(fmt: str, read_fmt: str, src: Path, text: str, edit: ProgramEdit) -> str:
    """The plan's moves (passes and links included) written in the other CL dialect.

    What is translated: every move (arcs as the reader linearised them, to
    ``arc_tol_mm``), the spindle speed, its direction, the feed and the tool
    number. What is not: coolant, stops, cycles, comments and other machine
    functions of the source (said in the written program's head).

    Raises
    ------
    InputError
        A source that uses both spindle directions or more than one tool.
    """
    from robolobe.plan.paths.apt import apt_setup, translate_apt
    from robolobe.plan.paths.gcode import gcode_setup, translate_gcode

    directions, tools = gcode_setup(text) if read_fmt == "gcode" else apt_setup(text)
    if len(directions) > 1 or len(tools) > 1:
        what = (
            f"spindle directions {sorted(directions)}"
            if len(directions) > 1
            else (f"tools {tools}")
        )
        raise InputError(
            f"--program-format {fmt}: the program uses {what}; a translation carries one "
            f"tool turning one way (write it as {read_fmt}, or split the program)",
            source=src.name,
        )
    ccw = bool(directions & {"M4", "CCLW"})
    tool = tools[0] if tools else None
    note = [
        f"ROBOLOBE: translated from {src.name} ({read_fmt}) with the plan's spindle speeds, "
        "feeds and passes",
        "ROBOLOBE: moves (arcs as line segments), spindle speed and direction, feed and tool "
        "only; coolant, stops, cycles and other machine functions of the source are not "
        "carried over",
    ]
    logger.warning(
        "%s: translated to %s: coolant, stops, cycles and other machine functions of the "
        "source are not carried over",
        src.name,
        fmt,
    )
    exp = expected_table(edit, full=True)
    if fmt == "gcode":
        return translate_gcode(exp, src.name, spindle="M4" if ccw else "M3", tool=tool, note=note)
    return translate_apt(exp, src.name, direction="CCLW" if ccw else "CLW", tool=tool, note=note)


def _reread(files: ProgramText, fmt: str, name: str, opts: dict[str, Any]) -> pd.DataFrame:
    """The written program read back, its reader's notes not logged (they were, for the source)."""
    import logging

    log = logging.getLogger("robolobe.plan.paths")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        return _reread_files(files, fmt, name, opts)
    finally:
        log.setLevel(level)


def _reread_files(files: ProgramText, fmt: str, name: str, opts: dict[str, Any]) -> pd.DataFrame:
    import tempfile

    with tempfile.TemporaryDirectory(prefix="robolobe-program-") as tmp:
        for fname, text in files.items():
            (Path(tmp) / fname).write_text(text, encoding="utf-8")
        main = Path(tmp) / (name + EXTENSIONS[fmt])
        if fmt == "table":
            return read_toolpath(main, "table")
        return read_toolpath(main, fmt, applicable_only=True, **opts)


def _check(
    files: ProgramText,
    fmt: str,
    name: str,
    edit: ProgramEdit,
    opts: dict[str, Any],
    source: str,
) -> None:
    """Read the written program back; it must give ``expected_table(edit)``."""
    got = _reread(files, fmt, name, {**opts, **_analog_options(edit, fmt)})
    # a program without its end (M30/M2 or %...%, FINI, END, ENDPROC/ENDMODULE): read
    # tolerantly, but a controller rejects it, and a copy of a truncated program is one too
    cut_off = [w for w in got.attrs.get("warnings", []) if TRUNCATED in w]
    if cut_off:
        why = cut_off[0].split(": ", 1)[-1].split(f": {TRUNCATED}")[0]
        raise IncompleteProgramError(
            f"expected a complete program to write back, found {why} ({TRUNCATED}; a "
            "controller rejects it): complete the program and plan it again",
            source=source,
        )
    # what the check reads of it (the other columns go: not beside the expected table)
    got = got[["x_m", "y_m", "z_m", "motion", "rpm_programmed", "feed_mm_per_min", "line"]]
    # the reader's freed buffers: not under the expected table's and the comparison's peak
    release_free_memory(len(got))
    exp = expected_table(edit, full=False)
    where = f"{name}{EXTENSIONS[fmt]} (written from {source})"
    fix = " (not written; --program-format table or --no-program)"
    if len(got) != len(exp):
        raise InputError(
            f"robolobe cannot write this program faithfully: it reads back to {len(got)} "
            f"moves, expected {len(exp)}{fix}",
            source=where,
        )
    r = _first_difference(got, exp)
    if r is not None:
        p = [float(got[c].iloc[r]) * 1e3 for c in ("x_m", "y_m", "z_m")]
        q = [float(exp[c].iloc[r]) for c in ("x_mm", "y_mm", "z_mm")]
        raise InputError(
            f"robolobe cannot write this program faithfully: move {r} (written line "
            f"{got['line'].iloc[r]}) reads back as {np.round(p, 6).tolist()} mm "
            f"{got['motion'].iloc[r]} S{got['rpm_programmed'].iloc[r]:g} "
            f"F{got['feed_mm_per_min'].iloc[r]:g}, expected {np.round(q, 6).tolist()} mm "
            f"{exp['motion'].iloc[r]} S{exp['rpm'].iloc[r]:g} "
            f"F{exp['feed_mm_per_min'].iloc[r]:g}{fix}",
            source=where,
        )


#: Rows the check of a written program compares at a time (:func:`_first_difference`).
CHECK_BLOCK_ROWS = 65_536


def _first_difference(
    got: pd.DataFrame, exp: pd.DataFrame, block: int = CHECK_BLOCK_ROWS
) -> int | None:
    """The first row where the program read back is not the expected table, or None.

    A row differs where a coordinate is off by more than 1e-6 mm, the motion
    differs, or a cutting move's S (relative 1e-9) or F (relative 1e-7) does.
    ``block`` rows are compared at a time: no copy of either table's columns
    (on a million-move program the comparison's arrays were the check's peak).

    Parameters
    ----------
    got : pandas.DataFrame, shape (n, ...)
        The written program's waypoint table (its reader's: positions [m]).
    exp : pandas.DataFrame, shape (n, ...)
        :func:`~robolobe.plan.paths._edit.expected_table` (positions [mm]).
    block : int
        Rows compared at a time.
    """
    pos = [
        (got[g].to_numpy(dtype=np.float64), exp[e].to_numpy(dtype=np.float64))
        for g, e in (("x_m", "x_mm"), ("y_m", "y_mm"), ("z_m", "z_mm"))
    ]
    g_rpm = got["rpm_programmed"].to_numpy(dtype=np.float64)
    e_rpm = exp["rpm"].to_numpy(dtype=np.float64)
    g_feed = got["feed_mm_per_min"].to_numpy(dtype=np.float64)
    e_feed = exp["feed_mm_per_min"].to_numpy(dtype=np.float64)
    for lo in range(0, len(exp), max(1, int(block))):
        sl = slice(lo, lo + max(1, int(block)))
        e_mot = _labels(exp["motion"].iloc[sl])
        bad = _labels(got["motion"].iloc[sl]) != e_mot
        for g, e in pos:
            bad |= np.abs(g[sl] * 1e3 - e[sl]) > 1e-6
        cut = e_mot == "cut"
        bad |= cut & ~np.isclose(g_rpm[sl], e_rpm[sl], rtol=1e-9)
        bad |= cut & ~np.isclose(g_feed[sl], e_feed[sl], rtol=1e-7)
        if np.any(bad):
            return lo + int(np.argmax(bad))
    return None


def _labels(col: pd.Series) -> NDArray[np.object_]:
    """A label column's values as an object array, each distinct label one ``str`` object.

    (``to_numpy()`` of a string column makes an object per row: a million on a
    long program, at the check's peak.)
    """
    codes, names = pd.factorize(col, use_na_sentinel=False)
    return np.asarray(names, dtype=object)[codes]


def _analog_options(edit: ProgramEdit, fmt: str) -> dict[str, Any]:
    """Reader options that read the written analog spindle output back as rpm (KRL, RAPID)."""
    o = edit.options
    if fmt not in ("krl", "rapid") or o.get("analog_output") is None:
        return {}
    return {
        "spindle_output": str(o["analog_output"]),
        "spindle_rpm_per_unit": float(o["analog_rpm_full_scale"]) / float(o["analog_full_scale"]),
    }


def write_program(
    plan: PlanResult | FolderPlan | str | os.PathLike[str],
    path: str | os.PathLike[str],
    *,
    job: str | os.PathLike[str] | Job | None = None,
    fmt: str | None = None,
    passes: ArrayLikeInt | None = None,
    depth_mm: ArrayLikeFloat | None = None,
) -> Path:
    """Write the plan's program (speeds, feeds, passes) into ``path`` atomically.

    Parameters
    ----------
    plan : PlanResult, FolderPlan or path-like
        A plan, or its folder (``robolobe plan -o DIR``; its source program
        must be where the plan read it).
    path : path-like
        The program file; for KRL the ``.dat`` is written beside it (same stem).
    job : path-like or Job, optional
        With a plan folder: its job (default: the job file its summary names).
        The extension follows ``fmt`` (:data:`EXTENSIONS`) when it is missing.
    fmt : str, optional
        Dialect (default: the one read; :data:`TRANSLATIONS`).
    passes, depth_mm : optional
        See :func:`program_edit`.

    Returns
    -------
    Path
        The program written.

    Raises
    ------
    InputError
        See :func:`program_text`; ``path`` an existing directory. Nothing
        is written then, and an earlier file at ``path`` is left as it was.
    """
    p = Path(path)
    if p.is_dir():
        raise InputError(f"expected a program file to write, found {not_a_file(p)}", str(p))
    if not isinstance(plan, PlanResult | FolderPlan):
        plan = read_folder_plan(plan, job)
    edit = program_edit(plan, passes=passes, depth_mm=depth_mm)
    fmt0 = fmt or detect_format(_source_path(plan))
    if not p.suffix:
        p = p.with_suffix(EXTENSIONS[fmt0])
    files = program_text(plan, fmt0, edit=edit, name=p.stem)
    for fname in files:
        target = p.with_name(fname) if fname != p.stem + EXTENSIONS[fmt0] else p
        if target.is_dir():
            raise InputError(
                f"expected a program file to write, found {not_a_file(target)}", str(target)
            )
    for fname, text in files.items():
        target = p.with_name(fname) if fname != p.stem + EXTENSIONS[fmt0] else p
        with atomic_path(target) as tmp:
            Path(tmp).write_text(text, encoding="utf-8")
    return p


def program_changes(res: AnyPlan, edit: ProgramEdit | None = None) -> pd.DataFrame:
    """Where the written program's S or F is set: the blocks the report lists.

    A block is listed where its new S or F differs from the program's own
    (S_old, F_old) and either differs from the block before it (a new value
    is set there) or the program's own value changes there, and where it
    gets passes.

    Returns
    -------
    pandas.DataFrame
        ``source line rpm_old rpm_new feed_old feed_new margin passes``
        (feeds in mm/min), one row per listed block, in program order.
    """
    if edit is None:
        edit = program_edit(res)
    wp = edit.waypoints
    cut = edit.cut
    bid, first = _blocks(wp, cut)
    f_old = wp["feed_mm_per_min"].to_numpy()[first]
    s_old = wp["rpm_programmed"].to_numpy()[first]
    s_new = edit.rpm[first]
    f_new = edit.feed_mm_per_min[first]
    low = pd.Series(edit.margin[cut]).groupby(bid[cut]).min().to_numpy()
    differs = ~np.isclose(s_old, s_new, rtol=0, atol=0.5) | ~np.isclose(f_old, f_new, rtol=1e-9)

    def steps(v: FloatArray) -> NDArray[np.bool_]:
        out = np.ones(len(v), bool)
        out[1:] = ~np.isclose(v[1:], v[:-1], rtol=1e-9, equal_nan=True)
        return out

    new_value = steps(s_new) | steps(f_new) | steps(s_old) | steps(f_old)
    p = edit.passes[first]
    changed = (differs & new_value) | ((p > 1) & steps(p.astype(np.float64)))
    return pd.DataFrame(
        {
            "source": wp["source"].to_numpy()[first],
            "line": wp["line"].to_numpy()[first],
            "rpm_old": s_old,
            "rpm_new": s_new,
            "feed_old": f_old,
            "feed_new": f_new,
            "margin": low,
            "passes": edit.passes[first],
        }
    )[changed].reset_index(drop=True)
