"""End-to-end tests of robolobe train / transfer / predict / design-tests."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from robolobe.campaign import read_campaign, write_postures
from robolobe.cli import main as cli_main
from robolobe.modal.modal_csv import read_modal_csv, write_modal_csv
from robolobe.robots import load_robot
from robolobe.tl.twin_data import twin_modal_dataset
from robolobe.twin.designs import B_TEST_DEG, design_arrays, seed_design
from robolobe.twin.model import Twin


class _Result:
    def __init__(self, code: int, output: str) -> None:
        self.exit_code = code
        self.output = output


@pytest.fixture(scope="module")
def b_modal(tmp_path_factory):
    ids, q, roles = design_arrays(seed_design("B"))
    train = np.asarray(roles) == "train"
    ds = twin_modal_dataset(
        Twin(load_robot("B")),
        [i for i, t in zip(ids, train, strict=True) if t],
        q[train],
        rng=np.random.default_rng(0),
    )
    path = tmp_path_factory.mktemp("b") / "modal.csv"
    write_modal_csv(path, ds.to_frame())
    return path


@pytest.fixture
def run(capsys):
    """Run the robolobe CLI in-process like the console script (errors -> exit code)."""

    def _run(args):
        code = 0
        try:
            cli_main.main([str(a) for a in args])
        except SystemExit as exc:
            code = int(exc.code or 0)
        out = capsys.readouterr()
        return _Result(code, out.out + out.err)

    return _run


def test_transfer_then_predict_with_spread_and_frf(tmp_path, b_modal, run):
    model = tmp_path / "B.npz"
    res = run(
        [
            "transfer",
            str(b_modal),
            "--from",
            "A",
            "-o",
            str(model),
            "--robot",
            "B",
            "--epochs",
            "20",
        ]
    )
    assert res.exit_code == 0, res.output
    assert model.is_file()
    post = tmp_path / "postures.csv"
    write_postures(post, [f"T{i}" for i in range(1, 6)], np.radians(B_TEST_DEG))
    out = tmp_path / "pred.csv"
    res = run(["predict", str(model), str(post), "-o", str(out), "--frf", str(tmp_path / "frf")])
    assert res.exit_code == 0, res.output
    df = read_modal_csv(out)
    assert len(df) == 5 * 2 * 5
    for col in ("f_hz_std", "zeta_lo90", "k_N_per_m_hi90"):
        assert col in df.columns
    assert np.all(df["f_hz_lo90"] <= df["f_hz"])
    assert np.all(df["f_hz"] <= df["f_hz_hi90"])
    camp = read_campaign(tmp_path / "frf")
    assert camp.n_postures == 5
    assert camp.dirs == frozenset({"xx", "yy"})


def test_train_writes_a_model_with_holdout_calibration(tmp_path, b_modal, run):
    model = tmp_path / "src.npz"
    res = run(["train", b_modal, "-o", model, "--robot", "B", "--epochs", "5", "--members", "2"])
    assert res.exit_code == 0, res.output
    assert "spread factors" in res.output
    from robolobe.tl.estimator import ModalPredictor

    m = ModalPredictor.load(model)
    assert m.n_members == 2
    assert m.calibration == "holdout"
    assert len(m.train_q_rad_) == 16  # the seed's 80:20 split of 20 postures


def test_predict_with_shipped_model(tmp_path, run):
    post = tmp_path / "p.csv"
    write_postures(
        post, ["a", "b"], np.radians([[0, 10, -40, 0, 30, 0], [20, 30, -60, 90, -40, 10]])
    )
    res = run(["predict", "B", str(post), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 0, res.output
    assert len(pd.read_csv(tmp_path / "o.csv")) == 20


def test_too_few_postures_is_a_clear_error(tmp_path, b_modal, run):
    df = read_modal_csv(b_modal)
    few = df[df["posture_id"].isin(df["posture_id"].unique()[:4])]
    path = tmp_path / "few.csv"
    write_modal_csv(path, few)
    res = run(["transfer", str(path), "--from", "A", "-o", str(tmp_path / "m.npz")])
    assert res.exit_code == 2
    assert "at least 8 postures" in res.output
    assert "Traceback" not in res.output


def test_out_of_range_angles_are_rejected(tmp_path, b_modal, run):
    df = read_modal_csv(b_modal)
    df.loc[df["posture_id"] == df["posture_id"].iloc[0], "q2_deg"] = 170.0
    path = tmp_path / "bad.csv"
    write_modal_csv(path, df)
    res = run(["transfer", str(path), "--from", "A", "-o", str(tmp_path / "m.npz"), "--robot", "B"])
    assert res.exit_code == 2
    assert "q2" in res.output
    post = tmp_path / "p.csv"
    write_postures(post, ["x"], np.radians([[0, 170, -40, 0, 30, 0]]))
    res = run(["predict", "B", str(post), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 2
    assert not (tmp_path / "o.csv").exists()


def test_missing_modes_warn_and_extrapolation_warns(tmp_path, b_modal, run):
    df = read_modal_csv(b_modal)
    path = tmp_path / "gaps.csv"
    write_modal_csv(path, df.iloc[3:])
    res = run(
        ["transfer", str(path), "--from", "A", "-o", str(tmp_path / "m.npz"), "--epochs", "5"]
    )
    assert res.exit_code == 0, res.output
    assert "missing mode value" in res.output
    post = tmp_path / "p.csv"
    write_postures(post, ["far"], np.radians([[0, 74, -30, 0, 30, 0]]))
    res = run(["predict", str(tmp_path / "m.npz"), str(post), "-o", str(tmp_path / "o.csv")])
    assert res.exit_code == 0, res.output
    assert "outside the training range" in res.output


@pytest.mark.slow
def test_design_tests_and_augment(tmp_path, run):
    out = tmp_path / "d.csv"
    res = run(["design-tests", "C", "--n", "6", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "fill distance" in res.output
    assert len(pd.read_csv(out)) == 6
    res = run(
        ["design-tests", "C", "--n", "3", "--augment", str(out), "-o", str(tmp_path / "more.csv")]
    )
    assert res.exit_code == 0, res.output
    assert "6 existing postures" in res.output
    res = run(["design-tests", "C", "--n", "0", "-o", str(tmp_path / "x.csv")])
    assert res.exit_code == 2


@pytest.mark.slow
def test_default_transfer_makes_a_corrected_twin_a_job_plans_on(tmp_path, b_modal, run):
    """The documented one-liner: ``transfer modal.csv --robot B -o OUT.npz``, then a job
    with ``[robot] model = "OUT.npz"`` plans on the calibrated, corrected twin."""
    import json
    import re
    import subprocess
    import sys
    from importlib import resources
    from pathlib import Path

    from robolobe.tl.models import load_model
    from robolobe.tl.residual import CorrectedTwin

    out = tmp_path / "B_pred.npz"
    res = run(["transfer", b_modal, "--robot", "B", "-o", out, "--params", "stiffness,damping"])
    assert res.exit_code == 0, res.output
    # quiet by default: the headline, what the correction does, how to plan on it
    text = " ".join(res.output.split())
    assert "a corrected twin of B from" in text
    assert "learned correction:" in text
    advice = f'plan on it: [robot] name = "B", model = "{out}"'
    assert "".join(advice.split()) in "".join(text.split())  # wrapped at any space
    assert not re.search(r"^\s+k1 x", res.output, re.M)  # each parameter only with -v
    assert "correction of log f" not in text
    model = load_model(out)
    assert isinstance(model, CorrectedTwin)
    # the planning spread's calibration on held-out tests, as stored in the file
    m = re.search(
        r"spread \(robust plans\): calibrated on held-out tests \(scale f x([\d.]+), zeta "
        r"x([\d.]+), k x([\d.]+)\); cross-validated share of held-out tests within 2 sigma, "
        r"f/zeta/k: (\S+) % \(stated 95\.4 %",
        text,
    )
    assert m, text
    np.testing.assert_allclose([float(v) for v in m.groups()[:3]], model.spread_scale_, atol=0.006)
    shown = [float("nan") if v == "-" else float(v) / 100 for v in m.group(4).split("/")]
    np.testing.assert_allclose(shown, model.spread_cover_, atol=0.006)
    post = tmp_path / "postures.csv"
    write_postures(post, [f"T{i}" for i in range(1, 6)], np.radians(B_TEST_DEG))
    res = run(["predict", out, post, "-o", tmp_path / "pred.csv"])
    assert res.exit_code == 0, res.output
    pred = read_modal_csv(tmp_path / "pred.csv")
    assert len(pred) == 5 * 2 * 5
    assert np.all(pred["f_hz_lo90"] <= pred["f_hz"])
    # a .toml output is the calibrated robot file only: say so instead of guessing
    res = run(["transfer", b_modal, "--robot", "B", "-o", tmp_path / "B.toml"])
    assert res.exit_code == 2
    assert "twin-calibration" in res.output
    # -v: every fitted parameter, with what the names stand for
    toml = tmp_path / "B_cal.toml"
    args = ["--method", "twin-calibration", "--params", "stiffness", "-o", toml, "-v"]
    res = run(["transfer", b_modal, "--robot", "B", *args])
    assert res.exit_code == 0, res.output
    assert len(re.findall(r"^\s+k[1-6] x\d\.\d{3} \(\+- ", res.output, re.M)) == 6, res.output
    assert "joint stiffness" in res.output
    advice = f'plan on it: [robot] name = "{toml}", model = "twin"'
    assert "".join(advice.split()) in "".join(res.output.split())
    # neither a robot to calibrate nor a network to transfer
    res = run(["transfer", b_modal, "-o", tmp_path / "x.npz"])
    assert res.exit_code == 2
    assert "--robot" in res.output
    ex = Path(str(resources.files("robolobe.data").joinpath("examples")))
    text = (ex / "job_B_contour.toml").read_text(encoding="utf-8")
    text = re.sub(r"(?m)^model = .*$", f'model = "{out.name}"', text)
    job = tmp_path / "job.toml"
    job.write_text(text, encoding="utf-8")
    cmd = [sys.executable, "-m", "robolobe.cli.main", "plan", str(ex / "contour.apt")]
    r = subprocess.run(
        [*cmd, "--job", str(job), "-o", "plan_out"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert r.returncode == 0, r.stderr
    summary = json.loads((tmp_path / "plan_out" / "summary.json").read_text())
    assert summary["mode_source"] == f"corrected twin {out.name}"
    # the bundled job leaves plan.robust unset: robust on the model's calibrated spread
    assert summary["robust"] is True
    assert summary["robust_by_default"] is True
    assert "calibrated prediction-error spread" in summary["robust_bound"]["spread_from"]


def test_transfer_line_names_the_gears_that_stiffen_under_load():
    """The calibration's load stiffening is listed where found (>= 0.05 per 1e4 N m),
    not among the factors (its 0 is no change, not a factor of 0)."""
    import pandas as pd

    from robolobe.cli.tl import _largest_changes, _load_stiffening

    table = pd.DataFrame(
        {
            "param": ["k2", "d6", "c1x", "l2", "l3", "l5"],
            "value": [1.2, 0.5, 0.01, 0.743, 0.0, 0.04],
            "unit": ["x", "x", "m", "per 1e4 N m", "per 1e4 N m", "per 1e4 N m"],
            "std": [0.1, 0.1, 0.01, 0.1, 0.1, 0.1],
        }
    )
    assert _load_stiffening(table) == (
        "; gears stiffer under load (per 1e4 N m of gravity torque): l2 +0.743"
    )
    assert _largest_changes(table, n=2) == "d6 x0.500, k2 x1.200"
    assert _load_stiffening(table[table["unit"] != "per 1e4 N m"]) == ""
