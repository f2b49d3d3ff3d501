"""Constructs common in real programs, on files written here (not seen by the readers' authors).

Each file is generated from a geometry defined in the test, so the expected
path (length, tangency, extents, feed) is known independently of the reader.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from robolobe.errors import InputError
from robolobe.plan.job import job_from_dict, job_to_dict, load_job
from robolobe.plan.paths import read_toolpath, reader_options, segment_lengths
from robolobe.plan.paths.apt import parse_apt
from robolobe.plan.paths.gcode import parse_gcode
from robolobe.plan.paths.krl import parse_krl
from robolobe.plan.paths.rapid import parse_rapid

from .conftest import example


def xyz(df) -> np.ndarray:
    return df[["x_m", "y_m", "z_m"]].to_numpy() * 1e3


def cut_length(df) -> float:
    return float(segment_lengths(xyz(df))[(df["motion"] == "cut").to_numpy()].sum())


def max_turn_deg(df) -> float:
    d = np.diff(xyz(df), axis=0)
    n = np.linalg.norm(d, axis=1)
    u = d[n > 1e-6] / n[n > 1e-6, None]
    return float(np.degrees(np.arccos(np.clip(np.sum(u[1:] * u[:-1], axis=1), -1, 1))).max())


# ---------------------------------------------------------------- NX CLSF pocket
def nx_pocket(ccw: bool, w: float = 60.0, h: float = 40.0, r: float = 5.0, z: float = -2.0) -> str:
    """A rounded-rectangle pass written as NX writes it (axis for a clockwise arc)."""
    corners = [(w - r, r), (w - r, h - r), (r, h - r), (r, r)]  # CCW order, arc centres
    # CCW tour: bottom edge -> corner 0 -> right edge -> corner 1 -> ...
    lines = ["TOOL PATH/POCKET,TOOL,EM10", "$$ centerline data", "MSYS/0,0,0,1,0,0,0,1,0",
             "RAPID", f"GOTO/{r:.4f},0.0000,10.0000,0.0,0.0,1.0", "FEDRAT/MMPM,800.0000",
             f"GOTO/{r:.4f},0.0000,{z:.4f}"]  # fmt: skip
    seq = []
    order = range(4) if ccw else [3, 2, 1, 0]
    start_angles = {0: -90, 1: 0, 2: 90, 3: 180}
    for k in order:
        cx, cy = corners[k]
        a0 = start_angles[k] if ccw else start_angles[k] + 90
        a1 = a0 + 90 if ccw else a0 - 90
        p0 = (cx + r * math.cos(math.radians(a0)), cy + r * math.sin(math.radians(a0)))
        p1 = (cx + r * math.cos(math.radians(a1)), cy + r * math.sin(math.radians(a1)))
        seq.append((p0, p1, (cx, cy)))
    for p0, p1, (cx, cy) in seq:
        lines.append(f"GOTO/{p0[0]:.4f},{p0[1]:.4f},{z:.4f}")
        k = -1.0 if ccw else 1.0  # NX: the axis of a clockwise arc; a CCW arc flips it
        lines.append(f"CIRCLE/{cx:.4f},{cy:.4f},{z:.4f},0.0000000,0.0000000,{k:.7f},{r:.4f},"
                     "0.0600,0.5000,10.0000,0.0000")  # fmt: skip
        lines.append(f"GOTO/{p1[0]:.4f},{p1[1]:.4f},{z:.4f}")
    if not ccw:  # close the ring along the bottom edge
        lines.append(f"GOTO/{r:.4f},0.0000,{z:.4f}")
    lines += ["RAPID", f"GOTO/{r:.4f},0.0000,10.0000", "END-OF-PATH"]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("ccw", [True, False])
def test_nx_pocket_arcs_both_senses(ccw):
    w, h, r = 60.0, 40.0, 5.0
    df = parse_apt(nx_pocket(ccw), "pocket.cls")
    assert df.attrs["warnings"] == []
    ring = 2 * (w - 2 * r) + 2 * (h - 2 * r) + 2 * math.pi * r
    plunge = 12.0
    # chords within 0.01 mm are at most tol/(3 r) shorter than the arcs
    deficit = 2 * math.pi * r * 0.01 / (3 * r)
    assert ring + plunge - deficit - 1e-9 <= cut_length(df) <= ring + plunge + 1e-9
    cut = xyz(df)[(df["motion"] == "cut").to_numpy()]
    assert cut[:, 0].min() == pytest.approx(0.0, abs=1e-9)
    assert cut[:, 0].max() == pytest.approx(w)
    assert cut[:, 1].min() == pytest.approx(0.0, abs=1e-9)
    assert cut[:, 1].max() == pytest.approx(h)
    assert max_turn_deg(df[df["z_m"] < 0].iloc[1:]) < 10  # tangent all the way round
    other = parse_apt(nx_pocket(ccw), "pocket.cls", circle_axis="ccw")
    assert any("circle_axis = 'cw'" in w for w in other.attrs["warnings"])
    assert re.search(r"\((3|4) times\)", " ".join(other.attrs["warnings"]))


def test_nx_times_helix_and_load_tool():
    text = "\n".join([
        "TOOL PATH/HELIX,TOOL,EM10", "LOAD/TOOL,3,ADJUST,3", "UNITS/MM", "RAPID",
        "GOTO/10.0000,0.0000,5.0000,0.0,0.0,1.0", "FEDRAT/MMPM,500",
        # CCW (about +z) helix written NX-style with axis -z: 3 extra turns plus a quarter
        "CIRCLE/0.0000,0.0000,0.0000,0.0000000,0.0000000,-1.0000000,10.0000,0.06,0.5,8,0,TIMES,3",
        "GOTO/0.0000,10.0000,0.0000", "END-OF-PATH",
    ])  # fmt: skip
    df = parse_apt(text, "helix.cls")
    sweep = 3 * 2 * math.pi + math.pi / 2
    exact = math.hypot(10 * sweep, 5.0)
    assert exact * (1 - 0.01 / 30) - 1e-9 <= cut_length(df) <= exact + 1e-9
    p = xyz(df)  # from the start point (the rapid GOTO) on
    ang = np.unwrap(np.arctan2(p[:, 1], p[:, 0]))
    assert np.all(np.diff(p[:, 2]) < 0)
    assert ang[-1] - ang[0] == pytest.approx(sweep, abs=1e-9)


@pytest.mark.parametrize(
    ("head", "feed", "scale", "expected_feed"),
    [
        ("UNITS/MM", "FEDRAT/IPM,10", 1.0, 254.0),
        ("UNITS/MM", "FEDRAT/MMPM,10", 1.0, 10.0),
        ("UNITS/INCHES", "FEDRAT/MMPM,300", 25.4, 300.0),
        ("UNITS/INCHES", "FEDRAT/20,IPM", 25.4, 508.0),
        ("UNITS/INCHES", "FEDRAT/20", 25.4, 508.0),
    ],
)
def test_apt_feed_unit_words(head, feed, scale, expected_feed):
    text = f"{head}\nGOTO/0,0,0\n{feed}\nGOTO/2,0,0\nFINI\n"
    df = parse_apt(text, "f.cls")
    assert df["feed_mm_per_min"].iloc[1] == pytest.approx(expected_feed)
    assert df["x_m"].iloc[1] * 1e3 == pytest.approx(2 * scale)


def test_apt_inch_data_without_units_is_flagged():
    text = "GOTO/0,0,1\nFEDRAT/8\nGOTO/0,0,0\nGOTO/3,2,0\nGOTO/6,0,0\nFINI\n"
    df = parse_apt(text, "small.cls")
    joined = " ".join(df.attrs["warnings"])
    assert "no UNITS record" in joined
    assert "look like inches" in joined
    inch = parse_apt(text, "small.cls", units="inch")
    assert xyz(inch)[-1] == pytest.approx([6 * 25.4, 0, 0])
    assert inch["feed_mm_per_min"].iloc[-1] == pytest.approx(8 * 25.4)
    assert inch.attrs["warnings"] == []


def test_apt_cutcom_needs_centreline_data():
    body = "GOTO/0,0,0\nCUTCOM/LEFT\nGOTO/10,0,0\nFINI\n"
    with pytest.raises(InputError, match=r"c\.cls:3: .*CUTCOM/LEFT.*centre-line"):
        parse_apt("UNITS/MM\n" + body, "c.cls")
    df = parse_apt("$$ centerline data\n" + body, "c.cls", units="mm")
    assert any("CUTCOM/LEFT" in w for w in df.attrs["warnings"])
    assert xyz(df)[-1] == pytest.approx([10, 0, 0])


# ---------------------------------------------------------------- G-code post words
def test_gcode_post_words_names_and_offsets():
    text = "\n".join([
        "%", "OFLOOR_FACING", "(a Haas-style header)", "G20 G90 G17 G187 P2 E0.0005",
        "G103 P4", "G154 P12", "G05.1 Q1 R5",
        "G08 P1", "G05.1 Q1", "G10 L2 P1 X5. Y6. Z7.", "G0 X0 Y0 Z1.", "G1 Z0 F20.",
        "G92 X10. Y0", "G1 X11.", "G92.1", "G1 X2.", "M30", "%",
    ])  # fmt: skip
    df = parse_gcode(text, "post.nc")
    p = xyz(df) / 25.4
    # G10 block moved nothing; G92 X10 at X0 shifts the program origin by -10
    assert p[:, 0].tolist() == pytest.approx([0.0, 0.0, 1.0, 2.0])
    assert df["feed_mm_per_min"].iloc[-1] == pytest.approx(20 * 25.4)
    notes = " ".join(df.attrs["warnings"])
    for word in ("G187", "G103", "G154", "G08", "G10", "G92", "G5.1"):
        assert word in notes, word
    assert "truncated" not in notes


@pytest.mark.parametrize(
    ("text", "what"),
    [
        ("G0 X0 Y0\nG5.1 X5 Y5 I1 J1\n", "quadratic spline G5.1"),
        ("G0 X0 Y0\nG5.2 X5 Y5 P1 L3\n", "NURBS G5.2"),
        ("G0 X0 Y0\nG6.2 X5 Y5 P1\n", "NURBS"),
        ("G0 X0 Y0\nG12.1\n", "polar"),
        ("G92 X0 Y0\n", "G92"),
        ("O100 SUB\n", "O-word"),
        ("G0 X0\nO100 IF [#1 GT 2]\n", "O-word"),
    ],
)
def test_gcode_unsupported_motion_named(text, what):
    with pytest.raises(InputError, match=what):
        parse_gcode(text, "u.nc")


def test_gcode_tcp_rotary_words_and_vectors_agree():
    # one tool orientation given as B/C words under TCPC and as a G43.5 I/J/K vector
    b, c = 30.0, 60.0
    v = (
        math.sin(math.radians(b)) * math.cos(math.radians(c)),
        math.sin(math.radians(b)) * math.sin(math.radians(c)),
        math.cos(math.radians(b)),
    )
    abc = parse_gcode(
        f"G21 G90\nG0 B{b} C{c}\nG234 H1\nG0 X0 Y0 Z5\nG1 Z0 F100\nX10\nG49\nM30\n", "t.nc"
    )
    ijk = parse_gcode(
        f"G21 G90\nG43.5 H1\nG0 X0 Y0 Z5 I{v[0]:.9f} J{v[1]:.9f} K{v[2]:.9f}\nG1 Z0 F100\nX10\n"
        "M30\n",
        "t.nc",
    )
    assert xyz(abc) == pytest.approx(xyz(ijk))
    assert abc[["i", "j", "k"]].to_numpy() == pytest.approx(ijk[["i", "j", "k"]].to_numpy())
    with pytest.raises(InputError, match="rotary_axes"):  # same words without TCP
        parse_gcode(f"G21\nG0 X0 Y0 Z5 B{b} C{c}\nM30\n", "t.nc")


def test_gcode_units_warning():
    df = parse_gcode("G0 X0 Y0\nG1 X0.5 Y0.2 F20\nG1 X1 Y0.4\nM30\n", "u.nc")
    assert any("no G20/G21" in w and "inches" in w for w in df.attrs["warnings"])
    inch = parse_gcode("G0 X0 Y0\nG1 X0.5 Y0.2 F20\nM30\n", "u.nc", units="inch")
    assert xyz(inch)[-1][0] == pytest.approx(12.7)


# ---------------------------------------------------------------- KRL constructs
KRL_HEAD = "DEF t()\n$VEL.CP = 0.1\nPTP $AXIS_ACT\nLIN {X 10, Y 0, Z 0, A 0, B 0, C 180}\n"


def test_krl_circ_ca_spl_with_and_local_routines():
    text = (
        KRL_HEAD
        + "CIRC {X 0, Y 10, Z 0}, {X -10, Y 0, Z 0}, CA 90\n"  # quarter of the circle r 10
        + "SPLINE\nSPL {X 0, Y 5, Z 0}\n"
        + "SLIN {X 0, Y 0, Z 0} WITH $VEL = SVEL_CP(0.05, , LDEFAULT)\n"
        + "ENDSPLINE\nsub1()\nEND\n"
        + "DEF sub1()\nLIN {X 5, Y 5, Z 0}\nEND\n"
        + "GLOBAL DEFFCT BOOL helper()\nIF TRUE THEN\nRETURN(TRUE)\nENDIF\nENDFCT\n"
    )
    df = parse_krl(text, "t.src")
    p = xyz(df)
    arc = df[df["line"] == 5]
    q = xyz(arc)
    assert np.allclose(np.hypot(q[:, 0], q[:, 1]), 10.0, atol=1e-6)
    assert q[-1] == pytest.approx([0.0, 10.0, 0.0], abs=1e-9)  # CA 90 stops at (0, 10)
    assert df["feed_mm_per_min"].iloc[-2] == pytest.approx(3000.0)  # SVEL_CP 0.05 m/s
    assert df["feed_mm_per_min"].iloc[-3] == pytest.approx(6000.0)  # $VEL.CP 0.1
    assert p[-1] == pytest.approx([5.0, 5.0, 0.0])  # sub1's LIN, followed at its call
    assert any("SPL" in w for w in df.attrs["warnings"])
    assert not any("WITH $" in w for w in df.attrs["warnings"])
    # KSS inline form: variable velocity, base and tool from the FDAT
    inline = parse_krl(
        KRL_HEAD + "SLIN {X 20} WITH $VEL = SVEL_CP(gArcVel, , LCPDAT1), $TOOL = STOOL2(FP1), "
        "$BASE = SBASE(FP1.BASE_NO), $APO = SAPO(LCPDAT1) C_SPL\nEND\n",
        "t.src",
    )
    assert np.isnan(inline["feed_mm_per_min"].iloc[-1])
    assert xyz(inline)[-1] == pytest.approx([20.0, 0.0, 0.0])
    notes = " ".join(inline.attrs["warnings"])
    assert "not a number" in notes
    assert "WITH $BASE" not in notes
    neg = parse_krl(KRL_HEAD + "CIRC {X 0, Y 10, Z 0}, {X -10, Y 0, Z 0}, CA -90\nEND\n", "t.src")
    assert xyz(neg)[-1] == pytest.approx([0.0, -10.0, 0.0], abs=1e-9)


def test_krl_if_refused_and_base_applied_in_machine_coordinates():
    with pytest.raises(InputError, match=r"t\.src:5: .*control flow IF"):
        parse_krl(KRL_HEAD + "IF $IN[1] THEN\nENDIF\nEND\n", "t.src")
    base = (
        "DEF t()\n$BASE = {X 100, Y 0, Z 50, A 90, B 0, C 0}\n"
        "LIN {X 10, Y 0, Z 0, A 0, B 0, C 180}\nEND\n"
    )
    wp = parse_krl(base, "t.src")
    mc = parse_krl(base, "t.src", coordinates="machine")
    assert xyz(wp)[0] == pytest.approx([10, 0, 0])
    assert xyz(mc)[0] == pytest.approx([100, 10, 50])
    trunc = parse_krl("DEF t()\nLIN {X 10, Y 0, Z 0, A 0, B 0, C 180}\n", "t.src")
    assert any("truncated" in w for w in trunc.attrs["warnings"])


# ---------------------------------------------------------------- RAPID procedures, wobj
def test_rapid_procedures_followed_in_call_order_and_wobj():
    t = "[[{x},0,0],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
    text = f"""MODULE M
    PERS wobjdata wo := [FALSE, TRUE, "", [[100,0,0],[1,0,0,0]], [[0,0,10],[1,0,0,0]]];
    PROC second()
        MoveL {t.format(x=2)}, v10, fine, tool0 \\WObj:=wo;
    ENDPROC
    PROC main()
        MoveL {t.format(x=1)}, v10, fine, tool0 \\WObj:=wo;
        second;
        first;
        second;
    ENDPROC
    PROC first()
        MoveL {t.format(x=3)}, v10, fine, tool0 \\WObj:=wo;
    ENDPROC
    LOCAL FUNC num twice(num x)
        IF x > 0 THEN
            RETURN 2 * x;
        ENDIF
        RETURN 0;
    ENDFUNC
