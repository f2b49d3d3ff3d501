"""Numeric options and job keys at their edges: refused before any output (hypothesis).

The class: a count, step, tolerance, factor or seed outside what the
computation can use (zero, negative, tiny, astronomically large, NaN).
Each must end in one line naming the option or key, exit code 2, and
nothing written; or, where a large value has a natural meaning (a thinning
block longer than the table), give that meaning without the cost.
"""

from __future__ import annotations

import math
import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.cli.main import main
from robolobe.errors import InputError

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))
FUZZ = settings(
    max_examples=15,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
MODES = "dir,mode,f_hz,zeta,k_N_per_m\nxx,1,922,0.011,1.34e6\nyy,1,922,0.011,1.34e6\n"


def _refused(argv: list[str], option: str, capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    assert "Traceback" not in err
    assert option in err, err
    return err


def _sld(tmp_path: Path, *extra: str) -> list[str]:
    modes = tmp_path / "m.csv"
    modes.write_text(MODES)
    return ["sld", "--modes", str(modes), "--teeth", "2", "--immersion", "0.5",
            "--rpm", "5000:9000:20", "--material", "Al7075-T6",
            "-o", str(tmp_path / "out" / "l.csv"), *extra]  # fmt: skip


#: Below 1 (depths above the limit) or above 10 (a tenth of the limit: a slip, e.g. 2**64).
bad_safety = (
    st.floats(max_value=0.999, allow_nan=False)
    | st.floats(min_value=10.001, allow_nan=False)
    | st.sampled_from([math.nan, math.inf, 2.0**64])
)


@FUZZ
@given(safety=bad_safety)
def test_sld_safety_refused_before_the_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], safety: float
) -> None:
    argv = _sld(tmp_path, "--safety", repr(safety), "--plot", str(tmp_path / "out" / "l.png"))
    _refused(argv, "--safety", capsys)
    assert not (tmp_path / "out").exists()


@FUZZ
@given(intervals=st.integers(max_value=1) | st.integers(min_value=401, max_value=10**12))
def test_sld_sdm_intervals_bounded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], intervals: int
) -> None:
    argv = _sld(tmp_path, "--method", "sdm", "--intervals", str(intervals))
    _refused(argv, "--intervals", capsys)
    assert not (tmp_path / "out").exists()


@FUZZ
@given(seed=st.integers(max_value=-1) | st.integers(min_value=2**32, max_value=2**80))
def test_seed_out_of_range_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: int
) -> None:
    out = tmp_path / "d.csv"
    argv = ["design-tests", "A", "--n", "3", "-o", str(out), "--seed", str(seed)]
    _refused(argv, "--seed", capsys)
    assert not out.exists()


