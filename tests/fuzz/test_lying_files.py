"""Structured files that lie: deep, oversized, mistyped, truncated or inconsistent (hypothesis).

The classes:

* **nesting**: TOML (robot, job, campaign, effects) and JSON (model
  metadata, plan records) nested far deeper than any robolobe file;
* **types**: a value of another JSON type where the writer put a table, a
  string or a number (a list for a table, a number for a hash);
* **model files**: cut at any byte, arrays declaring more data than they
  hold, values no fit could give (negative variances, a correlation of 1,
  infinite weights, a covariance that is not positive semi-definite), or a
  model made for another robot than the one it is used with.

Every case ends in a result or one :class:`robolobe.errors.RobolobeError`
naming the file (never another exception, never a silent acceptance of a
lie).
"""

from __future__ import annotations

import io
import json
import shutil
import sys
import warnings
import zipfile
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.errors import InputError, RobolobeError

ROOT = Path(__file__).resolve().parents[2]
EX = Path(str(resources.files("robolobe.data").joinpath("examples")))
MODELS = Path(str(resources.files("robolobe.data").joinpath("models")))
FUZZ = settings(
    max_examples=20,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3)
    ),
    max_leaves=8,
)


def _refused_naming(exc: BaseException, *names: str) -> None:
    assert isinstance(exc, RobolobeError), f"{type(exc).__name__}: {exc}"
    msg = str(exc)
    assert "\n" not in msg.strip(), msg
    assert any(n in msg for n in names), msg


# ------------------------------------------------------------------ nesting
def _nested_toml(depth: int, style: str) -> str:
    if style == "array":
        return "x = " + "[" * depth + "1" + "]" * depth + "\n"
    if style == "inline":
        return "x = " + "{a = " * depth + "1" + "}" * depth + "\n"
    return "".join(f"[{'.'.join(['t'] * (k + 1))}]\n" for k in range(depth)) + "v = 1\n"


def _toml_readers(tmp: Path) -> dict[str, Any]:
    from robolobe.campaign import read_campaign
    from robolobe.plan.job import load_job
    from robolobe.robots import load_robot
    from robolobe.twin.effects_file import read_effects

    def campaign(text: str) -> Any:
        d = tmp / "camp"
        d.mkdir(exist_ok=True)
        (d / "campaign.toml").write_text('robot = "B"\n' + text)
        return read_campaign(d)

    def file_reader(name: str, read: Any) -> Any:
        def run(text: str) -> Any:
            f = tmp / name
            f.write_text(text)
            return read(f)

        return run

    robot_text = (resources.files("robolobe.data") / "robots" / "A.toml").read_text()
    job_text = (EX / "job_A_pocket.toml").read_text()
    return {
        "robot": (file_reader("r.toml", lambda f: load_robot(str(f))), robot_text, "r.toml"),
        "job": (file_reader("j.toml", load_job), job_text, "j.toml"),
        "campaign": (campaign, "", "campaign.toml"),
        "effects": (
            file_reader("e.toml", read_effects),
            'format = "robolobe-effects/1"\n',
            "e.toml",
        ),
    }


@pytest.mark.parametrize("kind", ["robot", "job", "campaign", "effects"])
@FUZZ
@given(
    depth=st.integers(33, 3000) | st.integers(10_000, 60_000),
    style=st.sampled_from(["array", "inline", "tables"]),
)
def test_deep_toml_is_refused(tmp_path: Path, kind: str, depth: int, style: str) -> None:
    read, base, name = _toml_readers(tmp_path)[kind]
    if style == "tables":
        depth = min(depth, 200)  # [t.t.t...] headers grow quadratically
    with pytest.raises(RobolobeError) as info:
        read(base + _nested_toml(depth, style))
    _refused_naming(info.value, name)


@FUZZ
@given(depth=st.integers(33, 100_000), opener=st.sampled_from(["[", '{"a":']))
def test_deep_json_is_refused(depth: int, opener: str) -> None:
    from robolobe._documents import parse_json

    closer = "]" if opener == "[" else "}"
    with pytest.raises(InputError, match="nested") as info:
        parse_json('{"a": ' + opener * depth + "1" + closer * depth + "}", "m.npz[meta]")
    _refused_naming(info.value, "m.npz")


