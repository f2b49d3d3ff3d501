"""``robolobe simulate`` end to end."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robolobe.campaign import read_campaign
from robolobe.cli import main as cli_main
from robolobe.robots import load_robot, save_robot
from robolobe.twin.model import Twin

REPO = Path(__file__).resolve().parents[2]
# Robot B's test postures, seed paper Table 3 [deg].
B_POSTURES = (
    "posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
    "T1,-2,21,-27,5,1,-29\n"
    "T2,-60,50,-120,115,-66,-197\n"
    "T3,23,-28,-101,-82,124,168\n"
)


def _argv(*args: str) -> list[str]:
    """Arguments for the robolobe app (typer runs a lone command without its name)."""
    app = cli_main.app
    single = (
        len(app.registered_commands) == 1
        and not app.registered_groups
        and app.registered_callback is None
    )
    return list(args) if single else ["simulate", *args]


def _run(*args: str) -> None:
    with pytest.raises(SystemExit) as exc:
        cli_main.main(_argv(*args))
    assert exc.value.code == 0


@pytest.fixture
def postures(tmp_path: Path) -> Path:
    p = tmp_path / "postures.csv"
    p.write_text(B_POSTURES)
    return p


def _frac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """FRAC over the last-but-one axis (frequency)."""
    num = np.abs(np.sum(a * b.conj(), axis=-1)) ** 2
    return num / (np.sum(np.abs(a) ** 2, axis=-1) * np.sum(np.abs(b) ** 2, axis=-1))


@pytest.mark.slow
def test_simulated_campaign_on_b(tmp_path, postures, capsys):
    out = tmp_path / "camp"
    _run("B", "--postures", str(postures), "-o", str(out), "--seed", "3")
    assert "3 postures" in capsys.readouterr().out
    c = read_campaign(out)
    assert c.robot == "B"
    assert c.posture_ids == ("T1", "T2", "T3")
    np.testing.assert_allclose(np.degrees(c.q_rad[1]), [-60, 50, -120, 115, -66, -197])
    assert c.dirs == {r + e for r in "xyz" for e in "xyz"}
    f, h, has = c.common_grid()
    np.testing.assert_allclose(f, np.arange(161) * 0.25)
    assert has.all()
    assert c.test["sample_rate_hz"] == 1024.0
    assert c.test["duration_s"] == 4.0
    assert c.test["impacts"] == 5
    # The test measured the right structure per posture: driving-point FRFs have the
    # shape of the exact receptance (FRAC; the 5 % exponential window broadens peaks),
    # and match each posture better than any other posture.
    exact = Twin(load_robot("B")).receptance(c.q_rad, f)
    band = f >= 2
    d = np.arange(3)
    sim = np.moveaxis(h[:, band][:, :, d, d], 1, -1)  # (3 postures, 3 dirs, n)
    ex = np.moveaxis(exact[:, band][:, :, d, d], 1, -1)
    same = _frac(sim, ex)
    assert np.median(same) > 0.85
    cross = _frac(sim[:, None], ex[None, :])  # (sim posture, exact posture, dir)
    for p in range(3):
        assert np.mean(cross[p, p]) > max(np.mean(cross[p, k]) for k in range(3) if k != p)
    # Same seed, same campaign.
    _run("B", "--postures", str(postures), "-o", str(tmp_path / "again"), "--seed", "3")
    np.testing.assert_array_equal(read_campaign(tmp_path / "again").common_grid()[1], h)


def test_exact_matches_twin(tmp_path, postures):
    out = tmp_path / "exact"
    _run("B", "--postures", str(postures), "-o", str(out), "--exact", "--fmax", "30")
    c = read_campaign(out)
    f, h, _ = c.common_grid()
    np.testing.assert_allclose(f, np.arange(121) * 0.25)
    exact = Twin(load_robot("B")).receptance(c.q_rad, f)
    np.testing.assert_allclose(h, exact, rtol=1e-12)
    assert c.test == {}


def test_user_robot_file_and_uff(tmp_path):
    robot_file = REPO / "examples" / "robots" / "my_robot.toml"
    if not robot_file.is_file():  # the example ships with the robots package
        robot_file = tmp_path / "my_robot.toml"
        save_robot(load_robot("C"), robot_file)
    robot = load_robot(robot_file)
    q_deg = np.degrees((robot.q_min + robot.q_max) / 2)
    pfile = tmp_path / "p.csv"
    pfile.write_text(
        "posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
        + "mid,"
        + ",".join(repr(float(x)) for x in q_deg)
        + "\n"
    )
    out = tmp_path / "user"
    _run(
        str(robot_file),
        "--postures",
        str(pfile),
        "-o",
        str(out),
        "--format",
        "uff",
        "--dirs",
        "xx,yy,zz",
        "--exact",
    )
    assert (out / "robot.toml").read_text() == robot_file.read_text()
    assert (out / "frf" / "mid.uff").is_file()
    c = read_campaign(out)
    assert Path(c.robot) == (out / "robot.toml").resolve()
    assert c.dirs == {"xx", "yy", "zz"}
    f, h, _ = c.common_grid()
    exact = Twin(robot).receptance(c.q_rad, f)
    d = np.arange(3)
    np.testing.assert_allclose(h[:, :, d, d], exact[:, :, d, d], rtol=1e-10)


def test_seed_design_exact(tmp_path):
    out = tmp_path / "design"
    _run("B", "--design", "seed", "-o", str(out), "--exact", "--fmax", "5", "--dirs", "zz")
    c = read_campaign(out)
    assert c.n_postures == 25
    assert c.posture_ids[-5:] == ("T1", "T2", "T3", "T4", "T5")


def _subprocess(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", *_argv(*args)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


@pytest.mark.slow
def test_bad_postures_file_exits_2_without_output(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text(B_POSTURES.replace("T3,23,", "T3,230,"))
    out = tmp_path / "never"
    r = _subprocess("B", "--postures", str(bad), "-o", str(out))
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    msg = r.stderr.strip()
    assert len(msg.splitlines()) == 1
    assert "bad.csv:4" in msg
    assert "posture 'T3'" in msg
    assert "q1_deg" in msg
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("--dirs", "xq"), "--dirs"),
        (("--format", "mat"), "--format"),
        (("--fmax", "600"), "--fmax"),
    ],
)
def test_bad_options_exit_2(tmp_path, postures, capsys, args, needle):
    out = tmp_path / "never"
    with pytest.raises(SystemExit) as exc:
        cli_main.main(_argv("B", "--postures", str(postures), "-o", str(out), *args))
    assert exc.value.code == 2
    assert needle in capsys.readouterr().err
    assert not out.exists()


def test_needs_postures_or_design(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cli_main.main(_argv("B", "-o", str(tmp_path / "x")))
    assert exc.value.code == 2
    assert "--postures" in capsys.readouterr().err
