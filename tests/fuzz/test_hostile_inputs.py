"""Hostile inputs for every reader: a result or one clear InputError, never a traceback.

Each reader gets the bundled example files cut at random points, with bytes
flipped, lines duplicated or dropped, numbers replaced by extreme values, a
byte-order mark, mixed line endings, and random text (hypothesis). Any
exception other than a :class:`robolobe.errors.RobolobeError` is a bug; so
is a ``RobolobeError`` whose message does not name the file.
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.errors import RobolobeError

EXAMPLES = resources.files("robolobe.data").joinpath("examples")
FUZZ = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

EXTREMES = ["1e300", "-1e300", "nan", "inf", "-0", "0", "1e-300", "99999999999", "-5", "", "x"]


@st.composite
def mutated(draw: st.DrawFn, text: str) -> str:
    """``text`` after a few hostile edits."""
    lines = text.splitlines(keepends=True)
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["cut", "drop", "dup", "number", "bom", "crlf", "junk", "flip"]))
        if not lines:
            break
        i = draw(st.integers(0, len(lines) - 1))
        if op == "cut":
            whole = "".join(lines)
            k = draw(st.integers(0, len(whole)))
            lines = whole[:k].splitlines(keepends=True)
        elif op == "drop":
            del lines[i]
        elif op == "dup":
            lines.insert(i, lines[i])
        elif op == "number":
            nums = list(re.finditer(r"-?\d+(\.\d*)?([eE][-+]?\d+)?", lines[i]))
            if nums:
                m = nums[draw(st.integers(0, len(nums) - 1))]
                rep = draw(st.sampled_from(EXTREMES))
                lines[i] = lines[i][: m.start()] + rep + lines[i][m.end() :]
        elif op == "bom":
            lines[0] = "\ufeff" + lines[0]
        elif op == "crlf":
            lines[i] = lines[i].rstrip("\r\n") + "\r\n"
        elif op == "junk":
            lines.insert(i, draw(st.text(max_size=40)) + "\n")
        elif op == "flip":
            s = lines[i]
            if s:
                k = draw(st.integers(0, len(s) - 1))
                lines[i] = s[:k] + chr((ord(s[k]) + 1) % 0x80 or 1) + s[k + 1 :]
    return "".join(lines)


def _check(read: Callable[[Path], Any], path: Path) -> None:
    try:
        read(path)
    except RobolobeError as exc:
        msg = str(exc)
        assert "\n" not in msg.strip(), msg
        # message rules: no numpy reprs, no doubled prefix ("f.toml: f.toml: ...")
        assert "np.float64" not in msg, msg
        assert "array(" not in msg, msg
        assert not re.search(r"(?:^|\s)(\S+): \1: ", msg), msg
        # the message names the file (or its companion, e.g. a KRL .dat)
        names = [path.name, path.parent.name, *(p.name for p in path.parent.iterdir())]
        assert any(n in msg for n in names), msg
    # anything else propagates and fails the test with its traceback


def _example(name: str) -> str:
    return EXAMPLES.joinpath(name).read_text(encoding="utf-8")


def _toolpath_reader() -> Callable[[Path], Any]:
    from robolobe.plan.paths import read_toolpath

    return read_toolpath


@pytest.mark.parametrize("name", ["pocket.nc", "contour.apt", "face.mod"])
@FUZZ
@given(data=st.data())
def test_toolpath_readers(tmp_path: Path, name: str, data: st.DataObject) -> None:
    text = data.draw(mutated(_example(name)))
    f = tmp_path / name
    f.write_text(text, encoding="utf-8", newline="")
    _check(_toolpath_reader(), f)


@FUZZ
@given(data=st.data())
def test_krl_reader(tmp_path: Path, data: st.DataObject) -> None:
    src = data.draw(mutated(_example("slot.src")))
    dat = data.draw(mutated(_example("slot.dat")))
    (tmp_path / "slot.src").write_text(src, encoding="utf-8", newline="")
    (tmp_path / "slot.dat").write_text(dat, encoding="utf-8", newline="")
    _check(_toolpath_reader(), tmp_path / "slot.src")


@pytest.mark.parametrize("name", ["job_A_pocket.toml", "job_C_face_steel.toml"])
@FUZZ
@given(data=st.data())
def test_job_reader(tmp_path: Path, name: str, data: st.DataObject) -> None:
    from robolobe.plan.job import load_job

    f = tmp_path / name
    f.write_text(data.draw(mutated(_example(name))), encoding="utf-8", newline="")
    _check(load_job, f)


@pytest.mark.parametrize("robot", ["A", "C"])
@FUZZ
@given(data=st.data())
def test_robot_reader(tmp_path: Path, robot: str, data: st.DataObject) -> None:
    from robolobe.robots import load_robot

    text = resources.files("robolobe.data").joinpath("robots", f"{robot}.toml").read_text()
    f = tmp_path / f"{robot}x.toml"
    f.write_text(data.draw(mutated(text)), encoding="utf-8", newline="")
    _check(lambda p: load_robot(str(p)), f)


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    import numpy as np

    from robolobe.campaign import write_campaign
    from robolobe.robots import load_robot
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.model import Twin

    robot = load_robot("B")
    q = np.radians([[0, 10, -20, 0, 20, 0], [30, 0, -30, 10, 30, 5], [-20, 20, -40, 0, 10, 0]])
    camp = simulate_campaign(
        Twin(robot).receptance,
        "B",
        ["1", "2", "3"],
        q,
        rng=np.random.default_rng(0),
        exact=True,
        dirs=("xx", "yy"),
        fmax_hz=20.0,
    )
    out = tmp_path_factory.mktemp("camp") / "camp"
    write_campaign(out, camp, fmt="csv")
    return out


@FUZZ
@given(data=st.data())
def test_campaign_reader(tmp_path: Path, campaign_dir: Path, data: st.DataObject) -> None:
    from robolobe.campaign import read_campaign

    target = tmp_path / "c"
    if target.exists():
        shutil.rmtree(target)
    shutil.copytree(campaign_dir, target)
    name = data.draw(st.sampled_from(sorted(p.name for p in target.iterdir() if p.is_file())))
    f = target / name
    f.write_text(data.draw(mutated(f.read_text())), encoding="utf-8", newline="")
    _check(read_campaign, f)


@pytest.mark.slow
@FUZZ
@given(text=st.text(max_size=300))
def test_random_text_everywhere(tmp_path: Path, text: str) -> None:
    from robolobe.modal.modal_csv import read_modal_csv
    from robolobe.plan.job import load_job
    from robolobe.plan.paths import read_toolpath
    from robolobe.sld.io import read_modes_csv

    for suffix, read in (
        (".nc", read_toolpath), (".apt", read_toolpath), (".mod", read_toolpath),
        (".src", read_toolpath), (".csv", read_modal_csv), (".toml", load_job),
    ):  # fmt: skip
        f = tmp_path / f"rand{suffix}"
        f.write_text(text, encoding="utf-8")
        _check(read, f)
    f = tmp_path / "modes.csv"
    f.write_text(text, encoding="utf-8")
    _check(read_modes_csv, f)
