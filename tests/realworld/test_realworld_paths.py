"""Every toolpath in ../shared/realworld/{apt,gcode,krl,rapid}: read right or refused by name.

The expected values are computed here from the raw numbers of each file by
minimal interpreters written for these tests (exact arc lengths from the
sweep angle, not from any chord polyline), or taken from facts stated in
../shared/realworld/README.md and from comments inside the files (tort.ngc
states every arc's start and end angle). The files are public programs
from other projects; they are read in place, never copied.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.paths import read_toolpath, segment_lengths

RW = Path(__file__).resolve().parents[2].parent / "shared" / "realworld"
pytestmark = pytest.mark.skipif(
    not RW.is_dir(), reason=f"real-world files not found at {RW} (../shared/realworld)"
)


def rw(sub: str, name: str) -> Path:
    p = RW / sub / name
    if not p.is_file():
        pytest.skip(f"{p} not present")
    return p


def cut_length_mm(df) -> float:
    p = df[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    return float(segment_lengths(p)[(df["motion"] == "cut").to_numpy()].sum())


def cut_extent_mm(df) -> np.ndarray:
    p = df[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    cut = (df["motion"] == "cut").to_numpy()
    # a cut's start point is the previous waypoint
    idx = np.unique(np.concatenate([np.flatnonzero(cut), np.flatnonzero(cut) - 1]))
    q = p[idx[idx >= 0]]
    return np.array([q.min(0), q.max(0)])


# ------------------------------------------------------------------ independent arc math
def sweep_rad(start, end, centre, axis, clockwise: bool, full_if_closed: bool = True) -> float:
    """Signed-free sweep [rad] of an arc about ``axis`` from start to end."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    u = np.asarray(start, float) - centre
    w = np.asarray(end, float) - centre
    u -= (u @ axis) * axis
    w -= (w @ axis) * axis
    ang = math.atan2(float(np.cross(u, w) @ axis), float(u @ w))  # CCW angle in (-pi, pi]
    ccw = ang % (2 * math.pi)
    sw = (2 * math.pi - ccw) % (2 * math.pi) if clockwise else ccw
    if sw < 1e-9 and full_if_closed:
        sw = 2 * math.pi
    return sw


def helix_length(start, end, centre, axis, sweep: float) -> float:
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    r = np.asarray(start, float) - centre
    r -= (r @ axis) * axis
    h = float((np.asarray(end, float) - np.asarray(start, float)) @ axis)
    return math.hypot(float(np.linalg.norm(r)) * sweep, h)


def chord_deficit(radius: float, sweep: float, tol: float = 0.01) -> float:
    """Upper bound on how much shorter a chord polyline within ``tol`` is than its arc [mm]."""
    return radius * sweep * (tol / (3 * max(radius, tol))) + 1e-9


# ------------------------------------------------------------------ minimal APT interpreter
def apt_moves(path: Path, scale: float = 1.0):
    """(kind, start, end, extra) of every move, CIRCLE arcs clockwise about i,j,k (NX)."""
    moves = []
    pos = None
    rapid = False
    circle = None
    for raw in path.read_text(encoding="utf-8", errors="replace").splitlines():
        s = raw.strip().upper().replace(" ", "")
        if s == "RAPID":
            rapid = True
        elif s.startswith("CIRCLE/"):
            f = s[7:].split(",")
            times = int(float(f[f.index("TIMES") + 1])) if "TIMES" in f else 0
            v = [float(x) for x in f[:7]]
            circle = (np.array(v[:3]) * scale, np.array(v[3:6]), v[6] * scale, times)
        elif s.startswith("GOTO/"):
            v = [float(x) for x in s[5:].split(",")]
            tgt = np.array(v[:3]) * scale
            if pos is not None:
                if circle is not None and not rapid:
                    moves.append(("arc", pos, tgt, circle))
                else:
                    moves.append(("rapid" if rapid else "line", pos, tgt, None))
            pos, rapid, circle = tgt, False, None
    return moves


def apt_cut_length(moves) -> float:
    total = 0.0
    for kind, a, b, c in moves:
        if kind == "line":
            total += float(np.linalg.norm(b - a))
        elif kind == "arc":
            centre, axis, _r, times = c
            sw = sweep_rad(a, b, centre, axis, clockwise=True) + 2 * math.pi * times
            total += helix_length(a, b, centre, axis, sw)
    return total


