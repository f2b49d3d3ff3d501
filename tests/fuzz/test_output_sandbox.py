"""No command, option or input name writes, replaces or removes anything outside its output folder.

Issue 24: ``robolobe compare ... --robots "...toml" -o cmp`` used to remove the
folder it was run in (the robot file's stem ``..`` became the output folder
``cmp/..``, and the step that replaces an output set removed it). Each test
here runs a writer in a sandbox folder that holds sentinel files and folders
outside the output folder (its parent, siblings, the inputs) and, where it
says so, symbolic links inside the output folder that point out of it; the
sandbox is hashed before and after (links by their target text, never
followed): every entry that existed before is byte-for-byte the same, and
nothing new appears outside the output folder.

Hostile names come from hypothesis (:data:`hostile`) for the fast writers
and from a fixed list (:data:`HOSTILE`) for the heavy commands (compare,
batch, identify, diagnose), most of those marked slow.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from robolobe._atomic import (
    MANIFEST,
    MAX_NAME_BYTES,
    atomic_dir,
    check_inside,
    safe_name,
    unique_names,
)
from robolobe.cli.main import main
from robolobe.errors import InputError

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))
ROBOT_A = EX.parent / "robots" / "A.toml"

FEW = settings(
    max_examples=6,
    deadline=None,
    derandomize=True,
    phases=(Phase.explicit, Phase.reuse, Phase.generate),  # no slow shrinking of CLI runs
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

#: Names that have broken or could break an output path (issue 24 and its class).
HOSTILE: tuple[str, ...] = (
    ".",
    "..",
    "...",
    "....",
    "../..",
    "a/../../b",
    "a\\..\\..\\b",
    "x\x00y",
    "new\nline",
    "\x1b[31mred\x1b[0m",
    "\x1b]0;title\x07t",
    "\u202egnp.exe",
    "con",
    " . ",
    "é" * 200,
    "n" * 300,
    "report.html",
    "compare.csv",
    "batch.csv",
    "summary.json",
    MANIFEST,
)

#: Hostile names: the fixed list, and text from characters that matter in paths.
hostile = st.sampled_from(HOSTILE) | st.text(
    alphabet=st.sampled_from(["a", ".", "/", "\\", "\x00", "\n", "\x1b", "[", " ", "é", ":"]),
    min_size=0,
    max_size=20,
)


# ---------------------------------------------------------------------------
# The sandbox


def _snapshot(root: Path) -> dict[str, tuple[str, str]]:
    """Every entry below ``root``: kind and content hash (links: their target, not followed)."""
    out: dict[str, tuple[str, str]] = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                out[rel] = ("dir", "")
            else:
                out[rel] = ("file", hashlib.sha256(p.read_bytes()).hexdigest())
    return out


class Sandbox:
    """A folder with sentinels around a work folder ``w`` (the commands' working folder).

    ``sandbox/``: ``sentinel.txt``, ``sibling/keep.txt``, ``w/`` (holding
    ``notes/important.txt`` and the inputs), and the output folder the test
    names (usually ``w/out``).
    """

    def __init__(self, root: Path) -> None:
        self.root = root
        self.w = root / "w"
        (root / "sibling").mkdir(parents=True)
        (root / "sibling" / "keep.txt").write_text("sibling sentinel")
        (root / "sentinel.txt").write_text("parent sentinel")
        (self.w / "notes").mkdir(parents=True)
        (self.w / "notes" / "important.txt").write_text("do not touch")
        self.before: dict[str, tuple[str, str]] = {}
        self.owned_before: set[str] = set()

    def links_out(self, out: Path) -> None:
        """Symbolic links inside ``out`` that point out of it, at names robolobe writes."""
        out.mkdir(parents=True, exist_ok=True)
        for name in ("report.html", "summary.json", "compare.json", "batch.csv", "verify.json"):
            (out / name).symlink_to(self.root / "sentinel.txt")
        for name in ("plots", "A", "robot", "path", "frf"):
            (out / name).symlink_to(self.root / "sibling", target_is_directory=True)

    def freeze(self) -> None:
        self.before = _snapshot(self.root)
        self.owned_before = self._owned()

    def _owned(self) -> set[str]:
        """Entries robolobe's manifests in the sandbox list as its own (it may replace them)."""
        owned: set[str] = set()
        for m in self.root.rglob(MANIFEST):
            if m.is_symlink() or not m.is_file():
                continue
            try:
                sets = json.loads(m.read_text())["sets"].values()
            except (ValueError, KeyError, AttributeError):
                continue
            folder = str(m.parent.relative_to(self.root))
            owned.add(str(m.relative_to(self.root)))
            for entry in sets:
                for rel in (*entry.get("files", []), *entry.get("folders", [])):
                    owned.add(os.path.normpath(os.path.join(folder, rel)))
        return owned

    def check(self, *outs: Path, named: tuple[Path, ...] = ()) -> None:
        """Every earlier entry is unchanged; new entries lie only inside ``outs``.

        Inside ``outs``, entries robolobe's manifest listed before (or lists
        now) may change: those are its own outputs, replaced by a re-run; so
        may the output files the command line ``named``.
        """
        after = _snapshot(self.root)
        roots = [str(o.relative_to(self.root)) for o in outs]
        owned = {
            k
            for k in self.owned_before | self._owned()
            if any(k.startswith(r + os.sep) for r in roots)
        } | {str(n.relative_to(self.root)) for n in named}
        changed = {
            k: (v, after.get(k))
            for k, v in self.before.items()
            if after.get(k) != v and k not in owned
        }
        assert not changed, f"changed or removed: {changed}"
        roots = [str(o.relative_to(self.root)) for o in outs]
        new = [k for k in after if k not in self.before]
        stray = [k for k in new if not any(k == r or k.startswith(r + os.sep) for r in roots)]
        assert not stray, f"written outside the output folder: {stray}"


@pytest.fixture
def box(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Sandbox:
    sb = Sandbox(tmp_path / "sandbox")
    monkeypatch.chdir(sb.w)
    return sb


def _cli(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return int(info.value.code or 0), err


def _one_line_refusal(code: int, err: str) -> None:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith("error: "), err


def _fresh(sb_root: Path) -> None:
    if sb_root.exists():
        shutil.rmtree(sb_root)


# ---------------------------------------------------------------------------
# The one place: names, inside-checks, atomic_dir


@settings(max_examples=300, deadline=None, derandomize=True)
@given(raw=hostile | st.text(max_size=300))
def test_safe_name_is_one_plain_component(raw: str) -> None:
    n = safe_name(raw, "fallback")
    assert n not in ("", ".", "..")
    assert Path(n).name == n
    assert "/" not in n
    assert "\\" not in n
    assert not n.startswith(".")
    assert all(c.isprintable() for c in n), repr(n)
    assert len(n.encode("utf-8")) <= MAX_NAME_BYTES
    assert safe_name(n, "fallback") == n  # a safe name stays as it is


def test_safe_name_examples() -> None:
    # written for the test: what each hostile stem becomes
    assert safe_name("..", "robot") == "robot"
    assert safe_name("...", "robot") == "robot"
    assert safe_name("a/../../b") == "a_.._.._b"
    assert safe_name("\x1b[31mred\x1b[0m") == "red"
    assert safe_name("x\x00y") == "xy"
    assert safe_name("con") == "_con"
    assert safe_name("r1") == "r1"
    long1, long2 = safe_name("n" * 300), safe_name("n" * 301)
    assert long1 != long2
    assert len(long1.encode()) == MAX_NAME_BYTES


@FEW
@given(raws=st.lists(hostile, min_size=1, max_size=8))
def test_unique_names_are_distinct_and_noted(raws: list[str]) -> None:
    got = unique_names(raws, what="robot", fallback="robot", taken=("compare.csv",))
    assert len(got.names) == len(raws)
    folded = [n.casefold() for n in got.names]
    assert len(set(folded)) == len(folded)
    assert "compare.csv" not in folded
    assert all(safe_name(n, "robot") == n for n in got.names)
    changed = sum(n != r for n, r in zip(got.names, raws, strict=True))
    assert len(got.notes) == changed
    assert all("\x1b" not in note and "\n" not in note for note in got.notes)


def test_check_inside_refuses_dotdot_and_links_out(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "link").symlink_to(tmp_path, target_is_directory=True)
    assert check_inside(out, out / "a" / "b.csv") == (out / "a" / "b.csv").resolve()
    for bad in (out, out / "..", out / "a" / ".." / "..", out / "link" / "x", tmp_path / "y"):
        with pytest.raises(InputError, match="is not inside the output folder"):
            check_inside(out, bad)


@FEW
@given(name=hostile)
def test_atomic_dir_refuses_unsafe_names_and_touches_nothing(tmp_path: Path, name: str) -> None:
    _fresh(tmp_path / "sandbox")
    sb = Sandbox(tmp_path / "sandbox")
    out = sb.w / "out"
    sb.freeze()
    try:
        with atomic_dir(out, "test") as tmp:
            (tmp / "ok.txt").write_text("x")
            target = tmp / name
            if "\x00" in name or safe_name(name, "x") != name:
                raise InputError("unsafe")  # a writer must make the name safe first
            target.write_text("y")
    except (InputError, OSError, ValueError):
        assert not out.exists()  # nothing written, the new folder removed again
    sb.check(out)


def test_rerun_removes_only_recorded_files(tmp_path: Path) -> None:
    sb = Sandbox(tmp_path / "sandbox")
    out = sb.w / "out"
    with atomic_dir(out, "plan") as tmp:
        (tmp / "plots").mkdir()
        (tmp / "plots" / "a.png").write_bytes(b"a")
        (tmp / "summary.json").write_text("1")
        (tmp / "report.html").write_text("r")
    (out / "plots" / "mine.png").write_bytes(b"mine")  # the user's, in robolobe's folder
    (out / "notes.txt").write_text("mine")
    with atomic_dir(out, "verify") as tmp:  # another kind in the same folder
        (tmp / "verify.json").write_text("v")
    sb.freeze()
    with atomic_dir(out, "plan") as tmp:
        (tmp / "summary.json").write_text("2")
    names = sorted(p.name for p in out.iterdir())
    assert names == [MANIFEST, "notes.txt", "plots", "summary.json", "verify.json"]
    assert sorted(p.name for p in (out / "plots").iterdir()) == ["mine.png"]
    manifest = json.loads((out / MANIFEST).read_text())
    assert manifest["sets"]["plan"] == {"files": ["summary.json"], "folders": []}
    assert manifest["sets"]["verify"]["files"] == ["verify.json"]


def test_forged_manifest_cannot_remove_anything_outside(tmp_path: Path) -> None:
    sb = Sandbox(tmp_path / "sandbox")
    out = sb.w / "out"
    out.mkdir()
    (out / "plots").symlink_to(sb.root / "sibling", target_is_directory=True)
    forged = {
        "written_by": "robolobe",
        "sets": {
            "plan": {
                "files": ["../notes/important.txt", "/etc/passwd", "plots/keep.txt", "..", "."],
                "folders": ["..", "../notes", "plots", "../../sibling"],
            }
        },
    }
    (out / MANIFEST).write_text(json.dumps(forged))
    sb.freeze()
    with atomic_dir(out, "plan") as tmp:
        (tmp / "summary.json").write_text("1")
    sb.check(out)
    assert (out / "plots").is_symlink()


def _write_set(out: Path, files: dict[str, str]) -> None:
    with atomic_dir(out, "plan") as tmp:
        for name, text in files.items():
            (tmp / name).write_text(text)


def test_a_foreign_file_is_refused_not_replaced(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.html").write_text("the user's report")
    with pytest.raises(InputError, match=r"already holds report\.html, which robolobe did not"):
        _write_set(out, {"report.html": "ours", "summary.json": "1"})
    assert sorted(p.name for p in out.iterdir()) == ["report.html"]
    assert (out / "report.html").read_text() == "the user's report"


def test_a_broken_manifest_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / MANIFEST).write_text("{not json")
    with pytest.raises(InputError, match="expected the list of files robolobe wrote"):
        _write_set(out, {"summary.json": "1"})
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST]


def test_an_output_folder_that_is_a_link_is_followed_and_nothing_else_touched(
    tmp_path: Path,
) -> None:
    sb = Sandbox(tmp_path / "sandbox")
    real = sb.root / "real_out"
    real.mkdir()
    (sb.w / "out").symlink_to(real, target_is_directory=True)
    sb.freeze()
    for _ in range(2):
        with atomic_dir(sb.w / "out", "plan") as tmp:
            (tmp / "summary.json").write_text("1")
    sb.check(real)
    assert (real / "summary.json").read_text() == "1"


# ---------------------------------------------------------------------------
# Every command that writes


def _plan_argv(out: str) -> list[str]:
    return ["plan", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"), "-o", out,
            "--no-refine", "--no-plots", "--no-html"]  # fmt: skip


def test_plan_into_a_folder_with_links_out_is_refused(
    box: Sandbox, capsys: pytest.CaptureFixture[str]
) -> None:
    out = box.w / "out"
    box.links_out(out)
    box.freeze()
    code, err = _cli(_plan_argv("out"), capsys)
    _one_line_refusal(code, err)
    assert "symbolic link" in err or "robolobe did not write" in err
    box.check(out)


def test_plan_twice_and_an_old_folder(box: Sandbox, capsys: pytest.CaptureFixture[str]) -> None:
    box.freeze()
    for _ in range(2):  # the README flow: the same -o again replaces the plan
        code, err = _cli(_plan_argv("out"), capsys)
        assert code == 0, err
    box.check(box.w / "out")
    # a folder written before the manifest existed: a clear refusal, nothing touched
    (box.w / "out" / MANIFEST).unlink()
    box.freeze()
    code, err = _cli(_plan_argv("out"), capsys)
    _one_line_refusal(code, err)
    assert "robolobe did not write" in err
    assert "move them away, or choose another folder" in err
    box.check(box.w / "out")


def test_plan_into_the_input_folder_keeps_the_inputs(
    box: Sandbox, capsys: pytest.CaptureFixture[str]
) -> None:
    for name in ("pocket.nc", "job_A_pocket.toml"):
        shutil.copy(EX / name, box.w / name)
    box.freeze()
    code, err = _cli(
        ["plan", "pocket.nc", "--job", "job_A_pocket.toml", "-o", ".", "--no-refine",
         "--no-plots", "--no-html"], capsys,
    )  # fmt: skip
    assert code == 0, err
    box.check(box.w)  # every file that was there (the inputs) is unchanged


@pytest.mark.parametrize(
    "stem",
    [
        "..",  # the case of issue 24
        "...",
        pytest.param("a\\..\\..", marks=pytest.mark.slow),
        pytest.param("\x1b[2Jx", marks=pytest.mark.slow),
        pytest.param("n" * 300, marks=pytest.mark.slow),
        pytest.param("compare", marks=pytest.mark.slow),
    ],
)
def test_compare_hostile_robot_file_names(
    box: Sandbox, capsys: pytest.CaptureFixture[str], stem: str
) -> None:
    """The case of issue 24 (``...toml`` -> ``..``) and its class."""
    name = stem[:240] + ".toml"
    shutil.copy(ROBOT_A, box.w / name)
    box.freeze()
    code, err = _cli(
        ["compare", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"),
         "--robots", name, "-o", "cmp", "--no-refine"], capsys,
    )  # fmt: skip
    assert code == 0, err
    box.check(box.w / "cmp")
    records = json.loads((box.w / "cmp" / "compare.json").read_text())
    folder = records[0]["folder"]
    assert folder == safe_name(Path(name).stem, "robot")
    assert (box.w / "cmp" / folder / "summary.json").is_file()
    if folder != Path(name).stem:
        assert "note: robot" in err  # the renamed folder is said


@pytest.mark.slow
@pytest.mark.parametrize("per_path", [True, False])
@pytest.mark.parametrize("stem", ["..", "...", ".", "batch", "a b"])
def test_batch_hostile_toolpath_names(
    box: Sandbox, capsys: pytest.CaptureFixture[str], stem: str, per_path: bool
) -> None:
    shutil.copy(EX / "pocket.nc", box.w / f"{stem}.nc")
    (box.w / "sub").mkdir()
    shutil.copy(EX / "pocket.nc", box.w / "sub" / f"{stem}.nc")  # the same stem twice
    box.freeze()
    argv = ["batch", f"{stem}.nc", f"sub/{stem}.nc", "--job", str(EX / "job_A_pocket.toml"),
            "-o", "b", "--no-refine", "--workers", "1", "--format", "csv"]  # fmt: skip
    code, err = _cli([*argv, "--per-path" if per_path else "--table-only"], capsys)
    assert code == 0, err
    box.check(box.w / "b")
    import pandas as pd

    t = pd.read_csv(box.w / "b" / "batch.csv", keep_default_na=False)
    if per_path:
        folders = sorted(t["output_folder"])
        assert len(set(folders)) == 2
        assert all((box.w / "b" / f / "summary.json").is_file() for f in folders)
    else:
        assert sorted(p.name for p in (box.w / "b").iterdir()) == [MANIFEST, "batch.csv"]


def test_batch_per_path_dotdot_fast(box: Sandbox, capsys: pytest.CaptureFixture[str]) -> None:
    """``..nc`` with --per-path used to write into the parent of -o."""
    shutil.copy(EX / "pocket.nc", box.w / "..nc")
    box.freeze()
    code, err = _cli(
        ["batch", "..nc", "--job", str(EX / "job_A_pocket.toml"), "-o", "b", "--no-refine",
         "--workers", "1", "--format", "csv", "--per-path"], capsys,
    )  # fmt: skip
    assert code == 0, err
    box.check(box.w / "b")
    assert (box.w / "b" / "path" / "summary.json").is_file()
    assert "note: toolpath '..nc': outputs in 'path'" in err


@pytest.mark.slow
def test_simulate_and_its_rerun(box: Sandbox, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["simulate", "A", "-o", "camp", "--design", "random", "--n", "2"]
    box.freeze()
    for _ in range(2):
        code, err = _cli(argv, capsys)
        assert code == 0, err
    code, err = _cli([*argv, "--format", "uff"], capsys)  # the other format replaces the set
    assert code == 0, err
    box.check(box.w / "camp")
    assert not (box.w / "camp" / "frf.csv").exists()
    box.links_out(box.w / "camp2")
    box.freeze()
    code, err = _cli(["simulate", "A", "-o", "camp2", "--design", "random", "--n", "2",
                      "--format", "uff"], capsys)  # fmt: skip
    _one_line_refusal(code, err)
    box.check(box.w / "camp2")


@pytest.fixture(scope="module")
def hostile_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Robot B, 4 seed postures with hostile ids, exact twin receptance, 0-40 Hz."""
    from robolobe.campaign import Campaign, write_campaign
    from robolobe.robots import load_robot
    from robolobe.twin.designs import design_arrays, load_seed_design
    from robolobe.twin.model import Twin

    _, q, _ = design_arrays(load_seed_design("B"))
    q = q[:4]
    f = np.arange(0, 161) * 0.25
    H = Twin(load_robot("B")).receptance(q, f, method="modal")
    ids = ("..", "../../sentinel", "\x1b[31mred\nz", "p" * 300)
    camp = Campaign.from_arrays("B", ids, q, f, H, dirs=("xx", "yy", "zz"))
    return write_campaign(tmp_path_factory.mktemp("camp") / "B", camp)


@pytest.mark.slow
def test_identify_plots_with_hostile_posture_ids(
    box: Sandbox, capsys: pytest.CaptureFixture[str], hostile_campaign: Path
) -> None:
    out = box.w / "out"
    box.freeze()
    code, err = _cli(
        ["identify", str(hostile_campaign), "-o", "out/modal.csv", "--plots", "out/plots",
         "--fit-report", "out/fit.csv"], capsys,
    )  # fmt: skip
    assert code == 0, err
    box.check(out)
    pngs = sorted(p.name for p in (out / "plots").iterdir() if p.suffix == ".png")
    assert len(pngs) == 8  # stab_ and frf_ for each of the 4 postures, none overwritten
    assert "note: --plots: posture" in err


@pytest.mark.slow
def test_diagnose_outputs_stay_inside(
    box: Sandbox, capsys: pytest.CaptureFixture[str], hostile_campaign: Path
) -> None:
    out = box.w / "out"
    box.links_out(out / "report")
    (out / "report" / "index.html").symlink_to(box.root / "sentinel.txt")
    box.freeze()
    code, err = _cli(
        ["diagnose", str(hostile_campaign), "--json", "out/d.json", "--report", "out/report"],
        capsys,
    )
    _one_line_refusal(code, err)  # robolobe's names in --report are links out: refused
    box.check(out)
    code, err = _cli(
        ["diagnose", str(hostile_campaign), "--json", "out/d.json", "--report", "out/r2",
         "--updated-model", "out/m"], capsys,
    )  # fmt: skip
    assert code in (0, 1), err
    box.check(out)


@pytest.fixture
def modal_csv(tmp_path: Path) -> Path:
    p = tmp_path / "modal.csv"
    p.write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,500,0.03,2e7\nyy,1,520,0.03,2e7\n")
    return p


def test_sld_replaces_a_link_not_its_target(
    box: Sandbox, capsys: pytest.CaptureFixture[str]
) -> None:
    """sld -o/--plot: a link at the output name is replaced, the file it points to kept."""
    out = box.w / "out"
    out.mkdir()
    modes = box.w / "modes.csv"
    modes.write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,500,0.03,2e7\nyy,1,520,0.03,2e7\n")
    (out / "s.csv").symlink_to(box.root / "sentinel.txt")
    (out / "s.png").symlink_to(box.root / "sentinel.txt")
    box.freeze()
    code, err = _cli(
        ["sld", "--modes", str(modes), "--teeth", "2", "--immersion", "0.5", "--rpm",
         "5000:6000:50", "--material", "Al7075-T6", "-o", str(out / "s.csv"), "--plot",
         str(out / "s.png")], capsys,
    )  # fmt: skip
    assert code == 0, err
    box.check(out, named=(out / "s.csv", out / "s.png"))
    assert not (out / "s.csv").is_symlink()
    assert (box.root / "sentinel.txt").read_text() == "parent sentinel"


def test_tl_outputs_stay_inside(box: Sandbox, capsys: pytest.CaptureFixture[str]) -> None:
    """design-tests, predict (-o and --frf), transfer: outputs only where named."""
    out = box.w / "out"
    out.mkdir()
    (out / "p.csv").symlink_to(box.root / "sentinel.txt")
    box.links_out(out / "frf")
    box.freeze()
    code, err = _cli(["design-tests", "B", "--n", "3", "-o", "out/postures.csv"], capsys)
    assert code == 0, err
    code, err = _cli(
        ["predict", "B", "out/postures.csv", "-o", "out/p.csv", "--frf", "out/frf"], capsys
    )
    assert code == 0, err
    assert (out / "frf" / "campaign.toml").is_file()
    assert not (out / "p.csv").is_symlink()
    modes = box.w / "modes.csv"
    modes.write_text("dir,mode,f_hz,zeta,k_N_per_m\nxx,1,500,0.03,2e7\n")
    box.freeze()
    code, err = _cli(["transfer", str(modes), "--robot", "B", "-o", "out/t.npz"], capsys)
    assert code in (0, 2), err  # one posture may be refused; either way nothing outside
    box.check(out, named=(out / "p.csv",))


@pytest.mark.slow
def test_verify_outputs_stay_inside(box: Sandbox, capsys: pytest.CaptureFixture[str]) -> None:
    code, err = _cli(_plan_argv("plan"), capsys)
    assert code == 0, err
    box.links_out(box.w / "plan" / "verify")
    box.freeze()
    code, err = _cli(["verify", "plan", "--robot", "A"], capsys)  # default: plan/verify
    _one_line_refusal(code, err)
    box.check(box.w / "plan")
    code, err = _cli(["verify", "plan", "--robot", "A", "-o", "v"], capsys)
    assert code in (0, 4), err
    box.check(box.w / "plan", box.w / "v")


def test_examples_twice_and_into_links(box: Sandbox, capsys: pytest.CaptureFixture[str]) -> None:
    box.freeze()
    code, err = _cli(["examples", "ex"], capsys)
    assert code == 0, err
    code, err = _cli(["examples", "ex", "--force"], capsys)
    assert code == 0, err
    box.check(box.w / "ex")
    (box.w / "ex2").mkdir()
    (box.w / "ex2" / "pocket.nc").symlink_to(box.root / "sentinel.txt")
    box.freeze()
    code, err = _cli(["examples", "ex2", "--force"], capsys)
    assert code == 0, err
    box.check(box.w / "ex2", named=(box.w / "ex2" / "pocket.nc",))  # the link, not its target
    assert (box.w / "ex2" / "pocket.nc").read_bytes() == (EX / "pocket.nc").read_bytes()


@pytest.fixture(scope="module")
def pocket_plan():  # type: ignore[no-untyped-def]
    from robolobe.plan.job import load_job
    from robolobe.plan.pipeline import plan_path

    return plan_path(EX / "pocket.nc", load_job(EX / "job_A_pocket.toml"), refine=False)


@FEW
@given(pid=hostile.filter(lambda s: s.strip() != "" and s != "p2"))
def test_python_writers_stay_inside(tmp_path: Path, pocket_plan, pid: str) -> None:  # type: ignore[no-untyped-def]
    """rl.write_plan (twice), rl.write_campaign with a hostile posture id (csv and uff)."""
    import robolobe as rl
    from robolobe.campaign import Campaign

    _fresh(tmp_path / "sandbox")
    sb = Sandbox(tmp_path / "sandbox")
    sb.links_out(sb.w / "linked")
    sb.freeze()
    for _ in range(2):
        rl.write_plan(pocket_plan, sb.w / "plan", plots=False, html_report=False)
    with pytest.raises(InputError):
        rl.write_plan(pocket_plan, sb.w / "linked", plots=False, html_report=False)
    f = np.array([0.0, 1.0, 2.0])
    H = np.ones((1, 3, 3, 3), complex)
    camp = Campaign.from_arrays("A", (pid, "p2"), np.zeros((2, 6)), f, np.repeat(H, 2, 0))
    rl.write_campaign(sb.w / "c", camp, fmt="csv")  # ids in a column: any id
    if re.fullmatch(r"[A-Za-z0-9_.\-]+", pid) and safe_name(pid, "x") == pid:
        rl.write_campaign(sb.w / "c", camp, fmt="uff")
        assert (sb.w / "c" / "frf" / f"{pid}.uff").is_file()
    else:  # ids are file names: refused, nothing written
        with pytest.raises(InputError, match="cannot be a file name"):
            rl.write_campaign(sb.w / "c", camp, fmt="uff")
    sb.check(sb.w / "plan", sb.w / "c")


def test_program_writes_only_the_file_named(
    box: Sandbox, capsys: pytest.CaptureFixture[str]
) -> None:
    """program PLAN -o FILE: a link at FILE is replaced (its target kept); a folder is refused."""
    code, err = _cli(_plan_argv("out"), capsys)
    assert code == 0, err
    prog = box.w / "prog"
    prog.mkdir()
    (prog / "p.nc").symlink_to(box.root / "sentinel.txt")
    (prog / "d.nc").mkdir()
    box.freeze()
    code, err = _cli(["program", "out", "-o", str(prog / "d.nc")], capsys)
    _one_line_refusal(code, err)
    box.check(prog)
    code, err = _cli(["program", "out", "-o", str(prog / "p.nc")], capsys)
    assert code == 0, err
    box.check(prog, named=(prog / "p.nc",))
    assert not (prog / "p.nc").is_symlink()
    from robolobe.plan.paths import read_toolpath

    back = read_toolpath(prog / "p.nc")
    assert back.loc[back["motion"] == "cut", "rpm_programmed"].notna().all()
    assert (box.root / "sentinel.txt").read_text() == "parent sentinel"
