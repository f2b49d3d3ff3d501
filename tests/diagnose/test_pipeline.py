"""End to end on small concealed campaigns (robot B), JSON schema and report."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from diagnose_reference import Case, P, make_campaign

from robolobe.campaign import Campaign
from robolobe.diagnose import DiagnoseSettings, diagnose, to_report, write_report
from robolobe.errors import InputError
from robolobe.robots import load_robot

FAMS = ("added_mass", "joint_stiffness", "sensor_delay", "gravity_stiffening")


@pytest.fixture(scope="module")
def mass_diagnosis():  # type: ignore[no-untyped-def]
    camp = make_campaign(Case("B", (P("mass", mass_kg=5.0),), "+5 kg", 0.0, 8, seed=3))
    return diagnose(camp, robot=load_robot("B"), settings=DiagnoseSettings(families=FAMS))


@pytest.mark.slow
def test_names_added_mass_and_improves_the_fit(mass_diagnosis) -> None:  # type: ignore[no-untyped-def]
    d = mass_diagnosis
    assert d.verdict == "added_mass"
    assert d.winner.params[0] == pytest.approx(5.0, rel=0.05)  # the concealed 5 kg
    assert d.fit_after.frac_mean > d.fit_before.frac_mean
    assert d.fit_after.frac_mean >= 0.98
    assert d.fit_after.nrmse_mean < d.fit_before.nrmse_mean
    assert "kg at the tool" in d.summary
    assert "Found:" in d.summary
    assert "UNEXPLAINED" not in d.summary
    assert "Analysed 1-409.5 Hz" in d.summary  # the whole recorded band, stated
    assert d.named == ("added_mass",)
    assert d.forward.noise.misfit_x_noise < 2.0
    assert "->" in d.summary
    assert [e.name for e in d.effects] == ["added_mass"]
    # friction cannot be tested on one force level, and the diagnosis says so
    assert not any(u.name == "friction_damping" for u in d.untestable)  # not requested
    assert d.window_decay_per_s == pytest.approx(-np.log(0.05) / 4.0)


@pytest.mark.slow
def test_json_schema_holds_the_required_keys(mass_diagnosis) -> None:  # type: ignore[no-untyped-def]
    rep = json.loads(to_report(mass_diagnosis).model_dump_json())
    for key in ("verdict", "candidates", "fit_before", "fit_after", "summary", "untestable"):
        assert key in rep
    assert rep["verdict"] == "added_mass"
    ranks = [c["rank"] for c in rep["candidates"]]
    assert ranks == sorted(ranks)
    named = [c for c in rep["candidates"] if c["named"]]
    assert len(named) == 1
    assert named[0]["name"] == "added_mass"
    assert rep["unexplained"] is False
    assert rep["steps"][0]["label"] == "added_mass"
    assert rep["steps"][0]["share"] == pytest.approx(1.0)
    for k in ("frac_mean", "frac_min", "nrmse_mean"):
        assert 0 <= rep["fit_after"][k] <= 1.5
    assert rep["parameters"][0]["name"] == "mass_kg"
    assert rep["parameters"][0]["std"] > 0


@pytest.mark.slow
def test_report_folder(mass_diagnosis, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    out = write_report(mass_diagnosis, tmp_path / "rep")
    for name in ("index.html", "mismatch_map.png", "frf_overlays.png", "ranking.png", "modes.png"):
        assert (out / name).stat().st_size > 1000
    html = (out / "index.html").read_text(encoding="utf-8")
    assert "added_mass" in html
    assert "mismatch_map.png" in html


@pytest.mark.slow
def test_null_campaign_gives_none() -> None:
    camp = make_campaign(Case("B", (), "null", 0.0, 8, seed=11))
    d = diagnose(camp, robot=load_robot("B"), settings=DiagnoseSettings(families=FAMS))
    assert d.verdict == "none"
    assert d.effects == ()
    assert "within the noise" in d.summary
    np.testing.assert_allclose(d.fit_after.frac, d.fit_before.frac)


@pytest.mark.slow
@pytest.mark.parametrize(("levels", "found"), [(None, "found 0"), (200.0, "found 1")])
def test_friction_needs_force_levels(levels: float | None, found: str) -> None:
    # no force column, or one hammer force level for every posture: friction cannot be
    # told from viscous damping; the diagnosis says so and still answers
    camp = make_campaign(Case("B", (), "null", 0.0, 6, seed=5))
    force = None if levels is None else np.full(len(camp.posture_ids), levels)
    d = diagnose(
        camp,
        robot=load_robot("B"),
        settings=DiagnoseSettings(families=("added_mass", "friction_damping")),
        force_N=force,
    )
    why = {u.name: u.reason for u in d.untestable}
    assert "force levels" in why["friction_damping"]
    assert found in why["friction_damping"]
    assert "friction_damping" in d.summary  # "Not tested: ..."
    assert d.verdict == "none"  # it still answers (a null campaign, exact file)


@pytest.mark.slow
def test_postures_outside_the_robots_limits_are_left_out_with_a_warning() -> None:
    camp = make_campaign(Case("B", (), "null", 0.0, 5, seed=1))
    q = camp.q_rad.copy()
    q[2, 0] = np.radians(300.0)
    bad = Campaign(camp.robot, camp.posture_ids, q, camp.frfs, test=camp.test)
    d = diagnose(bad, robot=load_robot("B"), settings=DiagnoseSettings(families=FAMS))
    left = [i for i in d.quality if i.check == "limits"]
    assert [i.posture_id for i in left] == [camp.posture_ids[2]]
    assert "q1" in left[0].message
    assert camp.posture_ids[2] not in d.obs.record_ids
    assert "Data warnings" in d.summary
    assert camp.posture_ids[2] in d.summary
    # with fewer than two postures left it refuses, naming the posture
    q2 = q.copy()
    q2[:4, 0] = np.radians(300.0)
    worse = Campaign(camp.robot, camp.posture_ids, q2, camp.frfs, test=camp.test)
    with pytest.raises(InputError, match="q1"):
        diagnose(worse, robot=load_robot("B"))


def test_a_single_posture_cannot_be_cross_validated() -> None:
    camp = make_campaign(Case("B", (), "null", 0.0, 1, seed=1))
    with pytest.raises(InputError, match="at least 2 postures"):
        diagnose(camp, robot=load_robot("B"))
