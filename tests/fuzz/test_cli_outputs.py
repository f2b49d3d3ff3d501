"""Every output option of every command, given a path it cannot write (hypothesis names).

For each command and each of its output options: an existing folder where a
file is expected, an existing file where a folder is expected, a path below a
file, and a path that cannot be created (``/proc``). Each must end in one
line on stderr that names the option, exit code 2, no traceback and nothing
written (the folder is byte-for-byte as before, no temporary files left).
The existing file or folder gets a hypothesis-made name (spaces, unicode,
rich markup like ``[red]`` or ``:smile:``) that must print as written.
"""

from __future__ import annotations

import shutil
from importlib import resources
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.cli.main import main

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))

FUZZ = settings(
    max_examples=2,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

# (command line with OUT for the output, option named in the message, "file" or "dir").
# Inputs exist (inputs are checked after outputs, or not at all before the refusal).
SPECS: list[tuple[list[str], str, str]] = [
    (["plan", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"), "-o", "OUT"],
     "--output", "dir"),
    (["compare", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"), "--robots", "A",
      "-o", "OUT"], "--output", "dir"),
    (["batch", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"), "-o", "OUT"],
     "--output", "dir"),
    (["verify", "INPUTDIR", "--robot", "A", "-o", "OUT"], "--output", "dir"),
    (["simulate", "A", "-o", "OUT", "--design", "random", "--n", "2"], "--output", "dir"),
    (["identify", "INPUTDIR", "-o", "OUT"], "--output", "file"),
    (["identify", "INPUTDIR", "-o", "GOOD.csv", "--plots", "OUT"], "--plots", "dir"),
    (["identify", "INPUTDIR", "-o", "GOOD.csv", "--fit-report", "OUT"], "--fit-report", "file"),
    (["train", "INPUTFILE", "-o", "OUT"], "--output", "file"),
    (["transfer", "INPUTFILE", "--robot", "A", "-o", "OUT"], "--output", "file"),
    (["predict", "A", "INPUTFILE", "-o", "OUT"], "--output", "file"),
    (["predict", "A", "INPUTFILE", "-o", "GOOD.csv", "--frf", "OUT"], "--frf", "dir"),
    (["design-tests", "A", "--n", "3", "-o", "OUT"], "--output", "file"),
    (["sld", "--modes", "INPUTFILE", "--teeth", "2", "--immersion", "0.5", "--rpm",
      "5000:20000", "-o", "OUT"], "--output", "file"),
    (["sld", "--modes", "INPUTFILE", "--teeth", "2", "--immersion", "0.5", "--rpm",
      "5000:20000", "-o", "GOOD.csv", "--plot", "OUT"], "--plot", "file"),
    (["diagnose", "INPUTDIR", "--json", "OUT"], "--json", "file"),
    (["diagnose", "INPUTDIR", "--json", "GOOD.json", "--report", "OUT"], "--report", "dir"),
    (["diagnose", "INPUTDIR", "--json", "GOOD.json", "--updated-model", "OUT"],
     "--updated-model", "dir"),
    (["examples", "OUT"], "DIR", "dir"),
]  # fmt: skip
KINDS = ["wrong-kind", "below-a-file", "not-creatable"]

names = st.text(
    alphabet=st.characters(
        codec="utf-8", exclude_categories=("Cs", "Cc"), exclude_characters="/\\\x00"
    ),
    min_size=1,
    max_size=12,
).filter(lambda s: s.strip(". ") != "" and s == s.strip()) | st.sampled_from(
    ["[bold]x", ":smile:x", "a b", "[s]", "résumé"]
)


def _tree(root: Path) -> dict[str, bytes | None]:
    return {
        str(p.relative_to(root)): (p.read_bytes() if p.is_file() else None)
        for p in sorted(root.rglob("*"))
    }


def _argv(spec: list[str], out: str, root: Path) -> list[str]:
    subst = {
        "OUT": out,
        "INPUTDIR": str(root / "input"),
        "INPUTFILE": str(root / "input" / "modal.csv"),
        "GOOD.csv": str(root / "good" / "g.csv"),
        "GOOD.json": str(root / "good" / "g.json"),
    }
    return [subst.get(a, a) for a in spec]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(("spec", "option", "expects"), SPECS, ids=lambda v: str(v)[:40])
@FUZZ
@given(name=names)
def test_unwritable_output_is_refused(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    spec: list[str],
    option: str,
    expects: str,
    kind: str,
    name: str,
) -> None:
    root = tmp_path / "w"
    if root.exists():
        shutil.rmtree(root)
    (root / "input").mkdir(parents=True)
    (root / "input" / "modal.csv").write_text("posture_id\n")
    existing = root / name
    if expects == "file" and kind == "wrong-kind":
        existing.mkdir()
        (existing / "keep.txt").write_text("keep")
        out = str(existing)
    else:
        existing.write_text("keep")
        out = {
            "wrong-kind": str(existing),
            "below-a-file": str(existing / "sub" / "o.csv"),
            "not-creatable": "/proc/robolobe-no/o",
        }[kind]
    before = _tree(root)
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(_argv(spec, out, root))
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert info.value.code == 2, err
    assert len(lines) == 1, err
    assert "Traceback" not in err
    assert lines[0].startswith(f"error: {option}: "), lines[0]
    if kind == "wrong-kind":
        assert name in lines[0], lines[0]  # printed as written, no markup
        assert ("is a directory" if expects == "file" else "is a file") in lines[0]
    assert _tree(root) == before, "something was written"
    assert not (tmp_path / "w" / "good").exists()