@FUZZ
@given(
    n=st.integers(1, 300),
    every=st.integers(1, 400) | st.integers(min_value=2**31, max_value=2**80),
    seed=st.integers(0, 2**16),
)
def test_thinning_blocks_beyond_the_table(n: int, every: int, seed: int) -> None:
    from robolobe.plan.report import thin_rows

    rng = np.random.default_rng(seed)
    margin = rng.uniform(1, 5, n)
    margin[rng.random(n) < 0.2] = np.inf  # rapids
    table = pd.DataFrame({"line": np.arange(n), "margin": margin})
    out = thin_rows(table, every)
    k = min(every, n)
    assert len(out) == -(-n // k)
    finite = margin[np.isfinite(margin)]
    if finite.size:
        assert out["margin"].min() == finite.min()  # the tightest row is kept


def test_batch_starts_no_pool_for_one_path(monkeypatch: pytest.MonkeyPatch) -> None:
    import joblib

    from robolobe.plan.batch import batch_plan
    from robolobe.plan.job import load_job

    def no_pool(*a: object, **k: object) -> None:
        raise AssertionError("a worker pool for one path")

    monkeypatch.setattr(joblib, "Parallel", no_pool)
    job = load_job(EX / "job_A_pocket.toml")
    rows = list(batch_plan([EX / "missing.nc"], job, workers=12))
    assert len(rows) == 1
    assert rows[0]["status"] != "ok"
    with pytest.raises(InputError, match="workers"):
        list(batch_plan([EX / "pocket.nc"], job, workers=0))


@FUZZ
@given(step=st.floats(min_value=1e-12, max_value=0.49))
def test_tool_rotation_step_bounded(step: float) -> None:
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job

    d = job_to_dict(load_job(EX / "job_A_pocket.toml"))
    d["robot"].update(tool_rotation="stiffest", tool_rotation_step_deg=step)
    with pytest.raises(InputError, match="tool_rotation_step_deg"):
        job_from_dict(d, source="j.toml")


@FUZZ
@given(tol=st.floats(min_value=5e-324, max_value=9.99e-4) | st.floats(max_value=0.0))
def test_arc_tolerance_bounded(tol: float) -> None:
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job

    d = job_to_dict(load_job(EX / "job_A_pocket.toml"))
    d.setdefault("path", {})["arc_tol_mm"] = tol
    with pytest.raises(InputError, match="arc_tol_mm"):
        job_from_dict(d, source="j.toml")


@FUZZ
@given(
    key=st.sampled_from(
        ["vc_min_m_per_min", "vc_max_m_per_min", "feed_per_tooth_min_mm", "feed_per_tooth_max_mm"]
    ),
    value=st.floats(max_value=0.0)
    | st.floats(min_value=1.0001e4)
    | st.sampled_from([math.nan, math.inf, -math.inf]),
)
def test_process_limit_keys_bounded(key: str, value: float) -> None:
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job

    d = job_to_dict(load_job(EX / "job_C_face_steel.toml"))
    d["cut"][key] = value
    with pytest.raises(InputError, match=key):
        job_from_dict(d, source="j.toml", base_dir=EX)


@FUZZ
@given(vc_min=st.floats(min_value=628.4, max_value=9000.0))
def test_vc_the_spindle_cannot_reach_is_refused(vc_min: float) -> None:
    # D25 at spindle.rpm_max 8000: vc = pi 25 8000 / 1000 = 628.3 m/min at most
    from robolobe.plan.job import job_from_dict, job_to_dict, load_job
    from robolobe.plan.limits import process_limits

    d = job_to_dict(load_job(EX / "job_C_face_steel.toml"))
    d["cut"].update(vc_min_m_per_min=vc_min, vc_max_m_per_min=1e4)
    job = job_from_dict(d, source="j.toml", base_dir=EX)
    with pytest.raises(InputError, match=r"j\.toml: cut\.vc_min_m_per_min: .* 628\.3 m/min"):
        process_limits(job)


#: Numeric options of the quick commands, the class of their edge values.
EDGE_VALUES = (
    st.sampled_from(
        ["0", "-1", "nan", "inf", "-inf", "1e300", "1e-300", str(2**64), "1e9", "abc", ""]
    )
    | st.integers(-(2**70), 2**70).map(str)
    | st.floats(allow_nan=True).map(repr)
)


@pytest.fixture(scope="module")
def quick_inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from robolobe.campaign import write_campaign
    from robolobe.robots import load_robot
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.model import Twin

    root = tmp_path_factory.mktemp("quick")
    q = np.radians([[0, 10, -20, 0, 20, 0], [30, 0, -30, 10, 30, 5], [-20, 20, -40, 0, 10, 0]])
    camp = simulate_campaign(
        Twin(load_robot("B")).receptance, "B", ["1", "2", "3"], q,
        rng=np.random.default_rng(0), exact=False, dirs=("xx", "yy"), fmax_hz=30.0,
    )  # fmt: skip
    write_campaign(root / "camp", camp, fmt="csv")
    (root / "m.csv").write_text(MODES)
    (root / "post.csv").write_text(
        "posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\nP1,0,-60,90,0,30,0\n"
    )
    return root


def _edge_argv(root: Path, out: Path, command: str, option: str, value: str) -> list[str]:
    base = {
        "identify": ["identify", str(root / "camp"), "-o", str(out / "i.csv")],
        "simulate": ["simulate", "B", "--design", "random", "--n", "2", "--fmax", "10",
                     "-o", str(out / "sim")],
        "predict": ["predict", "A", str(root / "post.csv"), "-o", str(out / "p.csv"),
                    "--frf", str(out / "pf")],
        "design-tests": ["design-tests", "A", "--n", "2", "-o", str(out / "d.csv")],
        "sld": ["sld", "--modes", str(root / "m.csv"), "--teeth", "2", "--immersion", "0.5",
                "--rpm", "5000:9000:20", "--material", "Al7075-T6", "-o", str(out / "l.csv"),
                "--plot", str(out / "l.png")],
    }[command]  # fmt: skip
    if option in base:
        i = base.index(option)
        return [*base[: i + 1], value, *base[i + 2 :]]
    return [*base, option, value]


_EDGE_OPTIONS = {
    "identify": ("--modes", "--fmin", "--fmax", "--window-end", "--record-s", "--jobs"),
    "simulate": ("--n", "--fmax", "--noise", "--impacts", "--double-hits", "--seed"),
    "predict": ("--fmax", "--df"),
    "design-tests": ("--n", "--seed"),
    "sld": ("--immersion", "--kt", "--kr", "--max-lobe", "--safety", "--teeth", "--rpm"),
}
EDGE_OPTIONS = [(c, o) for c, options in _EDGE_OPTIONS.items() for o in options]


@FUZZ
@given(data=st.data())
def test_numeric_option_edges(
    tmp_path: Path, quick_inputs: Path, capsys: pytest.CaptureFixture[str], data: st.DataObject
) -> None:
    command, option = data.draw(st.sampled_from(EDGE_OPTIONS))
    value = data.draw(EDGE_VALUES)
    out = tmp_path / "out"
    if out.exists():
        shutil.rmtree(out)
    out.mkdir()
    argv = _edge_argv(quick_inputs, out, command, option, value)
    capsys.readouterr()
    code: int | str | None = 0
    try:
        main(argv)
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert code in (0, 2), err
    if code == 2:
        assert list(out.iterdir()) == [], f"written although refused: {err}"
        if not err.startswith("Usage"):  # click's own usage errors name the option too
            lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("warning")]
            assert len(lines) == 1, err
            assert lines[0].startswith("error: "), err


