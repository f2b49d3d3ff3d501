"""An effects file (e.g. from ``robolobe diagnose --updated-model``) drives
``simulate --effects`` and the job key ``robot.effects``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from robolobe.campaign import read_campaign
from robolobe.cli.main import app
from robolobe.errors import InputError
from robolobe.plan.job import load_job
from robolobe.robots import load_robot
from robolobe.twin import Twin
from robolobe.twin.effects import AddedMass, ToolMode
from robolobe.twin.effects_file import effects_to_toml, read_effects

EXAMPLES = Path(__file__).resolve().parents[2] / "src" / "robolobe" / "data" / "examples"


@pytest.fixture
def effects_file(tmp_path: Path) -> Path:
    p = tmp_path / "effects.toml"
    p.write_text(effects_to_toml([ToolMode(f_hz=25.0, zeta=0.02, mass_kg=8.0, direction="y")]))
    return p


def test_effects_file_round_trip(effects_file: Path) -> None:
    (eff,) = read_effects(effects_file)
    assert isinstance(eff, ToolMode)
    assert (eff.f_hz, eff.zeta, eff.mass_kg, eff.direction) == (25.0, 0.02, 8.0, "y")


def test_simulate_exact_with_effects_matches_the_twin(tmp_path: Path, effects_file: Path) -> None:
    postures = tmp_path / "postures.csv"
    postures.write_text(
        "posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
        "p1,-2,21,-27,5,1,-29\np2,30,30,-102,-145,106,-11\n"
    )
    runner = CliRunner()
    out_nom, out_eff = tmp_path / "nominal", tmp_path / "with_effect"
    for out, extra in ((out_nom, []), (out_eff, ["--effects", str(effects_file)])):
        res = runner.invoke(
            app, ["simulate", "B", "--postures", str(postures), "--exact", "-o", str(out), *extra]
        )
        assert res.exit_code == 0, res.output
    nom, eff = read_campaign(out_nom), read_campaign(out_eff)
    f, h_eff, _ = eff.common_grid()
    _, h_nom, _ = nom.common_grid()
    robot = load_robot("B")
    expected = Twin(robot, read_effects(effects_file)).receptance(eff.q_rad, f)
    sel = f > 1.0
    np.testing.assert_allclose(h_eff[:, sel], expected[:, sel], rtol=1e-6, atol=1e-15)
    # the 25 Hz bracket mode changes the y driving point near 25 Hz
    near = (f > 20) & (f < 30)
    change = np.abs(h_eff[:, near, 1, 1] - h_nom[:, near, 1, 1]).max()
    assert change > 0.1 * np.abs(h_nom[:, near, 1, 1]).max()


def test_bad_effects_file_is_one_line_error(tmp_path: Path) -> None:
    bad = tmp_path / "effects.toml"
    bad.write_text('format = "robolobe-effects/1"\n[[effects]]\nname = "warp_drive"\n')
    res = CliRunner().invoke(
        app, ["simulate", "B", "--design", "seed", "--effects", str(bad), "-o", str(tmp_path / "c")]
    )
    assert res.exit_code != 0
    assert isinstance(res.exception, Exception)
    assert "effects.toml" in str(res.exception)
    assert not (tmp_path / "c").exists()


@pytest.mark.slow
def test_job_effects_need_the_twin_and_change_the_plan(tmp_path: Path) -> None:
    job_text = (EXAMPLES / "job_A_pocket.toml").read_text()
    eff = tmp_path / "effects.toml"
    eff.write_text(effects_to_toml([AddedMass(mass_kg=40.0)]))
    # effects with the shipped network (the bundled job plans on the twin by default)
    no_model = "\n".join(ln for ln in job_text.splitlines() if not ln.strip().startswith("model"))
    bad = tmp_path / "bad_job.toml"
    bad.write_text(
        no_model.replace("[robot]", '[robot]\neffects = "effects.toml"\nmodel = "builtin"', 1)
    )
    with pytest.raises(InputError, match=r"robot\.effects"):
        load_job(bad)
    good_text = job_text.replace("[robot]", '[robot]\neffects = "effects.toml"', 1)
    lines = [ln for ln in good_text.splitlines() if not ln.strip().startswith("model")]
    good = tmp_path / "job.toml"
    good.write_text("\n".join(lines).replace("[robot]", '[robot]\nmodel = "twin"', 1) + "\n")
    job = load_job(good)
    assert len(job.effects) == 1
    assert job.effects[0].name == "added_mass"
    res = CliRunner().invoke(
        app, ["plan", str(EXAMPLES / "pocket.nc"), "--job", str(good), "-o", str(tmp_path / "o")]
    )
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert "added_mass" in summary["mode_source"]
