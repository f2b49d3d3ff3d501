"""Engagement per move: the Z-map of robolobe.stock against an exact dense reference.

    python studies/engagement.py                      # bundled + two real CAM programs
    python studies/engagement.py --max-moves 300      # the first 300 cutting moves of each
    python studies/engagement.py --max-moves 1500 --margins --out studies/engagement.json
    python studies/engagement.py --max-moves 1500 --cells 80 --only rustyford   # a finer cell
    python studies/engagement.py --only freegroup,safaraz --merge --out studies/engagement.json

For each program (the bundled pocket, contour, face and slot, and the real
Fusion 360 programs ``freegroup_CamperGaskastenTuer.nc`` (pockets, 2-D
adaptive, 5 mm cutter) and ``rustyford_Tenon_jig.ngc`` (2-D adaptive at four
step-downs, inch) from ``../shared/realworld/cam``, read with the project's
readers) it computes the engagement of every cutting move with
:func:`robolobe.stock.compute_engagement` on the default stock at the default
Z-map cell (tool diameter / 40), and the same engagement with an independent
reference written here:

* no raster at all: a point of the cutting edge is in material when it lies
  inside the stock outline (even-odd rule, exact) and no earlier sweep of the
  tool (the exact stadium of each feed move, with the lowest tip height over
  the part of the move that covers the point) has cleared it down to the
  tool tip;
* the front half of the edge sampled every 0.25 deg and each change refined
  by bisection on that exact test (1e-4 deg), an arc narrower than 1 deg
  dropped (:data:`robolobe.stock.MIN_ARC_DEG`); the axial depth is the
  largest, over the engaged samples and points just inside each arc's refined
  ends, of the material height one cell inside the edge point above the tip
  where there is any (at the edge itself it jumps where the edge runs along an
  earlier, deeper wall), else of the height at the edge point itself. Until
  this session the edge points counted only when no point one cell inside
  stood above the tip anywhere (all or nothing), and production took its
  depth at the 4-deg samples only: both understated safarazfadli line 2170 (a
  full-height wall cut by the outer side of an arc of short chords, the points
  one cell inside cleared by the tool's own trail: production 0.500 mm, this
  reference 8.255, the true 8.255) and production freegroup line 2302 (a ramp
  over a deeper pass, the wall's untouched top only between the arc's refined
  entry and the sample at pi: 0.183 vs 1.433);
* the same definition of a move's engagement as the production (its
  samples every quarter diameter and just after a turn, the workpiece as the
  earlier moves left it, lagged by two cells behind a chain of tiny moves,
  the widest entry/exit of the samples), re-implemented here.

It prints, per program, the moves compared, the largest and 99th-percentile
differences of the entry and exit angles (deg) and of the axial depth (mm),
the moves one calls air and the other not, and the worst move with its
``file:line``; then, for the bundled programs, the moves whose engagement
differs from the job's ``cut.radial_width_mm`` (the immersion every move is
planned at today) by more than 0.05 in a_e/D, with the first lines, and
(``--margins``) the plan's own margins: since issue 26 the planner plans
every move at its own engagement and depth per pass, so its per-move margin
is the margin by its own model (the last session measured, with every move
planned at ``cut.radial_width_mm``: pocket 0.50, contour 0.65, face 0.70
at their own engagement).

Held out (``--no-held-out`` leaves them out): ``Dryless_TopFridge.nc`` and
``safarazfadli-glitch_1001.nc`` from the same folder were never used while the
production's exact test where the Z-map's cells disagree was built; they were
run once it was final (``Dryless`` once its reader was: its arcs have absolute I/J
centres and the program does not say G90.1, a setting of its machine; it is read
with the job key ``[path] arc_centres = "absolute"``, :data:`READER`).
A program with tool changes is taken by its flat end
mill's sections (``safarazfadli``: tool 1, 6.35 mm; its lines are the
original file's); one the project's readers refuse is reported with the reason.
A move called air by one side and cutting by the other errs by the width of
its arc (``air_mismatch_max_arc_deg``). Dryless's one run found the Z-map's
floor of a helix too high (its chords each drop 8.3 um, under the level
tolerance, and skipped their start disc): 202 moves over 2 deg, up to 84 deg,
on level moves over its bores' floors; fixed, the same reference run found 6
(18.8 deg) and 88 air in one only. The 6 are the last move of each contour
level's lead-out ramp (8 um in x-y, 49 um up), which ends at the program's
largest x: its edge runs tangent to the default stock's side and meets, beyond
the disc the level's plunge cleared, a sliver 0.6 deg wide and at most 1.4 um
over the level tolerance (80.3-80.9 deg; checked by sampled tool positions
every 1/10 cell); the reference took its entry, the Z-map's 1-deg search missed
it and took the next arc's (99.1 deg). An arc narrower than
:data:`robolobe.stock.MIN_ARC_DEG` (1 deg) is now none on both sides (the
reference below drops it with its depth): Dryless 0 over 2 deg (max 1.09, an
arc move), 80 air in one only (the holding-tab grazes).

Goal (issue 26): every angle within 2 deg of the reference at the stated cell.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import tempfile
import time
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from robolobe.errors import InputError
from robolobe.plan.job import Job, load_job
from robolobe.plan.paths import read_toolpath
from robolobe.stock import LEVEL_TOL_M, MIN_ARC_DEG, compute_engagement, default_stock

REPO = Path(__file__).resolve().parents[1]
REALWORLD = REPO.parent / "shared" / "realworld" / "cam"
BUNDLED = {
    "pocket.nc": "job_A_pocket.toml",
    "contour.apt": "job_B_contour.toml",
    "face.mod": "job_C_face_steel.toml",
    "slot.src": "job_A_slot_steel.toml",
}
REAL = ("freegroup_CamperGaskastenTuer.nc", "rustyford_Tenon_jig.ngc")
#: Held out: never used while the method was developed; run once it was final. Each
#: is (file, tool): a tool number takes that tool's sections of a program with tool
#: changes (the preamble before the first change prepended), its diameter from the
#: header's tool table; None the whole program.
HELD_OUT: tuple[tuple[str, int | None], ...] = (
    ("Dryless_TopFridge.nc", None),
    ("safarazfadli-glitch_1001.nc", 1),
)
#: Reader options (a job's ``[path]`` keys) of the programs that need them.
READER: dict[str, dict[str, str]] = {"Dryless_TopFridge.nc": {"arc_centres": "absolute"}}
_TOOL_CHANGE = re.compile(r"\bT(\d+)\s*M0?6\b")

LEVEL_TOL = LEVEL_TOL_M  # m: one height, and material thinner than it (in z or x-y) is none
TURN_COS = math.cos(math.radians(5.0))
#: The reference's depth is also taken this far [rad] inside each arc's refined end.
END_INSET = math.radians(1e-3)


# ------------------------------------------------------------ the reference
def _inside(outline: np.ndarray, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Even-odd inside test and distance to the outline's edges."""
    ins = np.zeros(x.shape, bool)
    d2 = np.full(x.shape, np.inf)
    for k in range(len(outline)):
        ax, ay = outline[k]
        bx, by = outline[(k + 1) % len(outline)]
        if (ay > y).any() or (by > y).any():
            cross = (ay > y) != (by > y)
            with np.errstate(divide="ignore", invalid="ignore"):
                xi = ax + (y - ay) * (bx - ax) / (by - ay)
            ins ^= cross & (x < xi)
        ex, ey = bx - ax, by - ay
        t = np.clip(((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey), 0, 1)
        d2 = np.minimum(d2, (x - ax - t * ex) ** 2 + (y - ay - t * ey) ** 2)
    return ins, np.sqrt(d2)


class Reference:
    """Exact edge-point material test against every earlier sweep (no grid)."""

    def __init__(self, stock: Any, radius: float, eps: float, res: float) -> None:
        self.stock = stock
        self.r = radius
        self.eps = eps
        self.res = res
        self._p0: list[np.ndarray] = []
        self._p1: list[np.ndarray] = []
        self.p0 = np.zeros((0, 3))
        self.p1 = np.zeros((0, 3))

    def add(self, a: np.ndarray, b: np.ndarray) -> None:
        self._p0.append(a)
        self._p1.append(b)

    def sync(self) -> None:
        """Make the sweeps added so far visible to the queries."""
        if len(self._p0) != len(self.p0):
            self.p0 = np.array(self._p0)
            self.p1 = np.array(self._p1)

    def tops(self, q: np.ndarray, near: np.ndarray) -> np.ndarray:
        """Material top at points q (k, 2): stock top, lowered by the sweeps that covered them."""
        top = np.full(len(q), self.stock.z_top)
        if not near.size:
            return top
        rr = self.r + self.eps
        a, b = self.p0[near], self.p1[near]  # (m, 3)
        d = b[:, :2] - a[:, :2]
        l2 = np.einsum("ij,ij->i", d, d)
        rel = q[:, None, :] - a[None, :, :2]  # (k, m, 2)
        r2 = np.einsum("kmi,kmi->km", rel, rel)
        bb = np.einsum("kmi,mi->km", rel, d)
        moving = l2 > 0.0
        safe = np.where(moving, l2, 1.0)
        disc = bb * bb - safe * (r2 - rr * rr)
        sq = np.sqrt(np.maximum(disc, 0.0))
        t1 = (bb - sq) / safe
        t2 = (bb + sq) / safe
        cov = np.where(moving, (disc >= 0) & (t2 >= 0) & (t1 <= 1), r2 <= rr * rr)
        za, dz = a[:, 2], b[:, 2] - a[:, 2]
        t1 = np.clip(t1, 0, 1)
        t2 = np.clip(t2, 0, 1)
        lev = np.where(moving, np.minimum(za + t1 * dz, za + t2 * dz), np.minimum(a[:, 2], b[:, 2]))
        return np.minimum(top, np.where(cov, lev, np.inf).min(axis=1))

    def material(self, q: np.ndarray, z: float, near: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ins, dist = _inside(self.stock.outline, q[:, 0], q[:, 1])
        top = self.tops(q, near)
        mat = ins & (dist > self.eps) & (top > z + LEVEL_TOL)
        return mat, top

    def near(self, c: np.ndarray) -> np.ndarray:
        self.sync()
        if not len(self.p0):
            return np.zeros(0, np.int64)
        lo = np.minimum(self.p0[:, :2], self.p1[:, :2]) - 2 * self.r - 2 * self.eps
        hi = np.maximum(self.p0[:, :2], self.p1[:, :2]) + 2 * self.r + 2 * self.eps
        return np.flatnonzero(np.all((c >= lo) & (c <= hi), axis=1))

    def engage(self, c: np.ndarray, z: float, f: np.ndarray) -> tuple[float, float, int, float]:
        near = self.near(c)
        left = np.array([-f[1], f[0]])

        def pts(ph: np.ndarray) -> np.ndarray:
            return c + self.r * (np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left)

        ph = np.linspace(0.0, math.pi, 721)
        mat = self.material(pts(ph), z, near)[0]
        if not mat.any():
            return math.nan, math.nan, 0, 0.0

        def refine(a: float, b: float, a_mat: bool) -> float:
            for _ in range(12):
                m = 0.5 * (a + b)
                if bool(self.material(pts(np.array([m])), z, near)[0][0]) == a_mat:
                    a = m
                else:
                    b = m
            return 0.5 * (a + b)

        # every arc of the samples, both ends refined; one narrower than MIN_ARC_DEG is
        # none (its samples leave the material too: they add no depth)
        edges = np.flatnonzero(np.diff(np.r_[0, mat.astype(np.int8), 0]))
        kept: list[tuple[float, float]] = []
        for k0, k1 in zip(edges[::2], edges[1::2] - 1, strict=True):
            lo = 0.0 if k0 == 0 else refine(ph[k0 - 1], ph[k0], False)
            hi = math.pi if k1 == len(mat) - 1 else refine(ph[k1], ph[k1 + 1], True)
            if hi - lo >= math.radians(MIN_ARC_DEG):
                kept.append((lo, hi))
            else:
                mat[k0 : k1 + 1] = False
        if not kept:
            return math.nan, math.nan, 0, 0.0
        # the depth at the engaged samples and just inside each kept arc's refined ends
        ends = [lo + END_INSET for lo, _ in kept if lo > 0.0]
        ends += [hi - END_INSET for _, hi in kept if hi < math.pi]
        pe = np.array(ends)
        pe = pe[self.material(pts(pe), z, near)[0]] if pe.size else pe
        pd = np.r_[ph[mat], pe]
        u = np.sin(pd)[:, None] * f + np.cos(pd)[:, None] * left
        # per engaged point: the material top one cell inside it where that stands above
        # the tip (at the edge itself the top jumps where the edge runs along the wall of
        # an earlier, deeper cut), else the top at the point itself (a crescent or wall
        # thinner than a cell: the outer side of a turn, a finishing pass at a wall)
        top_in = self.tops(c + (self.r - self.res) * u, near)
        top_edge = self.tops(c + self.r * u, near)
        h = np.where(top_in > z + LEVEL_TOL, top_in, top_edge)
        base = max(z, self.stock.z_bottom)
        depth = float(np.max(h - base, initial=0.0))
        return kept[0][0], kept[-1][1], len(kept), depth


def reference_engagement(
    xyz: np.ndarray,
    cut: np.ndarray,
    diameter: float,
    stock: Any,
    res: float,
    max_moves: int,
    first: int = 0,
) -> dict[str, np.ndarray]:
    """The reference per move (NaN where not compared: plunges, moves before ``first`` or
    past ``max_moves``; the earlier moves still remove their material)."""
    n = len(xyz)
    r = 0.5 * diameter
    lag, step, eps = 2.0 * res, 0.5 * r, max(0.01 * res, LEVEL_TOL)
    ref = Reference(stock, r, eps, res)
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]
    entry = np.full(n, np.nan)
    exit_ = np.full(n, np.nan)
    depth = np.full(n, np.nan)
    arcs = np.zeros(n, np.int64)
    compared = np.zeros(n, bool)
    applied = 0
    last = np.zeros(2)
    done = 0
    for i in range(1, n):
        if not cut[i]:
            last = np.zeros(2)
            continue
        while applied < i and cum[applied] <= cum[i] - lag:
            if applied > 0 and cut[applied]:
                ref.add(xyz[applied - 1], xyz[applied])
            applied += 1
        a, b = xyz[i - 1], xyz[i]
        d = b - a
        lxy = math.hypot(d[0], d[1])
        if lxy <= 1e-3 * res:
            last = np.zeros(2)
            continue
        if done >= max_moves or i < first:
            last = d[:2] / lxy
            continue
        done += 1
        f = d[:2] / lxy
        nseg = max(1, math.ceil(lxy / step))
        ts = [k / nseg for k in range(1, nseg + 1)]
        if float(last @ f) < TURN_COS and lxy > 2 * lag:
            ts.insert(0, lag / lxy)
        last = f
        es, xs, ds, rs = [], [], [], []
        for t in ts:
            e, x, na, dp = ref.engage(a[:2] + t * d[:2], a[2] + t * d[2], f)
            if na:
                es.append(e)
                xs.append(x)
                ds.append(dp)
                rs.append(na)
        compared[i] = True
        if es:
            entry[i], exit_[i], depth[i], arcs[i] = min(es), max(xs), max(ds), max(rs)
        else:
            depth[i] = 0.0
    while applied < n:
        applied += 1
    return {"entry": entry, "exit": exit_, "depth": depth, "arcs": arcs, "compared": compared}


CLASSES = ("line", "arc", "ramp")


def move_classes(xyz: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Per move: ``"ramp"`` (the tip height changes by more than the level tolerance),
    ``"arc"`` (one of the chords of a program line read as several moves) or ``"line"``."""
    n = len(xyz)
    out = np.full(n, "line", dtype="<U4")
    same = np.zeros(n, bool)
    same[1:] |= lines[1:] == lines[:-1]
    same[:-1] |= lines[:-1] == lines[1:]
    out[same] = "arc"
    dz = np.r_[0.0, np.abs(np.diff(xyz[:, 2]))]
    out[dz > LEVEL_TOL] = "ramp"
    return out


# ------------------------------------------------------------------ margins
def true_margins(path: Path, job: Job, imm: np.ndarray, milling: np.ndarray) -> dict[str, Any]:
    """Margin of each cutting move at its own engagement and depth per pass, by the planner.

    Since issue 26 the plan itself is made at each move's own engagement and in
    passes: its per-move margin (``a_lim_mm / cut_depth_mm``) is the margin by
    the planner's own model (``tests/plan/test_converged_plans.py`` checks it
    against an independent ZOA). ``imm`` and ``milling`` (this study's
    engagement) name the moves engaged wider than ``cut.radial_width_mm``.
    """
    from robolobe.plan.pipeline import plan_path

    res = plan_path(path, job)
    tab = res.table
    ci = res.cut_index
    own = tab["margin"].to_numpy()[ci]
    sf = job.plan.safety_factor
    lines = tab["line"].to_numpy()[ci]
    wider = np.isfinite(imm[ci]) & (imm[ci] > job.radial_immersion + 0.05)
    low = np.flatnonzero(own < sf * (1 - 1e-9))
    worst = int(np.nanargmin(own)) if np.isfinite(own).any() else -1
    return {
        "safety_factor": sf,
        "engagement": res.summary.engagement,
        "passes": [
            {k: r[k] for k in ("lines", "passes", "depth_per_pass_mm", "set_by")}
            for r in res.summary.passes
            if r["program_depth_mm"] > 0
        ],
        "moves_wider_than_job": int(wider.sum()),
        "own_min_margin": float(own[worst]) if worst >= 0 else math.nan,
        "own_min_line": int(lines[worst]) if worst >= 0 else 0,
        "moves_below_safety_factor": int(low.size),
        "lines_below_safety_factor": sorted({int(x) for x in lines[low]})[:12],
    }


# ------------------------------------------------------------------ programs
def _diameter_from_header(path: Path) -> float:
    text = path.read_text(errors="replace")[:3000]
    m = re.search(r"D=([0-9.]+)", text)
    if not m:
        raise SystemExit(f"{path.name}: no 'D=' tool diameter in the header")
    d = float(m.group(1))
    inch = re.search(r"\bG20\b", text) is not None
    return d * (25.4e-3 if inch else 1e-3)


def _tool_diameter(text: str, tool: int, inch: bool) -> float:
    m = re.search(rf"\bT{tool}\s+D=([0-9.]+)", text)
    if not m:
        raise SystemExit(f"no 'T{tool} D=' tool diameter in the header")
    return float(m.group(1)) * (25.4e-3 if inch else 1e-3)


def tool_sections(text: str, tool: int) -> tuple[str, np.ndarray]:
    """The program's lines before its first tool change and every section of ``tool``
    (from its tool change to the next one), and the original line number of each."""
    lines = text.splitlines()
    changes = [(k, int(m.group(1))) for k, ln in enumerate(lines) if (m := _TOOL_CHANGE.search(ln))]
    keep = list(range(changes[0][0] if changes else len(lines)))
    for (k, t), nxt in zip(changes, [c[0] for c in changes[1:]] + [len(lines)], strict=True):
        if t == tool:
            keep += range(k, nxt)
    return "\n".join(lines[k] for k in keep) + "\n", np.array(keep) + 1


def programs(tmp: Path, held_out: bool = True) -> list[tuple[str, Path, float, Job | None, bool]]:
    """(name, file, tool diameter [m], the bundled job or None, held out); a tool's
    sections are written to ``tmp`` (with their original line numbers beside them)."""
    ex = resources.files("robolobe.data.examples")
    out: list[tuple[str, Path, float, Job | None, bool]] = []
    for prog, jobname in BUNDLED.items():
        with resources.as_file(ex.joinpath(jobname)) as jp:
            job = load_job(jp)
        with resources.as_file(ex.joinpath(prog)) as pp:
            out.append((prog, Path(pp), job.tool.diameter_m, job, False))
    for name in REAL:
        p = REALWORLD / name
        if p.is_file():
            out.append((name, p, _diameter_from_header(p), None, False))
        else:
            print(f"{name}: not found under {REALWORLD} (skipped)")
    for name, tool in HELD_OUT if held_out else ():
        p = REALWORLD / name
        if not p.is_file():
            print(f"{name}: not found under {REALWORLD} (skipped)")
            continue
        if tool is None:
            out.append((name, p, _diameter_from_header(p), None, True))
            continue
        text = p.read_text(errors="replace")
        inch = re.search(r"\bG20\b", text[:3000]) is not None
        q = tmp / f"{p.stem}_T{tool}{p.suffix}"
        section, origin = tool_sections(text, tool)
        q.write_text(section, encoding="utf-8")
        np.save(q.with_suffix(".lines.npy"), origin)  # its lines in the original file
        out.append((f"{name} [T{tool}]", q, _tool_diameter(text, tool, inch), None, True))
    return out


def study(
    max_moves: int,
    margins: bool,
    cells: float | None = None,
    only: str | None = None,
    held_out: bool = True,
) -> list[dict[str, Any]]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, path, diameter, job, held in programs(Path(tmp), held_out):
            if only and not any(o in name for o in only.split(",")):
                continue
            rows += _program_rows(name, path, diameter, job, held, max_moves, margins, cells)
    return rows


def _program_rows(
    name: str,
    path: Path,
    diameter: float,
    job: Job | None,
    held: bool,
    max_moves: int,
    margins: bool,
    cells: float | None,
) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    immersion = job.radial_immersion if job is not None else None
    try:
        wp = read_toolpath(path, **READER.get(path.name, {}))
    except InputError as exc:
        row_u = {"program": name, "held_out": held, "unreadable": str(exc)}
        print(f"{name}{' (held out)' if held else ''}: not read by robolobe's readers: {exc}")
        return [row_u]
    xyz = wp[["x_m", "y_m", "z_m"]].to_numpy()
    cut = (wp["motion"] == "cut").to_numpy()
    lines = wp["line"].to_numpy()
    origin = path.with_suffix(".lines.npy")
    if origin.is_file():  # a tool's sections: the original file's lines
        lines = np.load(origin)[lines - 1]
    stock = default_stock(xyz, cut, 0.5 * diameter)
    t = time.process_time()
    res_m = diameter / cells if cells else None
    e = compute_engagement(
        xyz, cut, diameter, stock, resolution_m=res_m, axis=wp[["i", "j", "k"]].to_numpy()
    )
    t_prod = time.process_time() - t
    t = time.process_time()
    ref = reference_engagement(xyz, cut, diameter, stock, e.resolution_m, max_moves)
    t_ref = time.process_time() - t
    cmp_ = ref["compared"] & ~e.plunge
    both = cmp_ & e.engaged & (ref["arcs"] > 0)
    air_mismatch = cmp_ & (e.engaged != (ref["arcs"] > 0))
    de = np.degrees(np.abs(e.phi_entry - ref["entry"]))[both]
    dx = np.degrees(np.abs(e.phi_exit - ref["exit"]))[both]
    dd = np.abs(e.depth_m - ref["depth"])[both] * 1e3
    worst = np.maximum(de, dx)
    idx = np.flatnonzero(both)
    kind = move_classes(xyz, lines)
    classes = {}
    for k in CLASSES:
        sel = kind[idx] == k
        classes[k] = {
            "moves": int(sel.sum()),
            "max_err_deg": float(worst[sel].max()) if sel.any() else 0.0,
            "air_mismatch": int((air_mismatch & (kind == k)).sum()),
        }
    top = np.argsort(-worst)[:5]
    row: dict[str, Any] = {
        "program": name,
        "held_out": held,
        "tool_mm": round(diameter * 1e3, 3),
        "cell_mm": round(e.resolution_m * 1e3, 4),
        "moves": int(cut[1:].sum()),
        "compared": int(cmp_.sum()),
        "engaged": int(both.sum()),
        "air_mismatch": int(air_mismatch.sum()),
        "max_entry_err_deg": float(de.max()) if de.size else 0.0,
        "max_exit_err_deg": float(dx.max()) if dx.size else 0.0,
        "p99_angle_err_deg": float(np.percentile(worst, 99)) if worst.size else 0.0,
        "over_2deg": int((worst > 2.0).sum()),
        "max_depth_err_mm": float(dd.max()) if dd.size else 0.0,
        "p99_depth_err_mm": float(np.percentile(dd, 99)) if dd.size else 0.0,
        "worst_depth_line": f"{name}:{int(lines[idx[np.argmax(dd)]])}" if dd.size else "",
        "worst_line": f"{name}:{int(lines[idx[np.argmax(worst)]])}" if worst.size else "",
        "classes": classes,
        "worst_moves": [
            f"{name}:{int(lines[idx[j]])} ({kind[idx[j]]}) {worst[j]:.2f} deg, depth "
            f"{ref['depth'][idx[j]] * 1e3:.3f} mm"
            for j in top
            if worst[j] > 1.0
        ],
        "cpu_s_engagement": round(t_prod, 3),
        "cpu_s_reference": round(t_ref, 1),
    }
    # a move air in one and cutting in the other errs by the width of its arc
    arc_w = np.where(e.engaged, e.phi_exit - e.phi_entry, np.nan_to_num(ref["exit"] - ref["entry"]))
    row["air_mismatch_max_arc_deg"] = (
        float(np.degrees(arc_w[air_mismatch]).max()) if air_mismatch.any() else 0.0
    )
    if air_mismatch.any():
        k = np.flatnonzero(air_mismatch)
        row["air_mismatch_lines"] = [f"{name}:{int(lines[j])}" for j in k[:5]]
    if immersion is not None:
        imm = e.immersion
        wrong = e.engaged & (np.abs(imm - immersion) > 0.05)
        over = e.engaged & (imm > immersion + 0.05)
        row["job_immersion"] = round(immersion, 3)
        row["wrong_immersion_moves"] = int(wrong.sum())
        row["under_planned_moves"] = int(over.sum())
        row["air_moves"] = int(e.air[1:].sum())
        first = np.flatnonzero(over)[:6]
        row["under_planned_lines"] = [
            f"{name}:{int(lines[j])} ae/D {imm[j]:.2f} ({e.milling()[j]})" for j in first
        ]
        if margins and job is not None:
            row["margins"] = true_margins(path, job, imm, e.milling())
    rows.append(row)
    print(_line(row))
    return rows


def _line(r: dict[str, Any]) -> str:
    s = (
        f"{r['program']}: D {r['tool_mm']} mm, cell {r['cell_mm']} mm, {r['compared']} of "
        f"{r['moves']} moves compared ({r['engaged']} cutting in both, {r['air_mismatch']} "
        f"air in one only): max angle error entry {r['max_entry_err_deg']:.3f} / exit "
        f"{r['max_exit_err_deg']:.3f} deg (p99 {r['p99_angle_err_deg']:.3f}, "
        f"{r['over_2deg']} over 2 deg, worst {r['worst_line']}), depth "
        f"{r['max_depth_err_mm']:.4f} mm (at {r['worst_depth_line']}); "
        f"CPU {r['cpu_s_engagement']} s "
        f"(reference {r['cpu_s_reference']} s)"
    )
    if r["held_out"]:
        s = "(held out) " + s
    if r["air_mismatch"]:
        s += f"\n    widest arc of a move air in the other: {r['air_mismatch_max_arc_deg']:.3f} deg"
    if "job_immersion" in r:
        s += (
            f"\n    planned today at a_e/D = {r['job_immersion']} everywhere: "
            f"{r['wrong_immersion_moves']} moves off by > 0.05, {r['under_planned_moves']} "
            f"engaged wider than planned, {r['air_moves']} feed moves in air; first: "
            + "; ".join(r["under_planned_lines"])
        )
    if "margins" in r:
        m = r["margins"]
        s += (
            f"\n    the plan at each move's own engagement ({m['engagement']}): "
            f"{m['moves_wider_than_job']} moves engage wider than cut.radial_width_mm; "
            f"passes {m['passes']}; smallest margin {m['own_min_margin']:.3f} at line "
            f"{m['own_min_line']}; {m['moves_below_safety_factor']} moves below the "
            f"safety factor {m['safety_factor']:g}"
        )
    s += "\n    per class: " + "; ".join(
        f"{k} {c['moves']} moves max {c['max_err_deg']:.2f} deg ({c['air_mismatch']} air in one)"
        for k, c in r["classes"].items()
    )
    if r["worst_moves"]:
        s += "\n    over 1 deg: " + "; ".join(r["worst_moves"])
    if r.get("air_mismatch_lines"):
        s += "\n    air in one only: " + ", ".join(r["air_mismatch_lines"])
    return s


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--max-moves", type=int, default=10**9, help="moves compared per program")
    ap.add_argument("--out", type=Path, help="write the rows as JSON")
    ap.add_argument(
        "--cells",
        help="Z-map cells per tool diameter, one or a comma list for the convergence per move "
        "class (default: robolobe's, 40)",
    )
    ap.add_argument(
        "--only", help="only the programs whose name contains this (a comma list: any of them)"
    )
    ap.add_argument(
        "--merge",
        action="store_true",
        help="with --out: replace only the rows of the programs run in the existing file",
    )
    ap.add_argument("--no-held-out", action="store_true", help="leave out the held-out programs")
    ap.add_argument(
        "--margins", action="store_true", help="bundled programs: margins at their own engagement"
    )
    args = ap.parse_args()
    cells = [float(c) for c in args.cells.split(",")] if args.cells else [None]
    out: dict[str, Any] = {}
    for c in cells:
        rows = study(args.max_moves, args.margins, c, args.only, not args.no_held_out)
        worst = max(
            (
                max(r["max_entry_err_deg"], r["max_exit_err_deg"], r["air_mismatch_max_arc_deg"])
                for r in rows
                if "unreadable" not in r
            ),
            default=0,
        )
        label = f"D/{c:g}" if c else "default"
        print(f"{label}: largest angle error over all programs {worst:.3f} deg (goal: 2 deg)")
        out[label] = rows
    if len(cells) > 1:
        print("convergence, max angle error [deg] per move class:")
        for k, row in enumerate(out[next(iter(out))]):
            if "unreadable" in row:
                continue
            for cls in CLASSES:
                errs = [out[lab][k]["classes"][cls]["max_err_deg"] for lab in out]
                print(
                    f"  {row['program']:36s} {cls:5s} "
                    + "  ".join(f"{lab} {e:6.3f}" for lab, e in zip(out, errs, strict=True))
                )
    if args.out:
        data: Any = out["default"] if list(out) == ["default"] else out
        if args.merge and args.out.is_file() and isinstance(data, list):
            new = {r["program"]: r for r in data}
            old = json.loads(args.out.read_text(encoding="utf-8"))
            data = [new.pop(r["program"], r) for r in old] + list(new.values())
        args.out.write_text(json.dumps(data, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
