"""A plan's own program, checked as written, has no move inside the safety factor (issues 26, 29).

The plan is made at each move's own engagement and depth in passes; its
program holds the passes (each section once per pass, shifted up the tool
axis); ``check`` reads that program back, runs its own Z-map over it (every
pass's moves meet the material the earlier passes left) and judges every
move at its written S and engagement. Nothing the planner chose is taken
from the plan but the program text.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import pytest

import robolobe as rl
from robolobe.plan.program import write_program

EX = resources.files("robolobe.data").joinpath("examples")

CASES = [
    ("pocket.nc", "job_A_pocket.toml"),
    pytest.param("contour.apt", "job_B_contour.toml", marks=pytest.mark.slow),
    pytest.param("face.mod", "job_C_face_steel.toml", marks=pytest.mark.slow),
    pytest.param("slot.src", "job_A_slot_steel.toml", marks=pytest.mark.slow),
]


@pytest.mark.parametrize(("path", "job"), CASES)
def test_the_plans_own_program_checks_inside_no_safety_factor(path, job, tmp_path: Path) -> None:
    j = rl.load_job(EX.joinpath(job))
    res = rl.plan_path(EX.joinpath(path), j)
    assert res.summary.passes
    assert max(r["passes"] for r in res.summary.passes) > 1
    prog = write_program(res, tmp_path / "program")
    if prog.suffix in (".src", ".mod"):  # KRL, RAPID: S on the analog output the job scales
        po = j.program_options
        per_unit = float(po["analog_rpm_full_scale"]) / float(po.get("analog_full_scale", 1.0))
        opts = {"spindle_output": po["analog_output"], "spindle_rpm_per_unit": per_unit}
        j = j.replace(path_options={**j.path_options, **opts})
    chk = rl.check_program(prog, j)
    assert chk.n_beyond == 0
    assert chk.n_inside_sf == 0, chk.inside_sf[:5]
    assert chk.min_margin >= j.plan.safety_factor * (1 - 1e-9)
    # every pass's moves were judged: about the plan's bounded moves times their passes
    t = res.table
    bounded = (t["motion"] == "cut") & t["margin"].notna()
    expected = int(t.loc[bounded, "passes"].sum())
    assert 0.95 * expected <= chk.summary["n_bounded"] <= 1.05 * expected
