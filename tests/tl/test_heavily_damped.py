"""Transfer on a heavily damped robot (the example user robot, overdamped wrist modes).

The reference modes are solved here, independently of the twin's pole
routine: the quadratic eigenproblem ``(lambda^2 M + lambda C + K) x = 0`` by
``scipy.linalg.eig`` of its companion pencil, and the modal stiffness from
``scipy.linalg.eigh(K, M)``. An overdamped mode (two real poles ``p1, p2``)
is described as the calibration's convention says: ``w0 = sqrt(p1 p2)``,
``zeta = -(p1 + p2) / (2 w0)``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.linalg

from robolobe.errors import InputError
from robolobe.robots import load_robot, sample_postures
from robolobe.tl.dataset import ModalDataset
from robolobe.tl.graybox import TwinCalibration
from robolobe.tl.transfer import transfer
from robolobe.twin.params import apply_parameters
from robolobe.twin.system import nominal_system

MY_ROBOT = Path(__file__).resolve().parents[2] / "examples" / "robots" / "my_robot.toml"
STIFFNESS = np.array([1.08, 0.93, 1.1, 1.0, 1.0, 1.0])  # the truth's factors on the file
AXIS = {"xx": 0, "yy": 1, "zz": 2}


def _reference_modes(robot, q):
    """(f [Hz], zeta, k [N/m] per TCP axis) of every mode by rising natural frequency.

    Returns arrays of shape (n, 6), (n, 6), (n, 3, 6) and the count of
    overdamped modes per posture, shape (n,).
    """
    sys_ = nominal_system(robot, q)
    n, nd = len(q), sys_.n_dof
    M = sys_.M.reshape(n, nd, nd)
    K = np.broadcast_to(sys_.K, (n, nd, nd))
    C = np.broadcast_to(sys_.C, (n, nd, nd))
    J = sys_.J.reshape(n, 3, nd)
    f = np.empty((n, nd))
    z = np.empty((n, nd))
    k = np.empty((n, 3, nd))
    n_over = np.zeros(n, dtype=int)
    for i in range(n):
        a = np.block([[np.zeros((nd, nd)), np.eye(nd)], [-K[i], -C[i]]])
        b = np.block([[np.eye(nd), np.zeros((nd, nd))], [np.zeros((nd, nd)), M[i]]])
        lam = scipy.linalg.eigvals(a, b)
        cpx = lam[lam.imag > 1e-9 * np.abs(lam)]
        real = np.sort(lam[np.abs(lam.imag) <= 1e-9 * np.abs(lam)].real)
        half = real.size // 2
        lo, hi = real[::-1][:half], real[:half]  # smallest with largest magnitude
        w = np.r_[np.abs(cpx), np.sqrt(lo * hi)]
        zz = np.r_[-cpx.real / np.abs(cpx), -(lo + hi) / (2.0 * np.sqrt(lo * hi))]
        order = np.argsort(w)
        f[i], z[i] = w[order] / (2 * np.pi), zz[order]
        n_over[i] = half
        w2, phi = scipy.linalg.eigh(K[i], M[i])
        k[i] = w2[None, :] / (J[i] @ phi) ** 2
    return f, z, k, n_over


@pytest.fixture(scope="module")
def campaign():
    base = load_robot(MY_ROBOT)
    truth = apply_parameters(base, ("stiffness",), np.log(STIFFNESS))
    q = sample_postures(base, 14, rng=np.random.default_rng(7))
    f, z, k, n_over = _reference_modes(truth, q)
    dirs = ("xx", "yy", "zz")
    y = np.full((len(q), 3, 3, 3), np.nan)
    for j, d in enumerate(dirs):
        kd = k[:, AXIS[d], :3]
        seen = (kd < 3e8) & (z[:, :3] < 0.2)  # a peak a hammer test shows
        vals = np.stack([f[:, :3], z[:, :3], kd], axis=-1)
        y[:, j] = np.where(seen[..., None], vals, np.nan)
    ids = tuple(f"P{i + 1:02d}" for i in range(len(q)))
    return {"base": base, "q": q, "n_over": n_over, "ds": ModalDataset(ids, q, dirs, y)}


def test_calibrates_a_robot_with_overdamped_modes(campaign):
    # the case: the file's twin has an overdamped mode at some tested postures
    assert campaign["n_over"].sum() >= 1
    fit = TwinCalibration(robot=campaign["base"], params=("stiffness", "damping")).fit_dataset(
        campaign["ds"]
    )
    np.testing.assert_allclose(fit.factors_["stiffness"][:3], STIFFNESS[:3], rtol=0.02)
    assert fit.residual_rms_["f"] < 2e-3
    pred = fit.predict(campaign["q"])
    assert np.all(np.isfinite(pred.center))
    assert np.all(np.isfinite(pred.std))


def test_every_mode_overdamped_is_refused_naming_file_posture_joint(campaign, tmp_path):
    text = MY_ROBOT.read_text()
    out, k = [], 0.0
    for line in text.splitlines():
        m = re.match(r"stiffness_Nm_per_rad = (\S+)", line)
        if m:
            k = float(m.group(1))
        if line.startswith("damping_Nms_per_rad"):
            line = f"damping_Nms_per_rad = {0.029 * k:.6g}"  # ~0.9 x critical at 10 Hz
        out.append(line)
    heavy = tmp_path / "heavy.toml"
    heavy.write_text("\n".join(out) + "\n")
    with pytest.raises(InputError) as err:
        TwinCalibration(robot=str(heavy), params=("stiffness",)).fit_dataset(campaign["ds"])
    msg = str(err.value)
    assert "heavy.toml" in msg
    assert "posture 'P" in msg
    assert re.search(r"joint \d", msg)
    assert "every mode" in msg
    assert "damping_Nms_per_rad" in msg


def test_network_transfer_names_the_missing_modes(campaign):
    df = campaign["ds"].to_frame()
    with pytest.raises(InputError, match=r"direction 'xx'.*5 modes.*modes 1-3.*default transfer"):
        transfer(df, robot=str(MY_ROBOT), source="A")


def test_fewer_than_six_postures_refused(campaign):
    df = campaign["ds"].to_frame()
    five = df[df["posture_id"].isin(sorted(set(df["posture_id"]))[:5])]
    assert isinstance(five, pd.DataFrame)
    with pytest.raises(InputError, match="at least 6 postures"):
        transfer(five, robot=str(MY_ROBOT))


def test_mislabelled_directions_are_refused(campaign):
    ds = campaign["ds"]
    swapped = ModalDataset(ds.posture_ids, ds.q_rad, ("zz", "yy", "xx"), ds.y)
    with pytest.raises(InputError, match=r"direction '(xx|zz)'.*cannot fit.*factor of"):
        TwinCalibration(robot=campaign["base"], params=("stiffness", "damping")).fit_dataset(
            swapped
        )


def test_tests_of_another_robot_are_refused(campaign):
    with pytest.raises(InputError, match=r"cannot fit the measured modes.*posture 'P\d+'"):
        TwinCalibration(robot="C", params=("stiffness", "damping")).fit_dataset(campaign["ds"])


def _cli(args, capsys):
    from robolobe.cli import main as cli_main

    code = 0
    try:
        cli_main.main([str(a) for a in args])
    except SystemExit as exc:
        code = int(exc.code or 0)
    out = capsys.readouterr()
    return code, out.out + out.err


@pytest.mark.parametrize("case", ["swapped", "five"])
def test_cli_bad_campaigns_one_line_exit_2_nothing_written(case, campaign, tmp_path, capsys):
    from robolobe.modal.modal_csv import write_modal_csv

    ds = campaign["ds"]
    if case == "swapped":
        df = ModalDataset(ds.posture_ids, ds.q_rad, ("zz", "yy", "xx"), ds.y).to_frame()
        want = r"swapped\.csv: direction '(xx|zz)'.*posture 'P\d+'"
    else:
        df = ds.to_frame()
        df = df[df["posture_id"].isin(sorted(set(df["posture_id"]))[:5])]
        want = r"five\.csv: expected at least 6 postures"
    path = tmp_path / f"{case}.csv"
    write_modal_csv(path, df)
    out = tmp_path / "model.npz"
    code, text = _cli(
        [
            "transfer",
            path,
            "--robot",
            MY_ROBOT,
            "--method",
            "twin-calibration",
            "-o",
            out.with_suffix(".toml"),
        ],
        capsys,
    )
    assert code == 2
    errors = [ln for ln in text.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1
    assert re.search(want, errors[0])
    assert "Traceback" not in text
    assert not out.with_suffix(".toml").exists()