def test_nx_circle_is_clockwise_about_its_axis_and_tangent():
    f = rw("apt", "HumMan__1_KONTUR_NAR_40_N2.cls")
    moves = apt_moves(f)
    arcs = [(i, m) for i, m in enumerate(moves) if m[0] == "arc"]
    assert len(arcs) >= 10
    # the data themselves: clockwise arcs start tangent to the incoming line (NX doc)
    cosines = []
    for i, (_, a, _b, (centre, axis, r, _)) in arcs:
        prev = moves[i - 1]
        if prev[0] != "line" or np.linalg.norm(prev[2] - prev[1]) < 1e-3:
            continue
        d_in = (prev[2] - prev[1]) / np.linalg.norm(prev[2] - prev[1])
        radial = a - centre
        t_cw = -np.cross(axis / np.linalg.norm(axis), radial)
        t_cw /= np.linalg.norm(t_cw)
        assert abs(np.linalg.norm(radial[:2]) - r) < 0.01
        cosines.append(float(t_cw @ d_in))
    # most arcs continue their incoming line tangentially, a few start at a corner,
    # none turns back (read counter-clockwise, the tangent ones would reverse)
    assert sum(c > 0.999 for c in cosines) >= 10
    assert min(cosines) > 0.5
    df = read_toolpath(f)
    assert not any("circle_axis" in w for w in df.attrs["warnings"])
    expected = apt_cut_length(moves)
    got = cut_length_mm(df)
    deficit = sum(
        chord_deficit(m[3][2], sweep_rad(m[1], m[2], m[3][0], m[3][1], True)) for _, m in arcs
    )
    assert expected - deficit - 1e-6 <= got <= expected + 1e-6
    # no kink where an arc starts: direction change below 1 deg after tangent lines
    p = df[["x_m", "y_m", "z_m"]].to_numpy()
    d = np.diff(p, axis=0)
    n = np.linalg.norm(d, axis=1)
    ok = n > 1e-7
    u = d[ok] / n[ok, None]
    cosines = np.sum(u[1:] * u[:-1], axis=1)
    assert np.sum(cosines < math.cos(math.radians(100))) == 0  # the CCW read had ~180 deg kinks
    # the other convention, as an option, is flagged on these data
    ccw = read_toolpath(f, circle_axis="ccw")
    assert any("circle_axis = 'cw'" in w for w in ccw.attrs["warnings"])
    assert cut_length_mm(ccw) > 1.5 * got
    # extents: the CL points and the arcs' extreme points bound the cut
    ext = cut_extent_mm(df)
    pts = np.array([m[2] for m in moves if m[0] != "rapid"])
    assert np.all(ext[0] <= pts.min(0) + 1e-6)
    assert np.all(ext[1] >= pts.max(0) - 1e-6)