ENDMODULE
"""
    df = parse_rapid(text, "m.mod")
    assert xyz(df)[:, 0].tolist() == pytest.approx([1, 2, 3, 2])
    mc = parse_rapid(text, "m.mod", coordinates="machine")
    assert xyz(mc)[0] == pytest.approx([101, 0, 10])
    with pytest.raises(InputError, match=r"m\.mod:4: .*control flow IF"):
        parse_rapid("MODULE M\nPROC main()\nIF a THEN\nENDIF\nENDPROC\nENDMODULE\n".replace(
            "MODULE M\n", "MODULE M\n!\n"), "m.mod")  # fmt: skip


# ---------------------------------------------------------------- options: job and CLI
def test_job_path_section(tmp_path):
    base = load_job(example("job_A_pocket.toml"))
    d = job_to_dict(base)
    d["path"] = {"units": "inch", "tool_direction": "x", "rotary_axes": "head", "unit": "mm"}
    with pytest.raises(InputError, match=r"path\.unit; did you mean 'units'"):
        job_from_dict(d, "j.toml")
    del d["path"]["unit"]
    job = job_from_dict(d, "j.toml")
    assert job.path_options == {"units": "inch", "tool_direction": "x", "rotary_axes": "head"}
    assert job_from_dict(job_to_dict(job), "j.toml").path_options == job.path_options
    d["path"] = {"units": "furlong"}
    with pytest.raises(InputError, match=r"^j\.toml: path\.units"):
        job_from_dict(d, "j.toml")
    # each reader takes the options that apply to it
    assert reader_options("gcode", job.path_options) == {"units": "inch", "rotary_axes": "head"}
    assert reader_options("krl", job.path_options) == {"tool_direction": "x"}
    nc = tmp_path / "a.nc"
    nc.write_text("G0 X0 Y0\nG1 X1 F10\nM30\n", encoding="utf-8")
    df = read_toolpath(nc, applicable_only=True, **job.path_options)
    assert xyz(df)[-1][0] == pytest.approx(25.4)


def test_cli_rejects_a_bad_reader_option(tmp_path):
    from robolobe.cli.main import app

    res = CliRunner().invoke(
        app,
        ["plan", str(example("pocket.nc")), "--job", str(example("job_A_pocket.toml")),
         "--units", "furlong", "-o", str(tmp_path / "o")],
    )  # fmt: skip
    assert res.exit_code != 0
    assert isinstance(res.exception, InputError)
    assert "--units" in str(res.exception)
    assert "furlong" in str(res.exception)


def test_reader_warnings_reach_the_plan_summary(tmp_path):
    from robolobe.plan.pipeline import plan_path

    job = load_job(example("job_A_pocket.toml")).replace(model="twin")
    text = example("pocket.nc").read_text(encoding="utf-8").replace("G21", "")
    p = tmp_path / "pocket.nc"
    p.write_text(text, encoding="utf-8")
    res = plan_path(p, job, refine=False)
    assert any("toolpath reader" in n and "no G20/G21" in n for n in res.summary.notes)


def test_changing_origins_are_warned():
    nc = parse_gcode("G21 G54\nG0 X0 Y0\nG1 X5 F100\nG55\nG1 X6\nM30\n", "w.nc")
    assert any("G54 to G55" in w for w in nc.attrs["warnings"])
    one = "MSYS/0,0,0,1,0,0,0,1,0\nGOTO/0,0,0\nGOTO/1,0,0\n"
    two = "MSYS/100,0,0,1,0,0,0,1,0\nGOTO/0,0,0\nFINI\n"
    apt = parse_apt("UNITS/MM\n" + one + two, "m.cls")
    assert any("MSYS changes" in w for w in apt.attrs["warnings"])
    placed = parse_apt("UNITS/MM\n" + one + two, "m.cls", coordinates="machine")
    assert xyz(placed)[-1] == pytest.approx([100.0, 0.0, 0.0])
    assert not any("MSYS" in w for w in placed.attrs["warnings"])


def test_positions_set_at_run_time_are_not_read_stale():
    krl = (
        "DEF t()\nDECL E6POS P1={X 10, Y 0, Z 0, A 0, B 0, C 180}\nLIN P1\n"
        "P1.X = 20\nLIN P1\nP1 = $POS_ACT\nLIN {X 0}\nLIN P1\nEND\n"
    )
    with pytest.raises(InputError, match=r"t\.src:8: .*P1 is set at run time"):
        parse_krl(krl, "t.src")
    ok = parse_krl(krl.replace("LIN P1\nEND", "END"), "t.src")
    assert xyz(ok)[:, 0].tolist() == pytest.approx([10.0, 20.0, 0.0])
    lit = "[[{x},0,0],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
    mod = (
        "MODULE M\nVAR robtarget p := " + lit.format(x=1) + ";\nVAR robtarget q;\n"
        "PROC main()\nMoveL p, v10, fine, tool0;\np := Offs(p, 5, 0, 0);\n"
        "MoveL p, v10, fine, tool0;\n"
        "q := CRobT(\\Tool:=tool0);\nMoveL q, v10, fine, tool0;\nENDPROC\nENDMODULE\n"
    )
    with pytest.raises(InputError, match=r"m\.mod:9: .*q is set at run time"):
        parse_rapid(mod, "m.mod")
    good = parse_rapid(mod.replace("MoveL q, v10, fine, tool0;\n", ""), "m.mod")
    assert xyz(good)[:, 0].tolist() == pytest.approx([1.0, 6.0])


def test_circular_moves_turn_the_tool_along_the_arc():
    krl = (
        "DEF t()\nLIN {X 10, Y 0, Z 0, A 0, B 0, C 180}\n"
        "CIRC {X 0, Y 10, Z 0}, {X -10, Y 0, Z 0, A 0, B 30, C 180}\nEND\n"
    )
    c30 = math.cos(math.radians(15))  # quaternion of 30 deg about y, times 180 about x
    s30 = math.sin(math.radians(15))
    lit = "[[{x},{y},0],[{q}],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]"
    q0 = "0,1,0,0"  # 180 deg about x: tool z down
    q1 = f"0,{c30:.9f},0,{-s30:.9f}"  # then tilted 30 deg about y
    mod = (
        f"MODULE M\nPROC main()\nMoveL {lit.format(x=10, y=0, q=q0)}, v10, fine, tool0;\n"
        f"MoveC {lit.format(x=0, y=10, q=q0)}, {lit.format(x=-10, y=0, q=q1)}, v10, fine, "
        "tool0;\nENDPROC\nENDMODULE\n"
    )
    for df in (parse_krl(krl, "t.src"), parse_rapid(mod, "m.mod")):
        p = xyz(df)
        tilt = np.degrees(np.arccos(np.clip(df["k"].to_numpy(), -1, 1)))
        assert tilt[0] == pytest.approx(0.0, abs=1e-6)
        assert tilt[-1] == pytest.approx(30.0, abs=1e-6)
        mid = int(np.argmax(p[:, 1]))  # the top of the half circle: half the arc length
        assert tilt[mid] == pytest.approx(15.0, abs=1.0)
        assert np.all(np.diff(tilt) >= -1e-9)  # turns steadily
