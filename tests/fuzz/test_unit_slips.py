"""Values in the wrong unit (a factor 1000 and beyond) are refused by name (hypothesis).

The class: a modal stiffness written in N/mm instead of N/m (1000 times
too soft), a receptance in mm/N or um/N instead of m/N (1000 or 1e6 times
too large). The references are physical orders of magnitude stated here: a
robot's modal stiffness is 1e5-1e9 N/m, its receptance's median over the
measured band about 1e-7-1e-5 m/N.
"""

from __future__ import annotations

import csv
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.errors import InputError

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))
FUZZ = settings(
    max_examples=15,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

#: Modal stiffnesses [N/m] of the modes that limit robot milling: the robot's
#: (the twins' lowest over the shipped designs is 1.2e5 N/m) and a soft tool's,
#: up to 1e7. A stiffer mode in N/mm reads like a soft real one (1e4 N/m and
#: more): a modes file's values cannot tell, its lobes (1000 times too shallow)
#: or the tool's size can (``sld --tool-diameter``, a job; below).
real_k = st.floats(1.2e5, 9.9e6)
#: A unit slip: N/mm (x 1e-3) or kN/mm mixed up the other way is out of scope.
slip = st.sampled_from([1e-3, 1e-4, 1e-5, 1e-6])


@FUZZ
@given(k=real_k, factor=slip)
def test_modes_csv_stiffness_in_n_per_mm(tmp_path: Path, k: float, factor: float) -> None:
    from robolobe.sld.io import read_modes_csv

    f = tmp_path / "modes.csv"
    good = f"dir,mode,f_hz,zeta,k_N_per_m\nxx,1,900,0.02,{k!r}\nyy,1,900,0.02,{k!r}\n"
    f.write_text(good)
    read_modes_csv(f)  # the real value reads
    f.write_text(good.replace(repr(k), repr(k * factor)))
    with pytest.raises(InputError, match="k_N_per_m") as info:
        read_modes_csv(f)
    assert "modes.csv" in str(info.value)


def _sld(modes: Path, *extra: str) -> tuple[int, str]:
    """``robolobe sld`` as a user runs it: (exit code, output words)."""
    import contextlib
    import io

    from robolobe.cli.main import main

    buf = io.StringIO()
    code = 0
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        try:
            main(["sld", "--modes", str(modes), "--teeth", "2", "--material", "Al7075-T6",
                  "--immersion", "1", "--rpm", "2000:30000:300", "-o",
                  str(modes.with_name("lobes.csv")), *extra])  # fmt: skip
        except SystemExit as exc:
            code = int(exc.code or 0)
    return code, " ".join(buf.getvalue().split())


@settings(FUZZ, max_examples=10)
@given(
    f=st.floats(300.0, 3000.0),
    k=st.floats(1e7, 9.8e7),
    zeta=st.floats(0.01, 0.05),
    factor=st.sampled_from([1e-3, 1e-4]),
)
def test_sld_stiff_modes_in_n_per_mm(
    tmp_path: Path, f: float, k: float, zeta: float, factor: float
) -> None:
    """Stiff spindle or tool modes (1e7-1e8 N/m) in N/mm given to ``sld``.

    With the tool's size (the job's 20 mm tool at 60 mm: no mode lighter than
    11.8 g, nor softer than 98,945 N/m), every slip is refused by line and
    nothing is written. Without it the lobes are 1000 times too shallow: a
    slot in Al7075 with 2 teeth on such a mode has its minimum at about
    2 k zeta / (N Kt) ~ 0.1 mm and more in N/m, so the slip is refused (below
    10 um) or warned (below 30 um), never silent; the real values read quietly.
    """
    modes = tmp_path / "modes.csv"
    out = tmp_path / "lobes.csv"
    row = f"xx,1,{f!r},{zeta!r},{{k!r}}\nyy,1,{f * 1.05!r},{zeta!r},{{k!r}}\n"
    good = "dir,mode,f_hz,zeta,k_N_per_m\n" + row.format(k=k)
    bad = "dir,mode,f_hz,zeta,k_N_per_m\n" + row.format(k=k * factor)
    modes.write_text(good)
    code, msg = _sld(modes, "--tool-diameter", "20", "--stickout", "60")
    assert code == 0, msg
    assert "warning" not in msg
    code, msg = _sld(modes)
    assert code == 0, msg
    assert "warning" not in msg
    out.unlink()
    modes.write_text(bad)
    code, msg = _sld(modes, "--tool-diameter", "20", "--stickout", "60")
    assert code == 2, msg
    assert f"{modes}:2: k_N_per_m" in msg  # the tool's floor, or the file's own (1e4 N/m)
    assert "N/mm?" in msg
    assert not out.exists()
    code, msg = _sld(modes)
    if code == 2:
        assert f"{modes}:2: k_N_per_m" in msg
        assert "N/mm?" in msg
        assert not out.exists()
    else:
        assert code == 0, msg
        assert "shallower than any practical cut" in msg


@FUZZ
@given(k=real_k, factor=slip)
def test_modal_csv_stiffness_in_n_per_mm(tmp_path: Path, k: float, factor: float) -> None:
    from robolobe.modal.modal_csv import read_modal_csv

    head = "posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,dir,mode,f_hz,zeta,k_N_per_m\n"
    f = tmp_path / "modal.csv"
    f.write_text(head + f"P1,0,-60,90,0,30,0,xx,1,12.5,0.04,{k!r}\n")
    read_modal_csv(f)
    f.write_text(head + f"P1,0,-60,90,0,30,0,xx,1,12.5,0.04,{k * factor!r}\n")
    with pytest.raises(InputError, match="N/mm") as info:
        read_modal_csv(f)
    assert "modal.csv" in str(info.value)


@FUZZ
@given(factor=slip)
def test_job_tool_mode_in_n_per_mm(factor: float) -> None:
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job

    d = job_to_dict(load_job(EX / "job_A_pocket.toml"))
    d["tool"]["modes"][0]["k_N_per_m"] = 5e6 * factor  # a soft tool's mode, in N/mm
    with pytest.raises(InputError, match="k_N_per_m"):
        job_from_dict(d, source="j.toml")


@FUZZ
@given(f=st.floats(300.0, 3000.0), k=st.floats(1e7, 9.8e7), factor=slip)
def test_job_stiff_tool_mode_in_n_per_mm(f: float, k: float, factor: float) -> None:
    """A stiff tool mode (1e7-1e8 N/m) in N/mm: softer than the job's tool can be.

    The pocket's 20 mm tool at 60 mm (a 16 mm steel bar: 9.38e6 N/m, 94.7 g)
    cannot carry a mode softer than 98,945 N/m (on a 1e5 N/m mount) nor one
    lighter than 11.8 g (4.2e6 N/m at 3 kHz); every such mode reads, its slip does not.
    """
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job

    d = job_to_dict(load_job(EX / "job_A_pocket.toml"))
    d["tool"]["modes"][0].update(f_hz=f, k_N_per_m=k)
    job_from_dict(d, source="j.toml")
    d["tool"]["modes"][0]["k_N_per_m"] = k * factor
    with pytest.raises(InputError, match=r"^j\.toml: tool\.modes\[1\]\.k_N_per_m: expected"):
        job_from_dict(d, source="j.toml")


@pytest.fixture(scope="module")
def csv_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from robolobe.campaign import write_campaign
    from robolobe.robots import load_robot
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.model import Twin

    q = np.radians([[0, 10, -20, 0, 20, 0], [30, 0, -30, 10, 30, 5], [-20, 20, -40, 0, 10, 0]])
    camp = simulate_campaign(
        Twin(load_robot("B")).receptance, "B", ["1", "2", "3"], q,
        rng=np.random.default_rng(0), exact=False, dirs=("xx", "yy"), fmax_hz=40.0,
    )  # fmt: skip
    out = tmp_path_factory.mktemp("camp") / "camp"
    write_campaign(out, camp, fmt="csv")
    return out


@FUZZ
@given(factor=st.sampled_from([1e3, 1e4, 1e6]) | st.floats(500.0, 1e7))
def test_receptance_in_mm_per_n(tmp_path: Path, csv_campaign: Path, factor: float) -> None:
    from robolobe.campaign import read_campaign

    d = tmp_path / "c"
    if d.exists():
        shutil.rmtree(d)
    shutil.copytree(csv_campaign, d)
    with (d / "frf.csv").open() as fh:
        rows = list(csv.reader(fh))
    cols = [rows[0].index("re"), rows[0].index("im")]
    for r in rows[1:]:
        for c in cols:
            r[c] = repr(float(r[c]) * factor)
    with (d / "frf.csv").open("w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerows(rows)
    read_campaign(csv_campaign)  # the campaign in m/N reads
    with pytest.raises(InputError, match="mm/N") as info:
        read_campaign(d)
    assert "frf.csv" in str(info.value)


@FUZZ
@given(
    col=st.sampled_from(["feed_mm_per_min", "rpm_programmed"]),
    value=st.floats(max_value=0.0) | st.floats(min_value=1.01e6) | st.just(float("inf")),
    row=st.integers(0, 2),
)
def test_csv_path_rate_out_of_range(tmp_path: Path, col: str, value: float, row: int) -> None:
    from robolobe.plan.paths import read_toolpath

    vals = ["1000", "1000", "1000"]
    vals[row] = repr(value)
    f = tmp_path / "p.csv"
    f.write_text(
        f"x_m,y_m,z_m,{col}\n" + "".join(f"{0.01 * i},0,0,{v}\n" for i, v in enumerate(vals))
    )
    with pytest.raises(InputError, match=col) as info:
        read_toolpath(f)
    assert f"p.csv:{row + 2}" in str(info.value)


@FUZZ
@given(
    where=st.sampled_from(["omega", "frf"]),
    value=st.sampled_from([float("nan"), float("inf"), -1.0]),
    index=st.integers(0, 49),
)
def test_sampled_frf_with_nan_refused(where: str, value: float, index: int) -> None:
    """The API refuses what the CLI's readers refuse: NaN in a sampled FRF."""
    from robolobe.sld import CuttingConditions, get_material, stability_lobes

    omega = np.linspace(100.0, 10000.0, 50)
    wn, z, k = 2 * np.pi * 900.0, 0.02, 1e7
    h = 1.0 / (k * (1 - (omega / wn) ** 2 + 2j * z * omega / wn))
    frf = np.zeros((50, 2, 2), complex)
    frf[:, 0, 0] = frf[:, 1, 1] = h
    if where == "omega":
        if value == -1.0:
            value = -5.0
        omega[index] = value
    else:
        if value == -1.0:
            return  # a negative receptance is a phase, not an error
        frf[index, 0, 0] = value
    with pytest.raises(InputError, match=where):
        stability_lobes(
            (omega, frf), cutter=2, material=get_material("Al7075-T6"),
            conditions=CuttingConditions.from_immersion(0.5, "down"), rpm=np.linspace(5e3, 2e4, 50),
        )  # fmt: skip


@settings(FUZZ, max_examples=6)
@given(
    diameter=st.floats(3.0, 100.0),
    share=st.floats(0.5, 8.0),
    key=st.sampled_from(["stickout_mm", "f_hz"]),
)
def test_job_tool_in_metres_or_khz_refused(diameter: float, share: float, key: str) -> None:
    """A stick-out in metres (1000 times too short) or a tool mode's kHz written as Hz.

    A cutter sticks out of its holder at least a quarter of its diameter (a
    face mill's body), and a spindle, holder or tool mode lies above a milling
    robot's own lowest modes (5 Hz): a 60 mm stick-out written 0.06, a mode
    at 1.85 kHz written 1.85.
    """
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job

    d = job_to_dict(load_job(EX / "job_A_pocket.toml"))
    d["tool"].update(diameter_mm=diameter, stickout_mm=share * diameter)
    d["cut"]["radial_width_mm"] = 0.5 * diameter
    d["tool"]["modes"] = [{"dir": "xy", "f_hz": 2000.0, "zeta": 0.03, "k_N_per_m": 5e8}]
    job_from_dict(d, source="j.toml")
    if key == "stickout_mm":
        d["tool"]["stickout_mm"] = share * diameter * 1e-3
    else:
        d["tool"]["modes"][0]["f_hz"] = 2000.0 * 1e-3
    with pytest.raises(
        InputError, match=rf"^j\.toml: tool: (modes\[1\]\.)?{key}: expected .*at least"
    ):
        job_from_dict(d, source="j.toml")


@FUZZ
@given(
    robot=st.sampled_from(["A", "B", "C"]),
    keys=st.sampled_from([("q_min_deg",), ("q_max_deg",), ("q_min_deg", "q_max_deg")]),
    joints=st.sets(st.integers(0, 5), min_size=1),
)
def test_robot_joint_limits_in_radians(tmp_path: Path, robot: str, keys, joints) -> None:
    """Joint limits written in radians under ``_deg`` keys, for any joints and keys.

    Refused when every value of a key is radians (no arm has all six limits of a
    key within a few degrees of zero); a joint with both limits in radians is
    refused or warned (it would move a few degrees), a symmetric joint with one
    side in radians refused (-185 rad = 185 deg). One side of an asymmetric
    range is not decidable (robot A's joint 2 moves from -140 to -5 deg): no claim.
    """
    import math
    import tomllib

    import tomli_w

    from robolobe.robots import load_robot
    from robolobe.robots.io import builtin_path
    from robolobe.robots.plausibility import robot_warnings

    d = tomllib.loads(builtin_path(robot).read_text())
    decidable = len(joints) == 6 or any(
        len(keys) == 2 or d["joints"][i]["q_min_deg"] == -d["joints"][i]["q_max_deg"]
        for i in joints
    )
    for i in joints:
        for key in keys:
            d["joints"][i][key] = math.radians(d["joints"][i][key])
    p = tmp_path / "r.toml"
    p.write_text(tomli_w.dumps(d))
    try:
        r = load_robot(p)
    except InputError as exc:
        msg = str(exc)
        assert msg.startswith(f"{p}: "), msg
        assert any(k in msg for k in keys), msg
        return
    assert len(joints) < 6 or len(keys) < 2, "all limits in radians accepted"
    assert len(joints) < 6, f"every {keys[0]} in radians accepted"
    if decidable:
        warned = robot_warnings(r)
        assert any("radians" in w for w in warned), (joints, keys, warned)