# --------------------------------------------------------------- model files
@pytest.fixture(scope="module")
def model_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A shipped network (A) and a corrected twin of robot B fitted here."""
    sys.path.insert(0, str(ROOT / "studies"))
    from robolobe.robots import load_robot
    from robolobe.tl.design import design_postures
    from robolobe.tl.graybox import TwinCalibration
    from robolobe.tl.residual import CorrectedTwin
    from robolobe.tl.twin_data import twin_modal_dataset
    from robolobe.twin import Twin
    from robolobe.twin.designs import TESTED_RANGES_DEG

    base = load_robot("B")
    rng = np.random.default_rng(4)
    q = design_postures(base, 10, rng=rng, ranges_deg=TESTED_RANGES_DEG["B"]).q_rad
    ds = twin_modal_dataset(Twin(base), [f"D{i}" for i in range(10)], q, rng=rng)
    cal = TwinCalibration(robot=base, params=("stiffness",)).fit_dataset(ds)
    out = tmp_path_factory.mktemp("models")
    ct = CorrectedTwin(robot=base, prefit=cal).fit_dataset(ds).save(out / "B_ct.npz")
    net = out / "A_net.npz"
    shutil.copy(MODELS / "A.npz", net)
    return {"net": net, "ct": ct}


def _arrays(p: Path) -> dict[str, np.ndarray]:
    with np.load(p, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _load(p: Path) -> Any:
    from robolobe.tl.models import load_model

    return load_model(p)


@pytest.mark.parametrize("kind", ["net", "ct"])
@FUZZ
@given(cut=st.floats(0.0, 0.9999))
def test_truncated_model_refused(
    tmp_path: Path, model_files: dict[str, Path], kind: str, cut: float
) -> None:
    raw = model_files[kind].read_bytes()
    f = tmp_path / "m.npz"
    f.write_bytes(raw[: int(len(raw) * cut)])
    with pytest.raises(RobolobeError) as info:
        _load(f)
    _refused_naming(info.value, "m.npz")


@FUZZ
@given(
    shape=st.lists(st.integers(1, 10**6), min_size=1, max_size=4).filter(
        lambda s: int(np.prod(s, dtype=object)) > 16
    ),
    dtype=st.sampled_from(["<f8", "<f4", "<i8", "<c16"]),
)
def test_declared_array_larger_than_stored_refused(
    tmp_path: Path, shape: list[int], dtype: str
) -> None:
    from robolobe._npz import read_npz

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buf, {"descr": dtype, "fortran_order": False, "shape": tuple(shape)}
    )
    buf.write(b"\0" * 16)
    f = tmp_path / "big.npz"
    with zipfile.ZipFile(f, "w") as z:
        z.writestr("meta.npy", buf.getvalue())
    with pytest.raises(InputError, match="declares") as info:
        read_npz(f)
    _refused_naming(info.value, "big.npz")


@pytest.mark.parametrize("kind", ["net", "ct"])
@FUZZ
@given(data=st.data())
def test_model_metadata_of_another_type(
    tmp_path: Path, model_files: dict[str, Path], kind: str, data: st.DataObject
) -> None:
    a = _arrays(model_files[kind])
    meta = json.loads(str(a["meta"]))
    path = [data.draw(st.sampled_from(sorted(meta)))]
    node = meta[path[0]]
    if isinstance(node, dict) and node and data.draw(st.booleans()):
        path.append(data.draw(st.sampled_from(sorted(node))))
    target = meta
    for k in path[:-1]:
        target = target[k]
    target[path[-1]] = data.draw(json_values)
    a["meta"] = np.array(json.dumps(meta))
    f = tmp_path / "m.npz"
    np.savez(f, **a)
    try:
        model = _load(f)
    except RobolobeError as exc:
        _refused_naming(exc, "m.npz")
        return
    # accepted: the field was optional or descriptive; the model must still predict
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # trust warnings are not the point here
        pred = model.predict(model.train_q_rad_[:2])
    assert np.all(np.isfinite(pred.values) | np.isnan(pred.values))


#: Entries of a corrected twin and values no fit gives them.
CT_LIES = {
    "rho": [1.0, 1.5, -0.1, np.inf, np.nan],
    "length_scales": [0.0, -1.0, np.inf, np.nan],
    "alpha": [-0.5, 1.5, np.nan],
    "scale": [-1.0, 0.0, np.inf],
    "loo_rmse": [-1.0, np.inf],
    "loo_var_mean": [0.0, -1.0],
    "train_q_rad": [np.inf, 100.0],
    "cal_theta": [50.0, -50.0, 700.0, np.inf],  # log factors: e^700 breaks the eigen-solve
}


@FUZZ
@given(data=st.data())
def test_corrected_twin_values_that_break_the_math(
    tmp_path: Path, model_files: dict[str, Path], data: st.DataObject
) -> None:
    a = _arrays(model_files["ct"])
    key = data.draw(st.sampled_from(sorted(CT_LIES)))
    v = a[key].astype(float).copy()
    i = data.draw(st.integers(0, v.size - 1))
    v.flat[i] = data.draw(st.sampled_from(CT_LIES[key]))
    a[key] = v
    f = tmp_path / "m.npz"
    np.savez(f, **a)
    with pytest.raises(InputError, match=key.removeprefix("cal_")) as info:
        _load(f)
    _refused_naming(info.value, "m.npz")


@pytest.mark.parametrize("kind", ["net", "ct"])
def test_multi_turn_training_postures_accepted(
    tmp_path: Path, model_files: dict[str, Path], kind: str
) -> None:
    """B's axis 4 turns +-400 deg (6.98 rad): a model trained there is a model, not a lie."""
    a = _arrays(model_files[kind])
    q = a["train_q_rad"].astype(float).copy()
    q[0, 3] = np.radians(400.0)
    a["train_q_rad"] = q
    f = tmp_path / "m.npz"
    np.savez(f, **a)
    model = _load(f)
    assert np.isclose(model.train_q_rad_[0, 3], np.radians(400.0))
    q[0, 3] = np.radians(4000.0)  # beyond ten turns: no robot's axis
    a["train_q_rad"] = q
    np.savez(f, **a)
    with pytest.raises(InputError, match="train_q_rad"):
        _load(f)


