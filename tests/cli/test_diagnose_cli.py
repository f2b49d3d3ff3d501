"""``robolobe diagnose`` end to end through the command line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robolobe.campaign import Campaign, write_campaign
from robolobe.diagnose.updated_model import load_updated_model

# the concealed-campaign generator is study code, independent of robolobe.twin.effects
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))
from diagnose_reference import Case, P, make_campaign


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", "diagnose", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def mass_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("camp") / "mass"
    camp = make_campaign(Case("B", (P("mass", mass_kg=6.0),), "+6 kg", 0.0, 6, seed=2))
    return write_campaign(path, camp)


@pytest.mark.slow
def test_diagnose_writes_json_report_and_updated_model(mass_campaign: Path, tmp_path: Path) -> None:
    out = tmp_path / "d.json"
    r = _run(
        str(mass_campaign),
        "--json",
        str(out),
        "--report",
        str(tmp_path / "rep"),
        "--updated-model",
        str(tmp_path / "upd"),
        "--candidates",
        "added_mass,joint_stiffness,sensor_delay",
    )
    assert r.returncode == 0, r.stderr
    assert "verdict: added_mass" in r.stdout
    rep = json.loads(out.read_text(encoding="utf-8"))
    assert rep["verdict"] == "added_mass"
    assert rep["parameters"][0]["value"] == pytest.approx(6.0, rel=0.05)
    assert rep["fit_after"]["frac_mean"] > rep["fit_before"]["frac_mean"]
    assert (tmp_path / "rep" / "index.html").is_file()
    twin = load_updated_model(tmp_path / "upd")
    assert twin.effects == ()  # an added mass is baked into robot.toml
    ee = twin.robot.end_effector
    assert ee is not None


@pytest.mark.slow
def test_missing_robot_file_is_a_clear_error(mass_campaign: Path, tmp_path: Path) -> None:
    bad = tmp_path / "camp"
    bad.mkdir()
    for name in ("postures.csv", "frf.csv"):
        (bad / name).write_bytes((mass_campaign / name).read_bytes())
    (bad / "campaign.toml").write_text('robot = "my_robot.toml"\n', encoding="utf-8")
    r = _run(str(bad), "--json", str(tmp_path / "d.json"))
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    assert "campaign.toml" in r.stderr
    assert "my_robot.toml" in r.stderr
    assert not (tmp_path / "d.json").exists()


@pytest.mark.slow
def test_posture_outside_limits_is_left_out_and_said(mass_campaign: Path, tmp_path: Path) -> None:
    bad = tmp_path / "camp"
    bad.mkdir()
    for name in ("campaign.toml", "frf.csv"):
        (bad / name).write_bytes((mass_campaign / name).read_bytes())
    lines = (mass_campaign / "postures.csv").read_text(encoding="utf-8").splitlines()
    cells = lines[2].split(",")
    cells[2] = "90"  # q2 outside B's limits (-60..75 deg), a valid angle otherwise
    lines[2] = ",".join(cells)
    (bad / "postures.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = tmp_path / "d.json"
    r = _run(str(bad), "--json", str(out), "--candidates", "added_mass")
    assert r.returncode == 0, r.stderr
    rep = json.loads(out.read_text(encoding="utf-8"))
    left = [q for q in rep["quality"] if q["check"] == "limits"]
    assert len(left) == 1
    assert left[0]["posture"] == cells[0]
    assert "q2" in left[0]["message"]
    assert rep["n_postures"] == 5
    assert "Data warnings" in rep["summary"]


@pytest.mark.slow
def test_missing_folder_and_bad_options(tmp_path: Path, mass_campaign: Path) -> None:
    r = _run(str(tmp_path / "nope"), "--json", str(tmp_path / "d.json"))
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    r = _run(str(mass_campaign), "--json", str(tmp_path / "d.json"), "--candidates", "magic")
    assert r.returncode == 2
    assert "--candidates" in r.stderr
    r = _run(str(mass_campaign), "--json", str(tmp_path / "d.json"), "--band-hz", "40,2")
    assert r.returncode == 2
    assert "--band-hz" in r.stderr
    r = _run(str(mass_campaign), "--json", str(tmp_path / "d.json"), "--jobs", "0")
    assert r.returncode == 2
    assert "--jobs" in r.stderr
    assert not (tmp_path / "d.json").exists()


@pytest.mark.slow
def test_directions_missing_for_a_candidate_are_reported(tmp_path: Path) -> None:
    camp = make_campaign(Case("B", (), "null", 0.0, 5, seed=4))
    H = np.stack([f.H for f in camp.frfs])
    only_yy = Campaign.from_arrays(
        "B", camp.posture_ids, camp.q_rad, camp.frfs[0].freq_hz, H, dirs=["yy"], test=camp.test
    )
    path = write_campaign(tmp_path / "yy", only_yy)
    out = tmp_path / "d.json"
    r = _run(str(path), "--json", str(out), "--candidates", "sensor_misalignment,tool_mode")
    assert r.returncode == 0, r.stderr
    rep = json.loads(out.read_text(encoding="utf-8"))
    why = {(u["name"], u["variant"]): u["reason"] for u in rep["untestable"]}
    assert "2 measured directions" in why[("sensor_misalignment", "")]
    assert ("tool_mode", "direction x") in why
    assert ("tool_mode", "direction y") not in why
    assert "Not tested" in rep["summary"]
    assert rep["verdict"] in ("none", "unexplained") or "tool_mode" in rep["verdict"]


@pytest.mark.slow
def test_band_wider_than_the_data_is_cut_and_said(mass_campaign: Path, tmp_path: Path) -> None:
    out = tmp_path / "d.json"
    r = _run(
        str(mass_campaign),
        "--json",
        str(out),
        "--band-hz",
        "0.5,2000",
        "--candidates",
        "added_mass",
    )
    assert r.returncode == 0, r.stderr
    rep = json.loads(out.read_text(encoding="utf-8"))
    assert rep["band_hz"][1] == pytest.approx(512.0)  # an explicit band may go to the top
    assert any(q["check"] == "band" for q in rep["quality"])
    assert "wider than the recordings" in rep["summary"]
