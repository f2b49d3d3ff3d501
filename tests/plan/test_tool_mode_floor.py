"""A job's tool mode softer than a tool of its size can be is refused (a stiffness in N/mm).

The thresholds below are worked out by hand from the bound's physics, not
taken from the code. A tool-point mode either moves the spindle (modal mass
``k / (2 pi f)^2`` at least the spindle's mass at the tip, 0.5 kg when the robot
is not known, on a mount of at least 1e5 N/m: the floor
``max(1e5, 0.5 (2 pi f)^2)``) or is lighter, and then bends the tool, holder and
spindle only: a steel bar (E = 210 GPa, 7,850 kg/m^3) of 0.8 times the tool's
diameter, clamped at its stick-out, on a spindle and holder of 1e6 N/m gives the
static bound ``1 / (L^3 / (3 E I) + 1 / 1e6 N/m)``, and the mass bound
``(m_bar / 8) (2 pi f)^2`` (a quarter of the bar's mass is the tip-normalised
modal mass of every cantilever bending mode; half of it). The floor is the lower
of the two kinds' floors.

Bundled pocket tool, D = 20 mm, L = 60 mm: d = 16 mm,
I = pi 0.016^4 / 64 = 3.2170e-9 m^4, k_bar = 3 * 2.1e11 * I / 0.06^3 = 9.3829e6 N/m,
static bound 1 / (1 / 9.3829e6 + 1e-6) = 903,688 N/m; m_bar = 7850 * pi 0.016^2 / 4
* 0.06 = 0.094700 kg, m_bar / 8 = 0.0118375 kg, so at 1850 Hz
0.0118375 * (2 pi 1850)^2 = 1.5994e6 N/m (a spindle mode there: 6.76e7 N/m), at
850 Hz the static 903,688 N/m (spindle: 1.43e7), at 100 Hz the spindle's
0.5 * (2 pi 100)^2 = 197,392 N/m (below the tool's 903,688), at 50 Hz the mount's 1e5.

A 6 mm tool at 60 mm, 300 Hz: d = 4.8 mm, k_bar = 76,001 N/m, static bound
70,633 N/m (mass bound 3,785 N/m, spindle 1.78e6 N/m); at the default 50 mm
stick-out k_bar = 131,330 N/m and the bound 116,085 N/m.
"""

from __future__ import annotations

import copy
from importlib import resources
from pathlib import Path
from typing import Any

import pytest

from robolobe.errors import InputError
from robolobe.plan.job import job_from_dict, job_to_dict, load_job

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


@pytest.fixture(scope="module")
def pocket() -> dict[str, Any]:
    return job_to_dict(load_job(EX / "job_A_pocket.toml"))


def _with_mode(d: dict[str, Any], f_hz: float, k: float, **tool: float) -> dict[str, Any]:
    d = copy.deepcopy(d)
    d["tool"].update(tool)
    d["tool"]["modes"][0].update(f_hz=f_hz, k_N_per_m=k)
    return d


@pytest.mark.parametrize("name", sorted(p.name for p in EX.glob("job_*.toml")))
def test_bundled_jobs_load(name: str) -> None:
    assert load_job(EX / name).tool.modes


@pytest.mark.parametrize(
    ("f_hz", "floor"),
    [(1850.0, 1.5994e6), (850.0, 903_688.0), (100.0, 197_392.0), (50.0, 1.0e5)],
)
def test_threshold_of_the_pocket_tool(pocket: dict[str, Any], f_hz: float, floor: float) -> None:
    job_from_dict(_with_mode(pocket, f_hz, floor * 1.001), source="j.toml")
    with pytest.raises(InputError) as info:
        job_from_dict(_with_mode(pocket, f_hz, floor * 0.999), source="j.toml")
    msg = str(info.value)
    assert msg.startswith("j.toml: tool.modes[1].k_N_per_m: expected at least ")
    assert f"{floor:.3g} N/m" in msg
    assert "N/mm" in msg
    assert "a stick-out of 60 mm (" in msg
    assert msg.endswith("or give the tool's real tool.stickout_mm")
    assert "(the default)" not in msg
    assert "\n" not in msg


def test_second_mode_is_named(pocket: dict[str, Any]) -> None:
    d = copy.deepcopy(pocket)
    d["tool"]["modes"][1]["k_N_per_m"] = 6.0e4  # the bundled 6.0e7 N/m written in N/mm
    with pytest.raises(InputError, match=r"tool\.modes\[2\]\.k_N_per_m: .* found 60000: .*6e\+07"):
        job_from_dict(d, source="j.toml")


def test_slender_tool_and_default_stickout(pocket: dict[str, Any]) -> None:
    d = _with_mode(pocket, 300.0, 70_633.0 * 1.001, diameter_mm=6.0, stickout_mm=60.0)
    d["cut"]["radial_width_mm"] = 3.0
    job_from_dict(d, source="j.toml")
    d["tool"]["modes"][0]["k_N_per_m"] = 70_633.0 * 0.999
    with pytest.raises(InputError, match=r"7\.06e\+04 N/m"):
        job_from_dict(d, source="j.toml")
    # stick-out not given: the default 50 mm, said as such
    del d["tool"]["stickout_mm"]
    d["tool"]["modes"][0]["k_N_per_m"] = 116_085.0 * 0.999
    with pytest.raises(InputError, match=r"1\.16e\+05 N/m .*stick-out of 50 mm \(the default\)"):
        job_from_dict(d, source="j.toml")
    d["tool"]["modes"][0]["k_N_per_m"] = 116_085.0 * 1.001
    job_from_dict(d, source="j.toml")


def test_cli_refuses_with_one_line(tmp_path: Path) -> None:
    import subprocess
    import sys

    text = (EX / "job_A_pocket.toml").read_text()
    assert "k_N_per_m = 2.2e7" in text
    job = tmp_path / "slip.toml"
    job.write_text(text.replace("k_N_per_m = 2.2e7", "k_N_per_m = 2.2e4"))
    out = tmp_path / "out"
    r = subprocess.run(
        [sys.executable, "-m", "robolobe", "plan", str(EX / "pocket.nc"), "--job", str(job),
         "-o", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert r.returncode == 2
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1
    assert "slip.toml" in lines[0]
    assert "tool.modes[1].k_N_per_m" in lines[0]
    assert "Traceback" not in r.stderr
    assert not out.exists()


def test_python_api_tool_spec_is_checked() -> None:
    from robolobe.plan.job import ToolMode, ToolSpec

    ok = ToolMode("x", 1850.0, 0.035, 1.5994e6 * 1.001)
    ToolSpec(diameter_m=0.02, teeth=3, stickout_m=0.06, modes=(ok,))
    slip = ToolMode("y", 1850.0, 0.035, 2.2e4)
    want = r"^ToolSpec\.modes\[1\]\.k_N_per_m: expected at least 1\.6e\+06 .*real stickout_m$"
    with pytest.raises(InputError, match=want):
        ToolSpec(diameter_m=0.02, teeth=3, stickout_m=0.06, modes=(ok, slip))