@FUZZ
@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(1e-6, 10.0))
def test_covariance_not_positive_semidefinite(
    tmp_path: Path, model_files: dict[str, Path], seed: int, scale: float
) -> None:
    a = _arrays(model_files["ct"])
    n = a["cal_covariance"].shape[0]
    rng = np.random.default_rng(seed)
    m = rng.normal(size=(n, n))
    w, v = np.linalg.eigh(m + m.T)
    w[0] = -scale * max(1.0, float(np.max(np.abs(w))))  # at least one negative variance
    a["cal_covariance"] = (v * w) @ v.T
    f = tmp_path / "m.npz"
    np.savez(f, **a)
    with pytest.raises(InputError, match="covariance") as info:
        _load(f)
    _refused_naming(info.value, "m.npz")


def test_network_with_infinite_weights(tmp_path: Path, model_files: dict[str, Path]) -> None:
    a = _arrays(model_files["net"])
    a["W2"] = a["W2"].copy()
    a["W2"].flat[3] = np.inf
    f = tmp_path / "m.npz"
    np.savez(f, **a)
    with pytest.raises(InputError, match="W2"):
        _load(f)


# ------------------------------------------------------- a model of another robot
@pytest.mark.parametrize(("kind", "robot"), [("net", "B"), ("net", "C"), ("ct", "A"), ("ct", "C")])
def test_model_of_another_robot_refused(
    model_files: dict[str, Path], kind: str, robot: str
) -> None:
    from robolobe.plan.modes import mode_source
    from robolobe.robots import load_robot
    from robolobe.tl.models import check_model_robot

    rob = load_robot(robot)
    with pytest.raises(InputError, match="expected a model of robot"):
        check_model_robot(_load(model_files[kind]), rob, "--model")
    with pytest.raises(InputError, match=r"robot\.model"):
        mode_source(str(model_files[kind]), rob, robot)
    own = "A" if kind == "net" else "B"
    check_model_robot(_load(model_files[kind]), load_robot(own), "--model")  # its own: fine