def test_nx_times_helix_makes_the_extra_turns():
    f = rw("apt", "HumMan__2_KONTUR_VNUT_40_N2.cls")
    moves = apt_moves(f)
    helices = [m for m in moves if m[0] == "arc" and m[3][3] > 0]
    assert len(helices) == 2
    df = read_toolpath(f)
    assert cut_length_mm(df) == pytest.approx(apt_cut_length(moves), rel=2e-3)
    # the first helix: radius 18 about (1287.5, -422), 2 turns + the rest, z 471 -> 466
    line = next(
        n
        for n, t in enumerate(f.read_text().splitlines(), start=1)
        if t.startswith("CIRCLE") and "TIMES" in t
    )
    h = df[df["line"] == line + 1][["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    assert np.allclose(np.hypot(h[:, 0] - 1287.5, h[:, 1] + 422.0), 18.0, atol=0.01)
    assert np.all(np.diff(h[:, 2]) < 0)  # descends all the way
    ang = np.unwrap(np.arctan2(h[:, 1] + 422.0, h[:, 0] - 1287.5))
    a0 = math.atan2(-420.1821 + 422.0, 1269.5920 - 1287.5)
    turned = abs(ang[-1] - a0)
    partial = sweep_rad(
        np.array([1269.592, -420.1821, 0]), np.array([1287.4886, -440.0, 0]),
        np.array([1287.5, -422.0, 0]), [0, 0, -1], clockwise=True,
    )  # fmt: skip
    assert turned == pytest.approx(4 * math.pi + partial, abs=0.01)


def test_nx_face_mill_slot_in_step_downs():
    """NX slotting with a 125 mm face mill: 20 step-downs of 3 mm, FEDRAT/MMPM, no SPINDL."""
    f = rw("apt", "HumMan__3_PAZ_125_N2.cls")
    text = f.read_text().splitlines()
    # the raw file: the Z of every GOTO after the first FEDRAT (the cutting levels)
    first_feed = next(n for n, t in enumerate(text) if t.startswith("FEDRAT/"))
    raw_z = {
        round(float(t.split("/")[1].split(",")[2]), 3)
        for t in text[first_feed:]
        if t.startswith("GOTO/")
    }
    df = read_toolpath(f)
    assert not df.attrs["warnings"]
    z = df["z_m"].to_numpy() * 1e3
    cut = (df["motion"] == "cut").to_numpy()
    level = np.zeros_like(cut)
    level[1:] = np.abs(np.diff(z)) < 1e-9
    levels = sorted({round(v, 3) for v in z[cut & level]})
    # 20 levels 3 mm apart from 465 down to 408, each one present in the raw file
    assert levels == pytest.approx([408.0 + 3.0 * i for i in range(20)])
    assert set(levels) <= raw_z
    # the programmed feed on every cutting move; the file has no spindle record
    assert np.all(df.loc[cut, "feed_mm_per_min"].to_numpy() == 530.0)
    assert df.loc[cut, "rpm_programmed"].isna().all()


def test_nx_nurbs_refused_by_name():
    with pytest.raises(InputError, match=r"HumMan_nurbs\.clsf:13: .*NURBS"):
        read_toolpath(rw("apt", "HumMan_nurbs.clsf"))


def test_nx_load_tool_five_axis():
    f = rw("apt", "HumMan_ust_a.cls")
    df = read_toolpath(f)
    moves = apt_moves(f)
    assert cut_length_mm(df) == pytest.approx(apt_cut_length(moves), rel=1e-9)
    # tool axes as given on the GOTO records (normalised)
    rows = [
        (n, [float(x) for x in t.split("/")[1].split(",")])
        for n, t in enumerate(f.read_text().splitlines(), start=1)
        if t.startswith("GOTO/") and t.count(",") == 5
    ]
    for n, v in rows[:50]:
        a = np.array(v[3:]) / np.linalg.norm(v[3:])
        got = df[df["line"] == n][["i", "j", "k"]].to_numpy()[-1]
        assert got == pytest.approx(a, abs=1e-9)


def test_inch_cl_without_units_and_same_path_as_its_gcode():
    apt = read_toolpath(rw("apt", "userFour_APT_Variable_Axis.cls"))
    assert any("inch" in w for w in apt.attrs["warnings"])
    moves = apt_moves(rw("apt", "userFour_APT_Variable_Axis.cls"), scale=25.4)
    pts = np.array([m[2] for m in moves] + [moves[0][1]])  # every GOTO point
    span = pts.max(0) - pts.min(0)
    assert span[0] == pytest.approx(201.6, abs=0.2)
    assert span[1] == pytest.approx(153.0, abs=0.2)
    p = apt[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    assert (p.max(0) - p.min(0)) == pytest.approx(span, abs=1e-6)
    assert np.nanmax(apt["feed_mm_per_min"]) == pytest.approx(10 * 25.4)  # FEDRAT/IPM,10
    assert cut_length_mm(apt) == pytest.approx(apt_cut_length(moves), rel=1e-9)
    # the same operation posted for a Haas UMC-750 (B/C table under G234 TCPC)
    nc = read_toolpath(rw("gcode", "userFour_PostProcessed_Variable_Axis.nc"))
    assert len(nc) == len(apt)
    pa, pn = (d[["x_m", "y_m", "z_m"]].to_numpy() for d in (apt, nc))
    assert np.allclose(pa, pn, atol=0.0254 * 1e-4 * 1.01)
    aa, an = (d[["i", "j", "k"]].to_numpy() for d in (apt, nc))
    ang = np.degrees(np.arccos(np.clip(np.sum(aa * an, axis=1), -1, 1)))
    assert ang.max() < 0.05  # angles rounded to 0.001 deg in the post


# ------------------------------------------------------------------ minimal G-code interpreter
_W = re.compile(r"([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+))")


def gcode_moves(path: Path):
    """(kind, start, end, arc) for every move of a simple program; arc = (centre, axis, cw, R)."""
    st = {"g": None, "plane": 17, "scale": 1.0}
    pos = np.zeros(3)
    moves = []
    for raw in path.read_text(encoding="utf-8-sig", errors="replace").splitlines():
        s = re.sub(r"\(.*?\)", "", raw.upper()).split(";")[0].strip()
        if not s or s.startswith(("%", "O")):
            continue
        w = _W.findall(s)
        vals = {}
        for k, v in w:
            if k == "G":
                g = float(v)
                if g in (0, 1, 2, 3):
                    st["g"] = int(g)
                elif g in (17, 18, 19):
                    st["plane"] = int(g)
                elif g == 20:
                    st["scale"] = 25.4
                elif g == 21:
                    st["scale"] = 1.0
            else:
                vals[k] = float(v)
        if not any(k in vals for k in "XYZ"):
            continue
        tgt = pos.copy()
        for n, k in enumerate("XYZ"):
            if k in vals:
                tgt[n] = vals[k] * st["scale"]
        if st["g"] in (2, 3):
            axis = {17: [0, 0, 1.0], 18: [0, 1.0, 0], 19: [1.0, 0, 0]}[st["plane"]]
            if "R" in vals:
                arc = (None, np.array(axis), st["g"] == 2, vals["R"] * st["scale"])
            else:
                off = np.array([vals.get(k, 0.0) for k in "IJK"]) * st["scale"]
                arc = (pos + off, np.array(axis), st["g"] == 2, None)
            moves.append(("arc", pos, tgt, arc))
        else:
            moves.append(("rapid" if st["g"] == 0 else "line", pos, tgt, None))
        pos = tgt
    return moves


def gcode_arc_sweep(a, b, arc) -> tuple[float, float]:
    centre, axis, cw, r = arc
    if r is not None:
        d = (b - a) - ((b - a) @ axis) * axis
        chord = float(np.linalg.norm(d))
        half = math.asin(min(1.0, chord / (2 * abs(r))))
        sw = 2 * half if r > 0 else 2 * math.pi - 2 * half
        return sw, abs(r)
    rad = (a - centre) - ((a - centre) @ axis) * axis
    return sweep_rad(a, b, centre, axis, clockwise=cw), float(np.linalg.norm(rad))


def gcode_cut_length(moves) -> tuple[float, float]:
    total, deficit = 0.0, 0.0
    for kind, a, b, arc in moves:
        if kind == "line":
            total += float(np.linalg.norm(b - a))
        elif kind == "arc":
            sw, r = gcode_arc_sweep(a, b, arc)
            centre = arc[0] if arc[0] is not None else a  # helix rise only needs the axis
            total += (
                helix_length(a, b, centre, arc[1], sw)
                if arc[0] is not None
                else math.hypot(r * sw, float((b - a) @ arc[1]))
            )
            deficit += chord_deficit(r, sw)
    return total, deficit


@pytest.mark.parametrize(
    "name",
    [
        "LinuxCNC_tort.ngc",
        "LinuxCNC_arcspiral.ngc",
        "CAMotics_bear.nc",
        "SergeyPopov_HeatSink_mill.tap",
        "MFBryan_simple_mill.gcode",
    ],
)
def test_gcode_length_and_extents_match_an_independent_reading(name):
    f = rw("gcode", name)
    df = read_toolpath(f)
    moves = gcode_moves(f)
    expected, deficit = gcode_cut_length(moves)
    got = cut_length_mm(df)
    assert expected - deficit - 1e-6 * expected <= got <= expected * (1 + 1e-9) + 1e-6
    # every programmed end point of a cut is a waypoint
    ends = np.array([m[2] for m in moves if m[0] != "rapid"])
    p = df[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    ext = cut_extent_mm(df)
    assert np.all(ext[0] <= ends.min(0) + 1e-6)
    assert np.all(ext[1] >= ends.max(0) - 1e-6)
    have = {tuple(v) for v in np.round(p, 3)}
    missing = [e for e in np.round(ends, 3) if tuple(e) not in have]
    assert missing == []


def test_tort_arc_angles_match_the_comments():
    f = rw("gcode", "LinuxCNC_tort.ngc")
    df = read_toolpath(f)
    lines = f.read_text().splitlines()
    checked = 0
    for n, text in enumerate(lines, start=1):
        # the comment angles are unambiguous in G17 (from +X towards +Y); G18/G19 arcs
        # are checked by the independent length above
        m = re.search(r"G(17) G([23]).*?\((\d+) (\d+)\)", text)
        if not m:
            continue
        a0, a1 = math.radians(float(m.group(3))), math.radians(float(m.group(4)))
        cw = m.group(2) == "2"
        sw_comment = ((a0 - a1) if cw else (a1 - a0)) % (2 * math.pi) or 2 * math.pi
        seg = df[df["line"] == n]
        prev = df[df.index < seg.index[0]].iloc[-1]
        plane = {"17": (0, 1, 2), "18": (2, 0, 1), "19": (1, 2, 0)}[m.group(1)]
        pts = np.vstack(
            [
                prev[["x_m", "y_m", "z_m"]].to_numpy(float),
                seg[["x_m", "y_m", "z_m"]].to_numpy(float),
            ]
        )
        # angle travelled by the reader's points about the circle centre (from the raw I/J/K)
        ij = [float(re.search(rf"{k}([-\d.]+)", text).group(1)) for k in "IJ"]
        centre = pts[0] + np.array([ij[0], ij[1], 0.0]) * 1e-3
        ia, ib, _ = plane
        ang = np.unwrap(np.arctan2(pts[:, ib] - centre[ib], pts[:, ia] - centre[ia]))
        # the comments give whole degrees
        assert abs(ang[-1] - ang[0]) == pytest.approx(sw_comment, abs=math.radians(1.01)), n
        checked += 1
    assert checked > 40


def test_rotary_table_indexer_is_not_read_as_a_head_tilt():
    f = rw("gcode", "LinuxCNC_b-index.ngc")
    with pytest.raises(InputError, match=r"LinuxCNC_b-index\.ngc:9: .*rotary_axes"):
        read_toolpath(f)
    with pytest.raises(InputError, match="pivot"):
        read_toolpath(f, rotary_axes="table")
    head = read_toolpath(f, rotary_axes="head")  # the user's explicit choice
    assert head["k"].min() == pytest.approx(0.0, abs=1e-12)  # B90


def test_macro_program_refused_by_name():
    with pytest.raises(InputError, match=r"SafetyDav3_7997A\.NC:4: .*macro"):
        read_toolpath(rw("gcode", "SafetyDav3_7997A.NC"))


def test_bom_is_read():
    df = read_toolpath(rw("gcode", "MFBryan_simple_mill.gcode"))
    assert df["line"].iloc[0] == 8  # line 1 starts with the byte-order mark
    assert not any("truncated" in w for w in df.attrs["warnings"])  # ends with M30


# ------------------------------------------------------------------ robot programs
def test_krl_and_rapid_versions_of_one_program_give_one_tool_axis():
    krl = read_toolpath(rw("krl", "robodk_vscode_Program.src"))
    rapid = read_toolpath(rw("rapid", "robodk_vscode_Program.mod"))
    assert len(krl) == len(rapid) == 4
    assert np.allclose(
        krl[["x_m", "y_m", "z_m"]].to_numpy(), rapid[["x_m", "y_m", "z_m"]].to_numpy(), atol=1e-9
    )
    ak, ar = krl[["i", "j", "k"]].to_numpy(), rapid[["i", "j", "k"]].to_numpy()
    assert np.allclose(ak, ar, atol=1e-6)
    # independent: RAPID quaternion [0, -0.97969618, 0, 0.20048792]; tool z = working direction
    w, x, y, z = 0.0, -0.97969618, 0.0, 0.20048792
    z_tool = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])
    assert ar[0] == pytest.approx(-z_tool / np.linalg.norm(z_tool), abs=1e-6)
    # KRL A 0, B 23.131, C -180: Rz Ry Rx, z column
    b = math.radians(23.131)
    assert ak[0] == pytest.approx([math.sin(b), 0.0, math.cos(b)], abs=1e-5)
    assert any("work objects" in w for w in rapid.attrs["warnings"])  # WObj0 then Frame2


def test_krl_laser_cladding_points_from_the_dat():
    f = rw("krl", "Yassate_testKRC.src")
    df = read_toolpath(f)
    dat = rw("krl", "Yassate_testKRC.dat").read_text()
    pts = {
        m.group(1): [float(m.group(k)) for k in (2, 3, 4)]
        for m in re.finditer(r"DECL E6POS (X\w+)=\{X ([-\d.]+),Y ([-\d.]+),Z ([-\d.]+)", dat)
    }
    src_lines = f.read_text().splitlines()
    for n, text in enumerate(src_lines, start=1):
        m = re.match(r"^\s*LIN (X\w+)", text)
        if m:
            got = df[df["line"] == n][["x_m", "y_m", "z_m"]].to_numpy()[-1] * 1e3
            assert got == pytest.approx(pts[m.group(1)], abs=1e-6)


def test_krl_function_after_main_end_is_not_main_code():
    f = rw("krl", "Yassate_exampleKukaPath.src")
    df = read_toolpath(f)
    end_line = next(
        n for n, t in enumerate(f.read_text().splitlines(), start=1) if t.strip() == "END"
    )
    assert df["line"].max() < end_line
    assert set(df["motion"]) == {"rapid"}  # a PTP-only program: nothing to cut


def test_rapid_movec_arcs_pass_through_their_circle_points():
    f = rw("rapid", "Lrmena2000_Laboratorio_3_ModTotal.mod")
    df = read_toolpath(f)
    text = f.read_text()
    tg = {
        m.group(1).upper(): np.array([float(m.group(k)) for k in (2, 3, 4)])
        for m in re.finditer(r"robtarget (\w+):=\[\[([-\d.]+),([-\d.]+),([-\d.]+)\]", text)
    }
    n_arcs = 0
    for n, t in enumerate(text.splitlines(), start=1):
        m = re.match(r"\s*MoveC (\w+),(\w+),", t)
        if not m:
            continue
        via, end = tg[m.group(1).upper()], tg[m.group(2).upper()]
        seg = df[df["line"] == n][["x_m", "y_m", "z_m"]].to_numpy() * 1e3
        start = (
            df[df.index < df.index[df["line"] == n][0]][["x_m", "y_m", "z_m"]].to_numpy()[-1] * 1e3
        )
        # independent circumcentre of (start, via, end)
        a, b = via - start, end - start
        nrm = np.cross(a, b)
        c = start + (np.cross(nrm, a) * (b @ b) + np.cross(b, nrm) * (a @ a)) / (2 * nrm @ nrm)
        r = np.linalg.norm(start - c)
        assert np.allclose(np.linalg.norm(seg - c, axis=1), r, atol=0.01)
        assert np.min(np.linalg.norm(seg - via, axis=1)) < math.sqrt(8 * 0.01 * r) + 1e-6
        assert seg[-1] == pytest.approx(end)
        n_arcs += 1
    assert n_arcs >= 1


def test_rapid_while_refused_by_name():
    with pytest.raises(InputError, match=r"wsierrad_Lab5_Module1_Tarea2\.mod:36: .*WHILE"):
        read_toolpath(rw("rapid", "wsierrad_Lab5_Module1_Tarea2.mod"))


def test_every_realworld_toolpath_is_read_or_refused_by_name():
    """No traceback and no silent read: each file is covered by a test above."""
    covered = {
        "HumMan__1_KONTUR_NAR_40_N2.cls", "HumMan__2_KONTUR_VNUT_40_N2.cls", "HumMan_nurbs.clsf",
        "HumMan__3_PAZ_125_N2.cls",
        "HumMan_ust_a.cls", "userFour_APT_Variable_Axis.cls", "CAMotics_bear.nc",
        "LinuxCNC_arcspiral.ngc", "LinuxCNC_b-index.ngc", "LinuxCNC_tort.ngc",
        "MFBryan_simple_mill.gcode", "SafetyDav3_7997A.NC", "SergeyPopov_HeatSink_mill.tap",
        "userFour_PostProcessed_Variable_Axis.nc", "Yassate_exampleKukaPath.src",
        "Yassate_exampleKukaPath.dat", "Yassate_testKRC.src", "Yassate_testKRC.dat",
        "robodk_vscode_Program.src", "Lrmena2000_Laboratorio_3_ModTotal.mod",
        "robodk_vscode_Program.mod", "wsierrad_Lab5_Module1_Tarea2.mod",
    }  # fmt: skip
    present = {p.name for sub in ("apt", "gcode", "krl", "rapid") for p in (RW / sub).glob("*")}
    assert present <= covered, f"new real-world files without a test: {present - covered}"
    unnamed = []
    for sub in ("apt", "gcode", "krl", "rapid"):
        for p in sorted((RW / sub).glob("*")):
            try:
                read_toolpath(p)
            except InputError as exc:
                if not (str(exc).startswith(p.name) or p.suffix.lower() == ".dat"):
                    unnamed.append(str(exc))
    assert unnamed == []
