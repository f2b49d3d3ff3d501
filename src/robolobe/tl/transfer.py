"""Make a robot's mode predictor from a few hammer tests: the one transfer policy.

:func:`transfer` is what ``robolobe transfer`` runs and what
``robolobe.transfer`` is in Python. Which predictor it makes (the default is
the best validated one, studies/tl_graybox.py and studies/plan_safety.py):

- ``robot`` given, no ``source``: ``"corrected-twin"``, the robot file's twin
  calibrated to the tests plus a cross-validated learned correction
  (:class:`~robolobe.tl.residual.CorrectedTwin`; plans robustly on its own
  calibrated spread);
- ``method="twin-calibration"``: the calibrated robot file alone
  (:class:`~robolobe.tl.graybox.TwinCalibration`);
- ``source`` given (a network, e.g. the shipped ``"A"``): ``"network"``, the
  seed paper's transfer with frozen layers
  (:func:`~robolobe.tl.estimator.transfer_network`).

Measured modes the robot file's twin lacks (a servo, a spindle bracket) are
data: each method keeps them as extra modes interpolated over posture with
their own spread (:mod:`robolobe.tl.extra_modes`), which plans see; the
network learns the others (with a robot given, so that its twin tells them
apart).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from robolobe._frf_checks import robot_mode_mass_problem
from robolobe.errors import InputError, InputTypeError
from robolobe.robots import Robot, load_robot
from robolobe.tl.dataset import ModalDataset, check_dataset, dataset_from_frame
from robolobe.tl.estimator import ModalPredictor, transfer_network
from robolobe.tl.graybox import DEFAULT_PARAMS, TwinCalibration
from robolobe.tl.residual import CorrectedTwin

__all__ = [
    "METHODS",
    "MIN_POSTURES",
    "check_mode_masses",
    "checked_dataset",
    "default_method",
    "transfer",
]

METHODS: tuple[str, ...] = ("corrected-twin", "twin-calibration", "network")
"""The predictors :func:`transfer` makes."""
MIN_POSTURES: dict[str, int] = {"corrected-twin": 6, "twin-calibration": 6, "network": 8}
"""Fewest tested postures each method accepts (the twin's: one more than its
five lowest modes, so that a leave-one-posture-out check has data left)."""


def default_method(robot: object | None, source: object | None, method: str | None) -> str:
    """The method :func:`transfer` uses for these arguments (the policy, stated once).

    Raises
    ------
    InputError
        Neither a robot nor a source, or an unknown method.
    """
    if method is None:
        if source is not None:
            return "network"
        if robot is not None:
            return "corrected-twin"
        raise InputError(
            "expected a robot (the robot file to calibrate: the default predictor) or a "
            "source network to transfer",
            source="robot",
        )
    if method not in METHODS:
        raise InputError(f"expected one of {', '.join(METHODS)}, found {method!r}", "method")
    if source is not None and method != "network":
        given = (
            os.fspath(source) if isinstance(source, str | os.PathLike) else type(source).__name__
        )
        raise InputError(
            f"a source network is transferred by method 'network' only; expected no source "
            f"with method {method!r}, found {given!r}",
            source="source",
        )
    return method


def _frame(modal: pd.DataFrame | str | os.PathLike[str]) -> tuple[pd.DataFrame, str]:
    from robolobe.modal.modal_csv import read_modal_csv, validate_modal_frame

    if isinstance(modal, pd.DataFrame):  # the same checks as the file's (NaN, ranges)
        return validate_modal_frame(modal, "modal dataset"), "modal dataset"
    if not isinstance(modal, str | os.PathLike):
        raise InputTypeError("modal", "a modal.csv path or a pandas DataFrame", modal)

    return read_modal_csv(modal), os.fspath(modal)


def checked_dataset(
    df: pd.DataFrame,
    name: str,
    directions: Sequence[str],
    n_modes: int,
    robot: Robot | None,
    min_postures: int,
    every_mode: bool = True,
) -> ModalDataset:
    """The tests as a dataset, checked: enough postures, inside the robot's limits.

    Parameters
    ----------
    df : pandas.DataFrame
        A modal dataset frame (``modal.csv``).
    name : str
        The data's name in messages (its file).
    directions : sequence of str
        Driving-point directions kept.
    n_modes : int
        Modes per direction.
    robot : Robot, optional
        Postures are checked against its joint limits.
    min_postures : int
        Fewest postures accepted.
    every_mode : bool
        Each direction must have each of the ``n_modes`` modes (a network's
        outputs); False for the twin methods, where a direction may see fewer
        modes than the others (:func:`~robolobe.tl.dataset.check_dataset`).

    Raises
    ------
    InputError
        Too few postures, postures outside the limits, repeated postures, a
        mode no posture has, a driving-point mode lighter than the robot's end
        effector allows (:func:`check_mode_masses`); a TrustWarning for missing values.
    """
    if robot is not None:
        check_mode_masses(df, name, robot)
    ds = dataset_from_frame(df, directions=tuple(directions), n_modes=n_modes, source=name)
    check_dataset(
        ds,
        min_postures=min_postures,
        q_min_rad=None if robot is None else robot.q_min,
        q_max_rad=None if robot is None else robot.q_max,
        source=name,
        every_mode=every_mode,
    )
    return ds


_DIR_AXIS = {"x": 0, "y": 1, "z": 2}


def check_mode_masses(df: pd.DataFrame, name: str, robot: Robot) -> None:
    """Refuse a driving-point mode lighter than the robot's end effector allows (N/mm).

    A mode's tip-normalised modal mass ``k / (2 pi f)^2`` is no smaller than the
    end effector's effective mass at the TCP
    (:meth:`~robolobe.robots.model.Robot.tcp_effective_mass_kg`); a stiffness
    written in N/mm makes it 1000 times lighter
    (:func:`robolobe._frf_checks.robot_mode_mass_problem`).

    Raises
    ------
    InputError
        Naming the file, the posture, direction and mode, expected vs found.
    """
    if not {"dir", "f_hz", "k_N_per_m"} <= set(df.columns):
        return  # the dataset reader names the missing columns
    m_ee = robot.tcp_effective_mass_kg()
    dirs = df["dir"].astype(str).str.lower()
    f = pd.to_numeric(df["f_hz"], errors="coerce").to_numpy(dtype=np.float64)
    k = pd.to_numeric(df["k_N_per_m"], errors="coerce").to_numpy(dtype=np.float64)
    for i, d in enumerate(dirs):
        if len(d) != 2 or d[0] != d[1] or d[0] not in _DIR_AXIS:
            continue
        problem = robot_mode_mass_problem(f[i], k[i], float(m_ee[_DIR_AXIS[d[0]]]), d)
        if problem is not None:
            row = df.iloc[i]
            where = ", ".join(
                f"{c} {row[c]}" for c in ("posture_id", "dir", "mode") if c in df.columns
            )
            raise InputError(f"k_N_per_m ({where}) on robot {robot.name!r}: {problem}", source=name)


def _check_network_modes(
    df: pd.DataFrame, name: str, directions: Sequence[str], n_modes: int
) -> None:
    """Refuse a network transfer whose tests lack some of the network's modes.

    The network predicts ``n_modes`` modes per direction; a mode no test
    measured would be predicted from the source robot alone, with nothing of
    the target robot in it. Names the direction and the modes found, and
    what to do instead.

    Raises
    ------
    InputError
    """
    if not {"dir", "mode"} <= set(df.columns):
        return  # the dataset reader names the missing columns
    dirs = df["dir"].astype(str).str.lower()
    modes = pd.to_numeric(df["mode"], errors="coerce")
    for d in directions:
        found = sorted({int(m) for m in modes[dirs == d].dropna()})
        missing = [m for m in range(1, n_modes + 1) if m not in found]
        if missing:
            where = f"modes {found[0]}-{found[-1]}" if found else "no mode"
            raise InputError(
                f"direction {d!r}: the network predicts {n_modes} modes per direction, the tests "
                f"have {where} (mode {missing[0]} at no posture), so it would come from the "
                "source robot alone; use the default transfer (`robolobe transfer MODAL_CSV "
                "--robot ROBOT`: the calibrated twin takes the modes measured), or measure a "
                "band that holds five modes",
                source=name,
            )


def transfer(
    modal: pd.DataFrame | str | os.PathLike[str],
    *,
    robot: Robot | str | os.PathLike[str] | None = None,
    source: ModalPredictor | str | os.PathLike[str] | None = None,
    method: str | None = None,
    params: Sequence[str] = DEFAULT_PARAMS,
    n_frozen: int = 3,
    epochs: int | None = None,
    random_state: int = 0,
) -> CorrectedTwin | TwinCalibration | ModalPredictor:
    """Fit a robot's mode predictor to its hammer tests.

    Parameters
    ----------
    modal : pandas.DataFrame or path
        The tests' modal dataset (a ``modal.csv`` as ``robolobe identify``
        writes it, or its frame).
    robot : Robot or str or path, optional
        The robot: ``"A"``, ``"B"``, ``"C"`` or a robot file. The file to
        calibrate for the twin methods; for ``"network"`` the label and the
        joint-limit check.
    source : ModalPredictor or str or path, optional
        A fitted network to transfer from (``"A"``: the shipped one).
    method : {"corrected-twin", "twin-calibration", "network"}, optional
        Default: :func:`default_method`.
    params : sequence of str
        Twin methods: the parameter groups to calibrate
        (:data:`robolobe.tl.graybox.DEFAULT_PARAMS`).
    n_frozen : int
        Network: frozen layers (the seed: 3).
    epochs : int, optional
        Network: training epochs (default: the source's).
    random_state : int
        Seed of the random starts and of the network's training.

    Returns
    -------
    CorrectedTwin or TwinCalibration or ModalPredictor
        Fitted; ``save(path)`` writes it (``.npz``; the calibration a robot
        ``.toml``).

    Raises
    ------
    InputError
        No robot for a twin method, a source that is no network, too few
        postures, postures outside the robot's limits, a bad dataset.
    """
    method = default_method(robot, source, method)
    df, name = _frame(modal)
    rob = None
    if robot is not None:
        rob = robot if isinstance(robot, Robot) else load_robot(robot)
    if method == "network":
        if source is None:
            raise InputError("expected a source network for method 'network'", source="source")
        if isinstance(source, ModalPredictor):
            src = source
        else:
            from robolobe.tl.models import load_model

            loaded = load_model(os.fspath(source))
            if not isinstance(loaded, ModalPredictor):
                raise InputError(
                    f"expected a network model to transfer, found a corrected twin ({source})",
                    source="source",
                )
            src = loaded
        extra = None
        if rob is not None and {"dir", "mode", "posture_id", "f_hz"} <= set(df.columns):
            # modes the robot file's twin lacks (a servo, a bracket) would shift the rank
            # of the network's modes: modelled apart (robolobe.tl.extra_modes)
            from robolobe.tl.extra_modes import split_extra_modes

            df, extra = split_extra_modes(df, rob, src.directions)
        _check_network_modes(df, name, src.directions, int(src.n_modes))
        ds = checked_dataset(
            df, name, src.directions, int(src.n_modes), rob, MIN_POSTURES["network"]
        )
        kw: dict[str, Any] = {"n_frozen": n_frozen, "random_state": random_state}
        # the label is how the robot was named (a built-in key or a file), so that a
        # prediction's campaign can name it again; a Robot object gives its name
        if isinstance(robot, str | os.PathLike):
            kw["robot"] = os.fspath(robot)
        else:
            kw["robot"] = rob.name if rob is not None else Path(name).stem
        if epochs is not None:
            kw["epochs"] = epochs
        net = transfer_network(src, ds.q_rad, ds.y, **kw)
        if extra is not None and extra.n_tracks_:
            net.extra_ = extra
        return net
    if rob is None:
        raise InputError(
            f"expected the robot file to calibrate (A, B, C or a .toml) for method {method!r}",
            source="robot",
        )
    present = set(df["dir"].astype(str).str.lower()) if "dir" in df.columns else set()
    dirs = tuple(d for d in ("xx", "yy", "zz") if d in present) or ("xx", "yy")
    # the twin methods take as many modes per direction as the tests found (a small
    # robot may have fewer than five)
    n_modes = 5
    if "mode" in df.columns:
        modes = pd.to_numeric(df.loc[df["dir"].astype(str).str.lower().isin(dirs), "mode"])
        if len(modes) and np.isfinite(modes.max()):
            n_modes = int(min(5, modes.max()))
    checked_dataset(df, name, dirs, n_modes, rob, MIN_POSTURES[method], every_mode=False)
    groups = tuple(params)
    try:
        if method == "twin-calibration":
            return TwinCalibration(robot=rob, params=groups, random_state=random_state).fit(df)
        return CorrectedTwin(
            robot=rob, calibration={"params": groups}, random_state=random_state
        ).fit(df)
    except InputError as exc:
        if exc.source:
            raise
        raise InputError(exc.detail, source=name) from None