def test_cli_model_of_another_robot(
    tmp_path: Path, model_files: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    from robolobe.cli.main import main

    post = tmp_path / "p.csv"
    post.write_text("posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\nP1,0,-60,90,0,30,0\n")
    for argv, option in (
        (["predict", str(model_files["ct"]), str(post), "--robot", "A", "-o", "x.csv"], "--robot"),
        (["design-tests", "A", "--n", "2", "--model", str(model_files["ct"]), "-o", "x.csv"],
         "--model"),
    ):  # fmt: skip
        argv[argv.index("x.csv")] = str(tmp_path / "x.csv")
        capsys.readouterr()
        with pytest.raises(SystemExit) as info:
            main(argv)
        err = capsys.readouterr().err
        assert info.value.code == 2, err
        assert err.startswith(f"error: {option}: expected a model of robot"), err
        assert not (tmp_path / "x.csv").exists()


# --------------------------------------------------------------- plan records
@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from robolobe.plan.job import load_job
    from robolobe.plan.pipeline import plan_path
    from robolobe.plan.report import write_outputs

    res = plan_path(EX / "pocket.nc", load_job(EX / "job_A_pocket.toml"), refine=False)
    return write_outputs(res, tmp_path_factory.mktemp("plan") / "p", plots=False, html_report=False)


@FUZZ
@given(data=st.data())
def test_tampered_plan_record(tmp_path: Path, plan_dir: Path, data: st.DataObject) -> None:
    from robolobe.plan.verify import read_plan

    d = tmp_path / "p"
    if d.exists():
        shutil.rmtree(d)
    shutil.copytree(plan_dir, d)
    summary = json.loads((d / "summary.json").read_text())
    where = data.draw(st.sampled_from(["top", "record", "job"]))
    node = {"top": summary, "record": summary["plan_record"], "job": summary["plan_record"]["job"]}
    target = node[where]
    key = data.draw(st.sampled_from(sorted(target)))
    target[key] = data.draw(json_values)
    (d / "summary.json").write_text(json.dumps(summary))
    try:
        read_plan(d, EX / "job_A_pocket.toml")
    except RobolobeError as exc:
        _refused_naming(exc, "summary.json", "waypoints.csv", "job_A_pocket.toml")


@FUZZ
@given(doc=json_values.filter(lambda v: not isinstance(v, dict)))
def test_plan_record_not_an_object(tmp_path: Path, plan_dir: Path, doc: Any) -> None:
    from robolobe.plan.verify import read_plan

    d = tmp_path / "p"
    if d.exists():
        shutil.rmtree(d)
    shutil.copytree(plan_dir, d)
    (d / "summary.json").write_text(json.dumps(doc))
    with pytest.raises(InputError) as info:
        read_plan(d)
    _refused_naming(info.value, "summary.json")


# --------------------------------------------------------------- the Python API
wrong = st.sampled_from([None, 3, 2.5, b"bytes", ["A"], {"a": 1}, object(), np.zeros(3)])


@FUZZ
@given(value=wrong)
def test_api_says_which_type_it_expected(value: Any) -> None:
    import robolobe as rl

    calls = [
        lambda v: rl.load_robot(v),
        lambda v: rl.load_job(v),
        lambda v: rl.plan_path(EX / "pocket.nc", v),
        lambda v: rl.identify(v),
        lambda v: rl.write_plan(v, "o"),
        lambda v: rl.write_campaign("c", v),
        lambda v: rl.compare_robots(EX / "pocket.nc", EX / "job_A_pocket.toml", [v]),
        lambda v: rl.transfer(v, robot="B"),
    ]
    for call in calls:
        with pytest.raises(TypeError) as info:  # InputTypeError is both
            call(value)
        assert "expected" in str(info.value)
        assert isinstance(info.value, RobolobeError), info.value


def test_api_accepts_paths_and_refuses_empty_robot_lists() -> None:
    import robolobe as rl

    res = rl.plan_path(EX / "pocket.nc", str(EX / "job_A_pocket.toml"), robot="A", refine=False)
    assert res.summary.robot == rl.load_robot("A").name
    with pytest.raises(InputError, match="at least one robot"):
        rl.compare_robots(EX / "pocket.nc", EX / "job_A_pocket.toml", [])
    with pytest.raises(InputError, match="no such file"):
        rl.compare_robots(EX / "pocket.nc", EX / "job_A_pocket.toml", "A,nothere.toml")


# ---------------------------------------------------------- UFF files cut or spliced
@pytest.fixture(scope="module")
def uff_campaign(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from robolobe.campaign import write_campaign
    from robolobe.robots import load_robot
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.model import Twin

    q = np.radians([[0, 10, -20, 0, 20, 0], [30, 0, -30, 10, 30, 5], [-20, 20, -40, 0, 10, 0]])
    camp = simulate_campaign(
        Twin(load_robot("B")).receptance, "B", ["1", "2", "3"], q,
        rng=np.random.default_rng(0), exact=True, dirs=("xx", "xy", "yy", "zz"), fmax_hz=10.0,
    )  # fmt: skip
    out = tmp_path_factory.mktemp("uff") / "camp"
    write_campaign(out, camp, fmt="uff")
    return out


@FUZZ
@given(data=st.data())
def test_uff_cut_or_spliced_is_refused_or_exact(
    tmp_path: Path, uff_campaign: Path, data: st.DataObject, caplog: pytest.LogCaptureFixture
) -> None:
    """A UFF file with lines lost, cut and closed, or repeated: refused, or every value exact.

    Accepted files must give exactly the original values of every direction
    they hold, and a posture left with fewer directions than the others is
    said (a warning naming the file).
    """
    from robolobe.campaign import read_campaign

    d = tmp_path / "c"
    if d.exists():
        shutil.rmtree(d)
    shutil.copytree(uff_campaign, d)
    f = d / "frf" / "2.uff"
    lines = f.read_bytes().splitlines(keepends=True)
    i = data.draw(st.integers(1, len(lines) - 1))
    op = data.draw(st.sampled_from(["drop", "cut-and-close", "repeat"]))
    if op == "drop":
        n = data.draw(st.integers(1, 12))
        lines = lines[:i] + lines[i + n :]
    elif op == "cut-and-close":
        lines = [*lines[:i], b"    -1\n"]
    else:
        n = data.draw(st.integers(1, 12))
        lines = lines[: i + n] + lines[i : i + n] + lines[i + n :]
    f.write_bytes(b"".join(lines))
    original = read_campaign(uff_campaign).frfs[1].H
    caplog.clear()
    try:
        got = read_campaign(d).frfs[1].H
    except RobolobeError as exc:
        _refused_naming(exc, "2.uff")
        return
    have = np.isfinite(got).any(axis=0)
    np.testing.assert_array_equal(got[:, have], original[:, have])  # what is read is exact
    if (~have & np.isfinite(original).any(axis=0)).any():
        assert any("2.uff" in r.getMessage() for r in caplog.records), "directions lost silently"


# ------------------------------------------------------- TOML values of another type
toml_values = st.recursive(
    st.booleans() | st.integers(-(2**63), 2**63 - 1) | st.floats(allow_nan=False)
    | st.text(max_size=6),
    lambda inner: st.lists(inner, max_size=3)
    | st.dictionaries(st.text(min_size=1, max_size=5), inner, max_size=3),
    max_leaves=6,
)  # fmt: skip


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of a TOML document (tables and arrays of tables entered)."""
    out = []
    items = (
        doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else []
    )
    for k, v in items:
        out.append((*prefix, k))
        if isinstance(v, dict | list):
            out += _paths(v, (*prefix, k))
    return out


@pytest.mark.parametrize("kind", ["robot", "job", "campaign", "effects"])
@FUZZ
@given(data=st.data())
def test_toml_value_of_another_type(tmp_path: Path, kind: str, data: st.DataObject) -> None:
    """Any key of a valid file given a value of another type: a result or one named refusal."""
    import tomllib

    import tomli_w

    read, base, name = _toml_readers(tmp_path)[kind]
    if kind == "campaign":
        base = 'robot = "B"\nnotes = "x"\n[test]\nduration_s = 4.0\nwindow_end = 0.01\n'
    elif kind == "effects":
        base += '[[effects]]\nkind = "added_mass"\nmass_kg = 2.0\n'
    doc = tomllib.loads(base)
    path = data.draw(st.sampled_from(_paths(doc)))
    target = doc
    for k in path[:-1]:
        target = target[k]
    target[path[-1]] = data.draw(toml_values)
    try:
        read(tomli_w.dumps(doc))
    except RobolobeError as exc:
        _refused_naming(exc, name, "campaign.toml", "postures.csv", "B.toml")