@pytest.mark.slow
@FUZZ
@given(
    value=st.floats(min_value=1.0001e7, allow_nan=False)
    | st.floats(max_value=0.000999, allow_nan=False)
    | st.sampled_from([math.nan, 2.0**64])
)
def test_check_constant_speed_and_feed_bounded(tmp_path: Path, value: float) -> None:
    """``check --rpm/--feed`` (used where the program states none) is checked even when unused.

    The bound is the toolpath readers' own: a program's S or F above 1e7 is refused.
    """
    from robolobe.plan.check import check_program

    for what in ("rpm", "feed"):
        with pytest.raises(
            InputError, match=rf"^--{what}: expected a positive {what} of 0\.001 to 1e\+07"
        ):
            check_program(EX / "pocket.nc", EX / "job_A_pocket.toml", **{what: value})


@settings(FUZZ, max_examples=4)
@given(n=st.integers(257, 2**70), command=st.sampled_from(["batch", "identify", "diagnose"]))
def test_worker_counts_bounded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], n: int, command: str
) -> None:
    """``--workers``/``--jobs`` above 256 (``2**64`` typed for 2) is refused, nothing written."""
    out = tmp_path / f"out{n}"
    argv = {
        "batch": ["batch", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"),
                  "-o", str(out), "--workers", str(n), "--table-only"],
        "identify": ["identify", str(tmp_path / "camp"), "-o", str(out), "--jobs", str(n)],
        "diagnose": ["diagnose", str(tmp_path / "camp"), "--json", str(out), "--jobs", str(n)],
    }[command]  # fmt: skip
    err = _refused(argv, "workers" if command == "batch" else "--jobs", capsys)
    assert "expected" in err
    assert not out.exists()
