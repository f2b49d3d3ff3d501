"""Passes per section in every dialect (issue 29): plan tables made here, programs read back.

A *section* is a maximal run of consecutive cutting moves; the plan gives it
``passes`` (constant along it) and ``depth_mm`` (depth per pass). The
written program must cut the section ``passes`` times, whole, pass ``k``
(0-based) at the programmed depth plus ``(passes - 1 - k) * depth_mm`` along
the tool axis, with rapid links between passes, and carry the plan's S and F
on every move of every pass.

The references are made here from the source program's own moves (read by
robolobe's reader, before any writer ran) and the plan table written for the
test; the writers' own layout (``expected_table``) is not used.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from robolobe.errors import InputError
from robolobe.plan.job import load_job
from robolobe.plan.paths import read_toolpath
from robolobe.plan.paths._edit import ProgramEdit
from robolobe.plan.program import FolderPlan, _Record, write_program

EX = Path(__file__).resolve().parents[2] / "src" / "robolobe" / "data" / "examples"

# three sections in each program: lines 0-40 at Z-1, an arc section at Z-2, a closed
# rectangle at Z-1.5 (same geometry in every dialect, mm)
GCODE = """%
O0001 (THREE SECTIONS)
G21 G90 G94 G17
S10000 M3
G0 X0. Y0. Z5.
G1 Z-1. F600.
X40. F800.
Y10.
G0 Z5.
X60. Y0.
G1 Z-2. F600.
G2 X80. Y20. I20. J0. F900.
G1 X100.
G0 Z5.
X0. Y40.
G1 Z-1.5 F500.
X50. F1000.
Y60.
X0.
Y40.
G0 Z5.
M5
M30
%
"""

APT = """PARTNO THREE SECTIONS
UNITS/MM
SPINDL/10000,RPM,CLW
RAPID
GOTO/0,0,5
FEDRAT/600,MMPM
GOTO/0,0,-1
FEDRAT/800,MMPM
GOTO/40,0,-1
GOTO/40,10,-1
RAPID
GOTO/40,10,5
RAPID
GOTO/60,0,5
FEDRAT/600,MMPM
GOTO/60,0,-2
FEDRAT/900,MMPM
GOTO/80,20,-2
GOTO/100,20,-2
RAPID
GOTO/100,20,5
RAPID
GOTO/0,40,5
FEDRAT/500,MMPM
GOTO/0,40,-1.5
FEDRAT/1000,MMPM
GOTO/50,40,-1.5
GOTO/50,60,-1.5
GOTO/0,60,-1.5
GOTO/0,40,-1.5
RAPID
GOTO/0,40,5
FINI
"""

KRL = """DEF sect( )
$VEL.CP = 0.2
PTP {X 0, Y 0, Z 5, A 0, B 0, C 180}
$VEL.CP = 0.01
LIN {X 0, Y 0, Z -1} C_DIS
$VEL.CP = 0.0133333
LIN {X 40, Y 0, Z -1} C_DIS
LIN {X 40, Y 10, Z -1}
PTP {X 40, Y 10, Z 5}
PTP {X 60, Y 0, Z 5}
LIN {X 60, Y 0, Z -2}
CIRC {X 74.142136, Y 5.857864, Z -2}, {X 80, Y 20, Z -2} C_DIS
LIN {X 100, Y 20, Z -2} WITH $VEL = SVEL_CP(0.015, , LCPDAT1)
PTP {X 100, Y 20, Z 5}
PTP {X 0, Y 40, Z 5}
LIN {X 0, Y 40, Z -1.5}
LIN {X 50, Y 40, Z -1.5}
LIN {X 50, Y 60, Z -1.5}
LIN {X 0, Y 60, Z -1.5}
LIN {X 0, Y 40, Z -1.5}
PTP {X 0, Y 40, Z 5}
END
"""

RAPID = """MODULE Sect
    CONST speeddata vCut:=[10,300,4000,900];
    CONST robtarget p0:=[[0,0,0],[0,1,0,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];
    PROC main()
        MoveJ Offs(p0,0,0,5), v500, fine, tool0;
        MoveL Offs(p0,0,0,-1), v10, z1, tool0;
        MoveL Offs(p0,40,0,-1), vCut, z1, tool0;
        MoveL Offs(p0,40,10,-1), vCut, z1, tool0;
        MoveJ Offs(p0,40,10,5), v500, z10, tool0;
        MoveJ Offs(p0,60,0,5), v500, fine, tool0;
        MoveL Offs(p0,60,0,-2), v10, z1, tool0;
        MoveC Offs(p0,74.142136,5.857864,-2), Offs(p0,80,20,-2), vCut, z1, tool0;
        MoveL Offs(p0,100,20,-2), vCut, z1, tool0;
        MoveJ Offs(p0,100,20,5), v500, z10, tool0;
        MoveJ Offs(p0,0,40,5), v500, fine, tool0;
        MoveL Offs(p0,0,40,-1.5), v10, z1, tool0;
        MoveL Offs(p0,50,40,-1.5), vCut, z1, tool0;
        MoveL Offs(p0,50,60,-1.5), vCut, z1, tool0;
        MoveL Offs(p0,0,60,-1.5), vCut, z1, tool0;
        MoveL Offs(p0,0,40,-1.5), vCut, z1, tool0;
        MoveJ Offs(p0,0,40,5), v500, fine, tool0;
    ENDPROC
ENDMODULE
"""

PROGRAMS = {"gcode": ("s.nc", GCODE), "apt": ("s.apt", APT), "krl": ("s.src", KRL),
            "rapid": ("s.mod", RAPID)}  # fmt: skip
ANALOG = {
    "krl": {"analog_output": "2", "analog_rpm_full_scale": 30000.0},
    "rapid": {"analog_output": "aoSpindle", "analog_rpm_full_scale": 30000.0,
              "analog_full_scale": 10.0},
}  # fmt: skip
READ_S = {
    "krl": {"spindle_output": "2", "spindle_rpm_per_unit": 30000.0},
    "rapid": {"spindle_output": "aoSpindle", "spindle_rpm_per_unit": 3000.0},
}
PASSES = (1, 2, 3)  # per section, in program order
DEPTH = (1.0, 1.0, 0.5)  # depth per pass [mm]


def _sections(cut: np.ndarray) -> list[tuple[int, int]]:
    """Runs of consecutive cutting rows (start, stop), made here for the reference."""
    out, i = [], 0
    while i < len(cut):
        if cut[i]:
            j = i
            while j < len(cut) and cut[j]:
                j += 1
            out.append((i, j))
            i = j
        else:
            i += 1
    return out


def _plan(fmt: str, tmp: Path, rpm_step: float) -> tuple[FolderPlan, pd.DataFrame]:
    """A plan of the program: per-line speeds (stepping along each section), passes per section."""
    name, text = PROGRAMS[fmt]
    src = tmp / name
    src.write_text(text)
    job = load_job(EX / "job_A_pocket.toml")
    job = job.replace(program_options=ANALOG.get(fmt, {}))
    wp = read_toolpath(src)
    n = len(wp)
    cut = (wp["motion"] == "cut").to_numpy()
    secs = _sections(cut)
    assert len(secs) == 3
    line = wp["line"].to_numpy()
    rpm = 12000.0 + rpm_step * (line % 4)
    passes = np.ones(n, np.int64)
    depth = np.full(n, 2.0)
    for (a, b), p, d in zip(secs, PASSES, DEPTH, strict=True):
        passes[a:b] = p
        depth[a:b] = d
    table = pd.DataFrame(
        {
            "line": line,
            "motion": wp["motion"],
            "rpm": np.where(cut, rpm, np.nan),
            "feed_mm_per_min": np.where(cut, 0.05 * 4 * rpm, np.nan),
            "margin": np.where(cut, 1.5, np.nan),
            "dynamics_group": np.where(cut, 0, -1),
            "passes": passes,
            "depth_mm": depth,
        }
    )
    record = _Record({"path_sha256": hashlib.sha256(src.read_bytes()).hexdigest()})
    return FolderPlan(job, str(src), wp, table, record), wp


def _reference(fmt: str, wp: pd.DataFrame, table: pd.DataFrame) -> dict[str, np.ndarray]:
    """Cut moves the written program must hold: each section whole, once per pass."""
    cut = (wp["motion"] == "cut").to_numpy()
    pos = wp[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    s_new = np.round(table["rpm"].to_numpy())
    f_old = wp["feed_mm_per_min"].to_numpy()
    s_old = wp["rpm_programmed"].to_numpy()
    # read without the analog keys, KRL and RAPID have no S: the job's cut.programmed_rpm
    s_old = np.where(np.isfinite(s_old), s_old, 18000.0)
    own = np.isfinite(f_old)
    f_new = np.where(own, f_old * s_new / np.where(own, s_old, 1.0),
                     0.05 * 4 * s_new)  # fmt: skip
    xyz, s, f, sec_of = [], [], [], []
    for n_sec, ((a, b), p, d) in enumerate(zip(_sections(cut), PASSES, DEPTH, strict=True)):
        for k in range(p):
            xyz.append(pos[a:b] + np.array([0.0, 0.0, (p - 1 - k) * d]))
            s.append(s_new[a:b])
            f.append(f_new[a:b])
            sec_of.append(np.full(b - a, n_sec))
    return {"xyz": np.concatenate(xyz), "rpm": np.concatenate(s), "feed": np.concatenate(f),
            "section": np.concatenate(sec_of), "top": pos[:, 2].max()}  # fmt: skip


@pytest.mark.parametrize("fmt", ["gcode", "apt", "krl", "rapid"])
@pytest.mark.parametrize("rpm_step", [0.0, 250.0], ids=["S constant", "S steps"])
def test_sections_are_repeated_whole_per_pass(fmt, rpm_step, tmp_path) -> None:
    plan, wp = _plan(fmt, tmp_path, rpm_step)
    out = write_program(plan, tmp_path / "out" / "prog")
    back = read_toolpath(out, **READ_S.get(fmt, {}))
    ref = _reference(fmt, wp, plan.table)
    bc = (back["motion"] == "cut").to_numpy()
    got = back[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    assert bc.sum() == len(ref["xyz"])
    np.testing.assert_allclose(got[bc], ref["xyz"], atol=1e-6, rtol=0)
    # S exact in G-code and APT; KRL and RAPID write the analog value to 12 decimals
    np.testing.assert_allclose(back["rpm_programmed"].to_numpy()[bc], ref["rpm"], rtol=1e-11)
    np.testing.assert_allclose(back["feed_mm_per_min"].to_numpy()[bc], ref["feed"], rtol=1e-7)
    # a pass is the whole section: the cut rows come back as runs of whole sections
    runs = _sections(bc)
    assert [b - a for a, b in runs] == [
        int((ref["section"] == s).sum() / p) for s, p in enumerate(PASSES) for _ in range(p)
    ]
    # links between passes are rapids, none below the programmed start height (Z5) plus
    # nothing lower than the section's lowest pass start; the retract clears the top by 5 mm
    rapid_z = got[~bc, 2]
    assert rapid_z.max() == pytest.approx(max(ref["top"], 5.0) + 5.0, abs=1e-6)
    assert rapid_z.min() >= 5.0 - 1e-9
    # the rows before and after the passes are the program's own
    np.testing.assert_allclose(got[0], wp[["x_m", "y_m", "z_m"]].to_numpy()[0] * 1e3, atol=1e-9)
    np.testing.assert_allclose(got[-1], wp[["x_m", "y_m", "z_m"]].to_numpy()[-1] * 1e3, atol=1e-9)


def test_passes_must_be_constant_along_a_section(tmp_path) -> None:
    plan, wp = _plan("gcode", tmp_path, 0.0)
    cut = (wp["motion"] == "cut").to_numpy()
    a = _sections(cut)[1][0]
    plan.table.loc[a + 1, "passes"] = 3
    target = tmp_path / "prog.nc"
    target.write_text("previous\n")
    with pytest.raises(InputError, match=r"one pass count .* found \[2, 3\]"):
        write_program(plan, target)
    assert target.read_text() == "previous\n"


def test_krl_passes_with_dat_variables(tmp_path) -> None:
    """The bundled slot (targets from its .dat, a CIRC): three passes, the .dat untouched."""
    import shutil

    for name in ("slot.src", "slot.dat"):
        shutil.copy(EX / name, tmp_path / name)
    src = tmp_path / "slot.src"
    wp = read_toolpath(src)
    job = load_job(EX / "job_A_slot_steel.toml").replace(program_options=ANALOG["krl"])
    cut = (wp["motion"] == "cut").to_numpy()
    n = len(wp)
    table = pd.DataFrame(
        {"line": wp["line"], "rpm": np.where(cut, 11000.0, np.nan),
         "feed_mm_per_min": np.where(cut, 2200.0, np.nan), "margin": np.full(n, np.nan),
         "dynamics_group": np.where(cut, 0, -1), "passes": np.where(cut, 3, 1),
         "depth_mm": np.full(n, 1.0)}
    )  # fmt: skip
    record = _Record({"path_sha256": hashlib.sha256(src.read_bytes()).hexdigest()})
    out = write_program(FolderPlan(job, str(src), wp, table, record), tmp_path / "o" / "slotp")
    dat = (tmp_path / "o" / "slotp.dat").read_text()
    original = (EX / "slot.dat").read_text()
    assert dat.replace("slotp ; ROBOLOBE renamed from slot", "slot") == original
    back = read_toolpath(out, **READ_S["krl"])
    bc = (back["motion"] == "cut").to_numpy()
    p0 = wp[["x_m", "y_m", "z_m"]].to_numpy()[cut] * 1e3
    up = np.array([0.0, 0.0, 1.0])
    want = np.concatenate([p0 + 2 * up, p0 + up, p0])
    np.testing.assert_allclose(back[["x_m", "y_m", "z_m"]].to_numpy()[bc] * 1e3, want, atol=1e-6)
    np.testing.assert_allclose(back["rpm_programmed"].to_numpy()[bc], 11000.0, rtol=1e-11)
    text = out.read_text()
    assert "LIN {X 170, Y 150, Z -1, A 90, B 0, C 180, E1 0" in text  # XP1 as a literal
    assert text.count("; ROBOLOBE link to pass") == 1 + 3 + 3


# the programs above without their ends (a controller rejects each; robolobe reads them)
TRUNCATIONS = {
    "gcode": ("M30\n%\n", "no M30/M2 program end"),
    "apt": ("FINI\n", "no FINI or END-OF-PATH"),
    "krl": ("END\n", "DEF PROG has no END"),  # the DEF as written (named after the file)
    "rapid": ("    ENDPROC\nENDMODULE\n", "PROC MAIN has no ENDPROC"),
}


@pytest.mark.parametrize("fmt", ["gcode", "apt", "krl", "rapid"])
def test_a_truncated_program_is_read_but_not_written_back(fmt, tmp_path, monkeypatch) -> None:
    end, why = TRUNCATIONS[fmt]
    name, text = PROGRAMS[fmt]
    assert text.endswith(end)
    monkeypatch.setitem(PROGRAMS, fmt, (name, text[: -len(end)]))
    plan, wp = _plan(fmt, tmp_path, 0.0)  # read (with a warning) and planned
    assert any("may be truncated" in w for w in wp.attrs["warnings"])
    target = tmp_path / ("prog" + Path(name).suffix)
    target.write_text("previous\n")
    with pytest.raises(InputError, match=f"expected a complete program.*{why}"):
        write_program(plan, target)
    assert target.read_text() == "previous\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, target.name])


# ------------------------------------------------------------------ translations
@pytest.mark.parametrize(("src", "dst"), [("gcode", "apt"), ("apt", "gcode")])
@pytest.mark.parametrize("rpm_step", [0.0, 250.0], ids=["S constant", "S steps"])
def test_gcode_and_apt_translate_into_each_other(src, dst, rpm_step, tmp_path) -> None:
    """The plan's moves, passes and S/F come back from the other dialect as from the source."""
    plan, wp = _plan(src, tmp_path, rpm_step)
    out = write_program(plan, tmp_path / "out" / "prog", fmt=dst)
    assert out.suffix == {"gcode": ".nc", "apt": ".apt"}[dst]
    back = read_toolpath(out)
    ref = _reference(src, wp, plan.table)
    bc = (back["motion"] == "cut").to_numpy()
    got = back[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    np.testing.assert_allclose(got[bc], ref["xyz"], atol=1e-6, rtol=0)
    np.testing.assert_array_equal(back["rpm_programmed"].to_numpy()[bc], ref["rpm"])
    np.testing.assert_allclose(back["feed_mm_per_min"].to_numpy()[bc], ref["feed"], rtol=1e-7)
    assert got[~bc, 2].min() >= 5.0 - 1e-9  # rapids only at or above the programmed clearance
    text = out.read_text()
    assert not back.attrs.get("warnings")  # complete, with its units: nothing to warn about
    assert text.rstrip().endswith({"gcode": "M30\n%", "apt": "FINI"}[dst])
    assert "translated from s." in text.lower()


def test_translated_gcode_read_by_pygcode(tmp_path) -> None:
    """An independent interpreter agrees on the translated program's end points, F and S."""
    pygcode = pytest.importorskip("pygcode")
    plan, _ = _plan("apt", tmp_path, 250.0)
    text = write_program(plan, tmp_path / "prog.nc", fmt="gcode").read_text()
    ours = read_toolpath(tmp_path / "prog.nc")
    m = pygcode.Machine()
    rows = []
    s_now = np.nan
    for raw in text.splitlines():
        if raw.startswith(("%", "(")):
            continue
        line = pygcode.Line(raw)
        for g in line.block.gcodes:
            if g.word_letter == "S":
                s_now = float(g.word.value)
        m.process_block(line.block)
        if any(w.letter in "XYZ" for w in line.block.words):  # a move: its end point
            p = m.pos
            rows.append((p.X, p.Y, p.Z, float(m.mode.feed_rate.word.value), s_now))
    theirs = np.array(rows)
    assert len(theirs) == len(ours)
    np.testing.assert_allclose(theirs[:, :3], ours[["x_m", "y_m", "z_m"]].to_numpy() * 1e3,
                               atol=1e-6)  # fmt: skip
    cut = (ours["motion"] == "cut").to_numpy()
    np.testing.assert_allclose(theirs[cut, 3], ours["feed_mm_per_min"].to_numpy()[cut])
    np.testing.assert_allclose(theirs[cut, 4], ours["rpm_programmed"].to_numpy()[cut])


@pytest.mark.parametrize(
    ("src", "dst", "missing"),
    [
        ("gcode", "krl", "orientation A, B, C"),
        ("apt", "rapid", "robtargets"),
        ("krl", "apt", "TCP path in its base"),
        ("rapid", "gcode", "TCP path in its base"),
        ("krl", "rapid", "robtargets"),
    ],
)
def test_undefined_translations_are_refused(src, dst, missing, tmp_path) -> None:
    plan, _ = _plan(src, tmp_path, 0.0)
    target = tmp_path / "prog.out"
    target.write_text("previous\n")
    with pytest.raises(InputError, match=f"translation from {src} to '{dst}' is not defined: .*"
                       f"{missing}") as e:  # fmt: skip
        write_program(plan, target, fmt=dst)
    assert "\n" not in str(e.value)
    assert target.read_text() == "previous\n"
    assert len(list(tmp_path.iterdir())) == 2


def test_translation_refuses_two_tools_or_directions(tmp_path, monkeypatch) -> None:
    name, text = PROGRAMS["gcode"]
    monkeypatch.setitem(PROGRAMS, "gcode", (name, text.replace("X60. Y0.", "T2 M6\nX60. Y0.")
                                            .replace("S10000 M3", "T1 M6\nS10000 M3")))  # fmt: skip
    plan, _ = _plan("gcode", tmp_path, 0.0)
    with pytest.raises(InputError, match=r"uses tools \['1', '2'\]"):
        write_program(plan, tmp_path / "p.apt", fmt="apt")
    monkeypatch.setitem(PROGRAMS, "gcode", (name, text.replace("X60. Y0.", "M4\nX60. Y0.")))
    plan, _ = _plan("gcode", tmp_path, 0.0)
    with pytest.raises(InputError, match=r"spindle directions \['M3', 'M4'\]"):
        write_program(plan, tmp_path / "p.apt", fmt="apt")
    assert not (tmp_path / "p.apt").exists()


def test_plan_of_a_truncated_program_stands_without_the_program(tmp_path, caplog) -> None:
    """plan -o: the plan is written (its notes say why), the program not; asked for: refused."""
    from robolobe.plan.pipeline import plan_path
    from robolobe.plan.program import IncompleteProgramError
    from robolobe.plan.report import write_outputs

    src = tmp_path / "s.nc"
    src.write_text(GCODE.replace("M30\n%\n", ""))
    res = plan_path(src, load_job(EX / "job_A_pocket.toml"), refine=False)
    out = write_outputs(res, tmp_path / "plan", plots=False, html_report=False)
    assert (out / "summary.json").is_file()
    assert not list(out.glob("program.*"))
    assert any("no program written" in r.getMessage() for r in caplog.records)
    assert any("may be truncated" in n for n in res.summary.to_dict()["notes"])
    with pytest.raises(IncompleteProgramError, match="no M30/M2 program end"):
        write_outputs(res, tmp_path / "plan2", plots=False, html_report=False,
                      program_format="gcode")  # fmt: skip
    assert not (tmp_path / "plan2").exists()


def test_missing_analog_keys_are_refused_by_name(tmp_path) -> None:
    for fmt in ("krl", "rapid"):
        plan, _ = _plan(fmt, tmp_path, 0.0)
        plan = FolderPlan(plan.job.replace(program_options={"analog_output": ANALOG[fmt][
            "analog_output"]}), plan.path, plan.waypoints, plan.table, plan.summary)  # fmt: skip
        target = tmp_path / f"prog{PROGRAMS[fmt][0][1:]}"
        target.write_text("previous\n")
        with pytest.raises(InputError, match="analog_rpm_full_scale") as e:
            write_program(plan, target)
        assert "\n" not in str(e.value)
        assert target.read_text() == "previous\n"


def test_krl_passes_in_a_rotated_base(tmp_path) -> None:
    """coordinates = 'machine': the shift is along the tool axis in the base the targets are in."""
    from robolobe.plan.paths.krl import parse_krl, write_krl
    from robolobe.robots.transforms import pose_from_xyz_zyx

    base = "{X 100, Y 20, Z 5, A 30, B 20, C 10}"
    text = KRL.replace("$VEL.CP = 0.2\n", f"$VEL.CP = 0.2\n$BASE = {base}\n", 1)
    wp = parse_krl(text, "s.src", coordinates="machine")
    cut = (wp["motion"] == "cut").to_numpy()
    n = len(wp)
    edit = ProgramEdit(
        waypoints=wp, rpm=np.where(cut, 10000.0, np.nan),
        feed_mm_per_min=np.where(cut, 600.0, np.nan), margin=np.full(n, np.nan),
        passes=np.where(cut, 2, 1), depth_mm=np.full(n, 2.0),
        options={"analog_output": "2", "analog_rpm_full_scale": 30000.0},
    )  # fmt: skip
    src, _ = write_krl(text, "s.src", edit, name="p", options={"coordinates": "machine"})
    back = parse_krl(src, "p.src", coordinates="machine")
    # reference: the programmed (base) points, 1 mm up the base's Z for the first pass
    t = pose_from_xyz_zyx(np.array([100.0, 20.0, 5.0]), np.radians([30.0, 20.0, 10.0]))
    up = t[:3, :3] @ np.array([0.0, 0.0, 1.0])  # the tool axis (C 180: tool z down)
    p0 = wp[["x_m", "y_m", "z_m"]].to_numpy() * 1e3
    bc = (back["motion"] == "cut").to_numpy()
    want = []
    for a, b in _sections(cut):
        want += [p0[a:b] + up, p0[a:b]]
    np.testing.assert_allclose(back[["x_m", "y_m", "z_m"]].to_numpy()[bc] * 1e3,
                               np.concatenate(want), atol=1e-6)  # fmt: skip
    assert "LIN {X 40, Y 0, Z 0, A 0, B 0, C 180}" in src  # written in the base: Z -1 + 1


def test_rapid_passes_through_a_work_object_read_as_machine_are_refused() -> None:
    from robolobe.plan.paths.rapid import parse_rapid, write_rapid

    text = RAPID.replace("tool0;", "tool0\\WObj:=wobjT;").replace(
        "    PROC main",
        '    PERS wobjdata wobjT:=[FALSE,TRUE,"",[[100,0,0],[1,0,0,0]],[[0,0,0],[1,0,0,0]]];\n'
        "    PROC main",
    )
    wp = parse_rapid(text, "s.mod", coordinates="machine")
    cut = (wp["motion"] == "cut").to_numpy()
    n = len(wp)
    edit = ProgramEdit(
        waypoints=wp, rpm=np.where(cut, 9000.0, np.nan),
        feed_mm_per_min=np.where(cut, 600.0, np.nan), margin=np.full(n, np.nan),
        passes=np.where(cut, 2, 1), depth_mm=np.full(n, 1.0), options=ANALOG["rapid"],
    )  # fmt: skip
    with pytest.raises(InputError, match="Offs shifts in the work object's frame"):
        write_rapid(text, "s.mod", edit, coordinates="machine")
    assert "Offs(Offs(p0,40,0,-1),0,0,0.5)" in write_rapid(text, "s.mod", edit)
