"""Calibration of the built-in robots' joint stiffness, damping and end effector.

Robots A, B and C need joint stiffness, damping and an end effector that no
public source gives for these arms. This module holds the procedure that set
them (reproducible from a seed, :func:`calibrate_builtin`) and the report that
checks them against the seed paper's ranges (docs/references.md: seed paper in numbers):

1. Postures are drawn uniformly within the seed's tested joint ranges
   (Table 2, :data:`robolobe.twin.designs.TESTED_RANGES_DEG`), clipped to the
   robot's limits and its linear constraints
   (:func:`robolobe.robots.sample_postures`).
2. The end effector (spindle, holder, tool) is chosen per robot
   (:data:`END_EFFECTORS`, engineering estimates).
3. Stiffness: log-factors ``s_i`` on prior joint stiffnesses
   (:data:`PRIOR_STIFFNESS`, KUKA KR500 values scaled by robot class) are
   fitted so that the geometric mean over the postures of each of the five
   lowest modes seen at the TCP matches anchor frequencies from the seed's
   tables (:data:`TARGETS`), while the median modal stiffness of each stays
   below a cap, with a small ridge penalty on ``s`` (:func:`fit_stiffness`).
4. Damping: with mass-normalised undamped shapes ``phi``, modal damping is
   ``zeta_r ~ sum_i c_i phi_ir^2 / (2 w_r)``, linear in the joint damping
   ``c``; ``c >= c_min`` is fitted by bounded least squares to one target
   damping ratio (:func:`fit_damping`).
5. :func:`calibration_report` then checks the exact damped modes of the
   result: per-mode frequency, damping and modal-stiffness ranges over the
   postures and the fraction inside the target bands.

"Seen at the TCP" is :func:`robolobe.twin.modes.seen_mask`: with a tool on
the joint-6 axis, joint 6 never moves the TCP and joint 4 does not either at
a stretched wrist (q5 = 0), so the five lowest seen modes are not always
the five lowest modes.

Limits of a six-spring model (measured by ``studies/calibration.py``): for
these link masses a mode that swings the arm at 12-20 Hz has a modal
stiffness of 2-5e6 N/m, so the seed's upper modal stiffness (2.7e6 N/m) and
its upper frequencies cannot both be met; the fit trades them. The values in
``src/robolobe/data/robots/{A,B,C}.toml`` come from ``studies/calibration.py``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, lsq_linear

from robolobe._matching import match_modes
from robolobe._threads import with_one_blas_thread
from robolobe.errors import InputError
from robolobe.robots import RigidBody, Robot, sample_postures
from robolobe.robots.limits import as_postures
from robolobe.robots.transforms import pose_from_xyz_zyx
from robolobe.twin.designs import TESTED_RANGES_DEG
from robolobe.twin.modes import (
    SEEN_RATIO,
    compute_modes,
    lowest_seen,
    seen_mask,
    undamped_modes,
)
from robolobe.twin.params import COM_UNIT_M, BodyMassModel, body_indices
from robolobe.twin.seed_tables import SeedTable
from robolobe.twin.system import load_stiffened, nominal_system

__all__ = [
    "END_EFFECTORS",
    "FIT_POSTURES",
    "FIT_SEED",
    "PRIOR_STIFFNESS",
    "TARGETS",
    "TOOLS",
    "CalibrationReport",
    "CalibrationTargets",
    "ModeSummary",
    "calibrate",
    "calibrate_builtin",
    "calibration_report",
    "fit_damping",
    "fit_stiffness",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class CalibrationTargets:
    """Bands the calibrated modes should fall in, and the fit's anchors.

    Attributes
    ----------
    f_band_hz : tuple of 2 floats
        Band for the natural frequencies of the lowest seen modes [Hz].
    zeta_band : tuple of 2 floats
        Band for their damping ratios (fraction).
    k_band_N_per_m : tuple of 2 floats
        Band for their modal stiffness in the dominant TCP direction [N/m].
    f_anchor_hz : tuple of floats
        Geometric-mean frequency over the postures of each of the lowest
        seen modes, the stiffness fit's target [Hz]; its length is the number
        of calibrated modes.
    zeta_target : float
        Damping ratio the damping fit aims at for every calibrated mode.
    k_cap_N_per_m : float
        The stiffness fit penalises a per-mode median modal stiffness above
        this [N/m].
    source : str
        Where the anchors come from.
    """

    f_band_hz: tuple[float, float]
    zeta_band: tuple[float, float]
    k_band_N_per_m: tuple[float, float]
    f_anchor_hz: tuple[float, ...]
    zeta_target: float
    k_cap_N_per_m: float = 2.5e6
    source: str = ""

    @property
    def n_modes(self) -> int:
        """Number of calibrated (lowest seen) modes."""
        return len(self.f_anchor_hz)


TARGETS: dict[str, CalibrationTargets] = {
    "A": CalibrationTargets(
        f_band_hz=(5.0, 40.0),
        zeta_band=(0.002, 0.07),
        k_band_N_per_m=(1e4, 3e6),
        f_anchor_hz=(7.5, 10.5, 15.0, 22.0, 32.0),
        zeta_target=0.02,
        source=(
            "(est.) like B: the seed gives no table for A "
            "(docs/references.md: seed paper in numbers)"
        ),
    ),
    "B": CalibrationTargets(
        f_band_hz=(5.0, 40.0),
        zeta_band=(0.002, 0.07),
        k_band_N_per_m=(1e4, 3e6),
        f_anchor_hz=(7.3, 11.3, 14.3, 21.4, 31.1),
        zeta_target=0.019,
        source="seed Table 4 (B, Y direction): mean f of postures 1-3 and mean zeta",
    ),
    "C": CalibrationTargets(
        f_band_hz=(8.0, 32.0),
        zeta_band=(0.002, 0.07),
        k_band_N_per_m=(1e4, 3e6),
        f_anchor_hz=(12.3, 14.1, 21.2, 22.5, 25.3),
        zeta_target=0.013,
        source="seed Table 7 (C): mean f of postures 1-3 and mean zeta",
    ),
}
"""Calibration targets per built-in robot (bands: docs/references.md: seed paper in numbers)."""

_GENERIC_TARGETS = CalibrationTargets(
    f_band_hz=(5.0, 40.0),
    zeta_band=(0.002, 0.07),
    k_band_N_per_m=(1e4, 3e6),
    f_anchor_hz=(7.5, 11.0, 15.0, 21.0, 31.0),
    zeta_target=0.02,
    source="docs/references.md: seed paper in numbers (five modes in 5-40 Hz)",
)

PRIOR_STIFFNESS: dict[str, tuple[float, ...]] = {
    # KUKA KR500 joint stiffness from modal testing (docs/references.md: robots)
    "A": (2.3e6, 8.6e6, 2.8e6, 3.0e6, 0.2e6, 0.9e6),
    # x1.5 on axes 1-3 and 5 (650 kg class)
    "B": (3.45e6, 12.9e6, 4.2e6, 3.0e6, 0.3e6, 0.9e6),
    # x0.5 (1 t class)
    "C": (1.15e6, 4.3e6, 1.4e6, 1.5e6, 0.1e6, 0.45e6),
}
"""Prior joint stiffnesses [N m/rad] the stiffness fit starts from and is pulled towards."""


TOOLS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    # (est.) spindle bracket: the spindle axis is parallel to the flange (joint-6) axis,
    # 0.20 m off it, tool tip 0.45 m out from the flange (robot milling spindles commonly sit
    # 0.10-0.25 m off-axis, 0.3-0.5 m out), so that joints 4 and 6 move the TCP
    "A": ((0.20, 0.0, 0.45), (0.0, 0.0, 0.0)),
    "B": ((0.20, 0.0, 0.45), (0.0, 0.0, 0.0)),
    # (est.) smaller bracket for the 60 kg-payload IRB 4400: 0.15 m off-axis, 0.35 m out
    "C": ((0.15, 0.0, 0.35), (0.0, 0.0, 0.0)),
}
"""TCP in the flange per robot: ``(xyz_m, zyx_deg)`` as in the robot file's ``[tool]``."""

END_EFFECTORS: dict[str, RigidBody] = {
    # (est.) 125 kg spindle (cylinder r = 0.11 m, 0.40 m long on the tool axis, ending 0.10 m
    # behind the tool tip) plus a 25 kg bracket plate halfway between the flange centre and
    # the spindle body; COM and inertia about the COM in the TCP frame
    "A": RigidBody(
        150.0,
        np.array([-0.017, 0.0, -0.313]),
        np.array([[2.44, 0.0, -0.16], [0.0, 2.65, 0.0], [-0.16, 0.0, 1.25]]),
    ),
    "B": RigidBody(
        150.0,
        np.array([-0.017, 0.0, -0.313]),
        np.array([[2.44, 0.0, -0.16], [0.0, 2.65, 0.0], [-0.16, 0.0, 1.25]]),
    ),
    # (est.) 45 kg spindle (r = 0.08 m, 0.30 m long, 0.10 m behind the tip) and a 10 kg bracket
    "C": RigidBody(
        55.0,
        np.array([-0.014, 0.0, -0.259]),
        np.array([[0.54, 0.0, -0.03], [0.0, 0.59, 0.0], [-0.03, 0.0, 0.30]]),
    ),
}
"""End effectors chosen per robot (engineering estimates, TCP frame of :data:`TOOLS`)."""

FIT_SEED = 2024
"""Seed of the postures the built-in robots were fitted on."""

FIT_POSTURES = 80
"""Number of postures the built-in robots were fitted on."""


# ------------------------------------------------------------------- fit
def _lowest_seen_undamped(
    m: FloatArray, k: FloatArray, j: FloatArray, n: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """Undamped (f [Hz], k_dominant [N/m], phi, w [rad/s]) of the n lowest seen modes."""
    w, phi = undamped_modes(m, k)
    u = j @ phi
    with np.errstate(divide="ignore"):
        kk = (w**2)[..., None, :] / u**2
    idx, valid = lowest_seen(seen_mask(kk), n)
    ws = np.take_along_axis(w, idx, axis=-1)
    ks = np.take_along_axis(np.min(kk, axis=-2), idx, axis=-1)
    ph = np.take_along_axis(phi, idx[..., None, :], axis=-1)
    return ws / (2.0 * np.pi), ks, ph, ws, valid


def fit_stiffness(
    robot: Robot,
    q: ArrayLike,
    targets: CalibrationTargets,
    *,
    prior: ArrayLike | None = None,
    ridge: float = 0.03,
    k_weight: float = 1.5,
    band_weight: float = 5.0,
    seen_weight: float = 1.0,
    seen_margin: float = 5.0,
    max_factor: float = 10.0,
) -> FloatArray:
    """Joint stiffnesses that put the lowest modes at the anchors, seen and in the bands.

    Least squares over ``k_i = prior_i exp(s_i)``, ``|s_i| <= log max_factor``, of
    the residuals (undamped modes; ``n = targets.n_modes``; RMS over postures)

    * ``mean_q log f_r - log f_anchor_r`` for the ``n`` lowest seen modes
      (:func:`~robolobe.twin.modes.seen_mask`),
    * ``band_weight`` x RMS of ``log f_r`` outside ``targets.f_band_hz``,
    * ``k_weight`` x RMS of ``max(0, log k_r - log k_cap)`` (modal stiffness in
      the dominant direction),
    * ``seen_weight`` x RMS of ``max(0, log(k_rd / min_s k_sd) - log(SEEN_RATIO /
      seen_margin))`` minimised over directions ``d``: pushes each of the ``n``
      lowest modes to be seen with a margin,
    * ``sqrt(ridge) s_i``.

    The last three act on the ``n`` lowest modes (seen or not) at every posture.

    Parameters
    ----------
    robot : Robot
        Masses, end effector and kinematics used.
    q : array_like, shape (n, 6)
        Postures [rad].
    targets : CalibrationTargets
    prior : array_like, shape (6,), optional
        Starting and reference stiffness [N m/rad]; the robot's if omitted.
    ridge : float
        Weight of the penalty pulling ``s`` towards 0.
    k_weight, band_weight, seen_weight : float
        Weights of the modal-stiffness cap, the frequency band and the
        visibility terms against the frequency anchors.
    seen_margin : float
        Visibility margin (> 1) on :data:`~robolobe.twin.modes.SEEN_RATIO`.
    max_factor : float
        Bound on ``k_i / prior_i`` and ``prior_i / k_i`` (> 1).

    Returns
    -------
    ndarray, shape (6,)
        Stiffness [N m/rad].
    """
    if not max_factor > 1.0 or not seen_margin > 1.0:
        raise InputError(
            f"max_factor, seen_margin: expected numbers > 1, found {max_factor!r}, {seen_margin!r}"
        )
    if robot.has_load_stiffening:
        # the springs below are one diagonal for all postures
        raise InputError(
            "robot: expected constant joint springs, found load_stiffening_per_kNm "
            "(fit such a robot with fit_seed_table)"
        )
    s = nominal_system(robot, q)
    target = np.log(np.asarray(targets.f_anchor_hz, dtype=np.float64))
    k0 = np.asarray(robot.stiffness if prior is None else prior, dtype=np.float64)
    nm = target.size
    log_cap = np.log(targets.k_cap_N_per_m)
    log_lo, log_hi = np.log(targets.f_band_hz)
    log_seen = np.log(SEEN_RATIO / seen_margin)

    def rms(x: FloatArray) -> FloatArray:
        r: FloatArray = np.sqrt(np.mean(x**2, axis=0))
        return r

    k_all = np.diagonal(s.K.reshape(-1, s.n_dof, s.n_dof)[0]).copy()  # compliances kept

    def resid(x: FloatArray) -> FloatArray:
        k_all[:6] = k0 * np.exp(x)
        w, phi = undamped_modes(s.M, np.diag(k_all))
        with np.errstate(divide="ignore"):
            logkk = np.log((w**2)[..., None, :] / (s.J @ phi) ** 2)  # (n, 3, modes)
        idx, valid = lowest_seen(seen_mask(np.exp(logkk)), nm)
        logf_all = np.log(w / (2.0 * np.pi))
        logf = np.where(valid, np.take_along_axis(logf_all, idx, axis=-1), np.nan)
        r_f = np.nanmean(logf, axis=0) - target
        lf = logf_all[:, :nm]
        r_b = band_weight * rms(np.maximum(lf - log_hi, 0.0) + np.maximum(log_lo - lf, 0.0))
        r_k = k_weight * rms(np.maximum(np.min(logkk, axis=-2)[:, :nm] - log_cap, 0.0))
        rel = logkk - np.min(logkk, axis=-1, keepdims=True)
        r_s = seen_weight * rms(np.maximum(np.min(rel, axis=-2)[:, :nm] - log_seen, 0.0))
        return np.concatenate([r_f, r_b, r_k, r_s, np.sqrt(ridge) * x])

    bound = np.log(max_factor)
    sol = least_squares(resid, np.zeros(6), bounds=(-bound, bound))
    k: FloatArray = k0 * np.exp(sol.x)
    return k


def fit_damping(
    robot: Robot,
    q: ArrayLike,
    targets: CalibrationTargets,
    *,
    c_min: float = 20.0,
) -> FloatArray:
    """Joint damping that gives the lowest seen modes the target damping ratio.

    First-order (light damping) modal damping ``zeta_r = sum_i c_i phi_ir^2 /
    (2 w_r)`` is linear in ``c``; its relative error to ``targets.zeta_target``
    over all postures and the lowest seen modes is minimised with
    ``c_i >= c_min``.

    Parameters
    ----------
    robot : Robot
        With the (calibrated) stiffness.
    q : array_like, shape (n, 6)
        Postures [rad].
    targets : CalibrationTargets
    c_min : float
        Lower bound on each joint's damping [N m s/rad].

    Returns
    -------
    ndarray, shape (6,)
        Damping [N m s/rad].
    """
    s = nominal_system(robot, q)
    _, _, phi, w, valid = _lowest_seen_undamped(s.M, s.K, s.J, targets.n_modes)
    # a[n, r, i] = phi_ir^2 / (2 w_r) / zeta_target
    a = (phi**2 / (2.0 * w[:, None, :])).transpose(0, 2, 1) / targets.zeta_target
    rows = a[valid]
    # dampers of the robot's tilt/mount DOFs stay as they are; fit the six joints'
    c_fixed = np.diagonal(s.C.reshape(-1, s.n_dof, s.n_dof)[0])[6:]
    rhs = np.ones(len(rows)) - rows[:, 6:] @ c_fixed
    res = lsq_linear(rows[:, :6], rhs, bounds=(c_min, np.inf))
    c: FloatArray = res.x
    return c


@with_one_blas_thread
def calibrate(
    robot: Robot,
    q: ArrayLike,
    targets: CalibrationTargets,
    *,
    end_effector: RigidBody | None = None,
    prior: ArrayLike | None = None,
) -> Robot:
    """Robot with fitted stiffness and damping (steps 2-4 of the module doc).

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (n, 6)
        Postures [rad] (see :func:`robolobe.robots.sample_postures`).
    targets : CalibrationTargets
    end_effector : RigidBody, optional
        Replaces the robot's end effector first.
    prior : array_like, shape (6,), optional
        Prior stiffness; the robot's if omitted.

    Returns
    -------
    Robot
    """
    r = robot if end_effector is None else robot.replace(end_effector=end_effector)
    r = r.with_stiffness(fit_stiffness(r, q, targets, prior=prior))
    return r.with_damping(fit_damping(r, q, targets))


def calibrate_builtin(name: str, robot: Robot) -> Robot:
    """Re-run the calibration of built-in robot ``name`` ("A", "B", "C").

    Uses :data:`TOOLS`, :data:`END_EFFECTORS`, :data:`PRIOR_STIFFNESS`, :data:`TARGETS` and
    :data:`FIT_POSTURES` postures drawn with seed :data:`FIT_SEED` within
    :data:`TESTED_RANGES_DEG`. The seed-table fit of B and C
    (:func:`fit_seed_table`) is a separate procedure (``studies/seed_tables.py``);
    the shipped files are not its output yet.

    Parameters
    ----------
    name : str
    robot : Robot
        The robot's kinematics and link masses (e.g. ``load_robot(name)``).
    """
    if name not in TARGETS:
        raise InputError(f"name: expected one of {sorted(TARGETS)}, found {name!r}")
    xyz, zyx_deg = TOOLS[name]
    tool = pose_from_xyz_zyx(np.array(xyz), np.radians(zyx_deg))
    r = robot.replace(tool=tool, end_effector=END_EFFECTORS[name])
    q = sample_postures(r, FIT_POSTURES, np.random.default_rng(FIT_SEED), TESTED_RANGES_DEG[name])
    return calibrate(r, q, TARGETS[name], prior=PRIOR_STIFFNESS[name])


def seed_prior_plain(robot: Robot) -> Robot:
    """``robot`` without tilt or mount compliance."""
    r = robot.with_mount(None, None)
    for j in range(6):
        r = r.with_tilt(j, None, None)
    return r


# ---------------------------------------------------------------- report
@dataclass(frozen=True)
class ModeSummary:
    """Ranges of one mode over the postures, and fractions inside the bands.

    Attributes
    ----------
    mode : int
        1-based, by rising frequency.
    f_hz, zeta, k_N_per_m : tuple of 3 floats
        (min, median, max) over the postures of the natural frequency [Hz],
        damping ratio and modal stiffness in the dominant TCP direction [N/m].
    f_spread : float
        ``max/min - 1`` of the frequency (posture dependence).
    seen : float
        Fraction of postures where this many modes are seen at the TCP
        (:func:`~robolobe.twin.modes.seen_mask`); the statistics are over those.
    in_f_band, in_zeta_band, in_k_band, in_all_bands : float
        Fractions of all postures inside each band (all three at once for the
        last); a posture where the mode is not seen counts as outside.
    """

    mode: int
    f_hz: tuple[float, float, float]
    zeta: tuple[float, float, float]
    k_N_per_m: tuple[float, float, float]
    f_spread: float
    seen: float
    in_f_band: float
    in_zeta_band: float
    in_k_band: float
    in_all_bands: float


@dataclass(frozen=True)
class CalibrationReport:
    """Calibration check of one robot.

    Attributes
    ----------
    robot_name : str
    n_postures : int
    targets : CalibrationTargets
    modes : tuple of ModeSummary
        The ``targets.n_modes`` lowest modes.
    all_modes_in_bands : float
        Fraction of postures where every calibrated mode is seen and inside
        all bands.
    """

    robot_name: str
    n_postures: int
    targets: CalibrationTargets
    modes: tuple[ModeSummary, ...]
    all_modes_in_bands: float

    def to_markdown(self) -> str:
        """The report as a Markdown table (one row per mode)."""
        t = self.targets
        lines = [
            f"{self.robot_name}: {self.n_postures} postures; bands f {t.f_band_hz[0]:g}-"
            f"{t.f_band_hz[1]:g} Hz, zeta {100 * t.zeta_band[0]:g}-{100 * t.zeta_band[1]:g} %, "
            f"k {t.k_band_N_per_m[0]:.0e}-{t.k_band_N_per_m[1]:.0e} N/m; all modes in all "
            f"bands: {100 * self.all_modes_in_bands:.0f} % of postures",
            "",
            "| mode | seen [%] | f min/med/max [Hz] | spread | zeta min/med/max [%] "
            "| k min/med/max [1e5 N/m] | in f / zeta / k band [%] |",
            "|---|---|---|---|---|---|---|",
        ]
        for m in self.modes:
            f = "/".join(f"{x:.1f}" for x in m.f_hz)
            z = "/".join(f"{100 * x:.2f}" for x in m.zeta)
            k = "/".join(f"{x / 1e5:.2f}" for x in m.k_N_per_m)
            frac = f"{100 * m.in_f_band:.0f} / {100 * m.in_zeta_band:.0f} / {100 * m.in_k_band:.0f}"
            lines.append(
                f"| {m.mode} | {100 * m.seen:.0f} | {f} | {100 * m.f_spread:.0f} % | {z} | {k} "
                f"| {frac} |"
            )
        return "\n".join(lines)


def _mmm(x: FloatArray) -> tuple[float, float, float]:
    if np.all(np.isnan(x)):
        return (np.nan, np.nan, np.nan)
    return (float(np.nanmin(x)), float(np.nanmedian(x)), float(np.nanmax(x)))


def _inside(x: FloatArray, band: tuple[float, float]) -> NDArray[np.bool_]:
    return np.asarray((x >= band[0]) & (x <= band[1]))


def calibration_report(
    robot: Robot, q_samples: ArrayLike, targets: CalibrationTargets | None = None
) -> CalibrationReport:
    """Frequency, damping and modal-stiffness ranges of the lowest seen modes.

    Parameters
    ----------
    robot : Robot
    q_samples : array_like, shape (n, 6)
        Postures [rad], e.g. from :func:`robolobe.robots.sample_postures`.
    targets : CalibrationTargets, optional
        Bands and the number of modes; if omitted, those of the built-in robot
        (``robot.source == "built-in B"`` etc.), else 5 modes in 5-40 Hz.

    Returns
    -------
    CalibrationReport
        Computed from the exact damped modes of the nominal model; mode r is
        the r-th lowest mode seen at the TCP at each posture.
    """
    if targets is None:
        key = robot.source.removeprefix("built-in ")
        t = TARGETS.get(key, _GENERIC_TARGETS)
    else:
        t = targets
    q = as_postures(q_samples, "q_samples")
    s = nominal_system(robot, q)
    md = compute_modes(s.M, s.K, s.C, s.J)
    nm = t.n_modes
    idx, valid = lowest_seen(md.seen(), nm)

    def take(x: FloatArray) -> FloatArray:
        return np.where(valid, np.take_along_axis(x, idx, axis=-1), np.nan)

    f, z, k = take(md.f_hz), take(md.zeta), take(md.k_dominant_N_per_m())
    fin, zin, kin = _inside(f, t.f_band_hz), _inside(z, t.zeta_band), _inside(k, t.k_band_N_per_m)
    allin = fin & zin & kin
    modes = tuple(
        ModeSummary(
            mode=r + 1,
            f_hz=_mmm(f[:, r]),
            zeta=_mmm(z[:, r]),
            k_N_per_m=_mmm(k[:, r]),
            f_spread=float(np.nanmax(f[:, r]) / np.nanmin(f[:, r]) - 1.0),
            seen=float(np.mean(valid[:, r])),
            in_f_band=float(np.mean(fin[:, r])),
            in_zeta_band=float(np.mean(zin[:, r])),
            in_k_band=float(np.mean(kin[:, r])),
            in_all_bands=float(np.mean(allin[:, r])),
        )
        for r in range(nm)
    )
    return CalibrationReport(
        robot_name=robot.name,
        n_postures=len(q),
        targets=t,
        modes=modes,
        all_modes_in_bands=float(np.mean(np.all(allin, axis=1))),
    )


# ------------------------------------------------------ seed-table fit
SEED_FIT_STARTS = 40
"""Random starts of :func:`fit_seed_table` for the shipped robots."""

_LOG15 = float(np.log(1.5))
K_WEIGHT = 2.0
"""Weight of a factor 1.5 in relative modal stiffness against 1 % in frequency."""
FRAC_WEIGHT = 10.0
"""Weight of ``1 - FRAC`` (per posture) in the stage-1 residuals."""
TOTAL_MASS_TOL = 0.05
"""Scale of the penalty on the log of the fitted total link mass against the robot
file's (the datasheet mass) when link masses are free; the end effector is not in it."""
UNMATCHED_ZETA = 0.02
"""Damping ratio assumed for twin modes no table mode is matched to (stage 1), and kept
as a floor for them in stage 2, so that the fitted dampers do not sharpen their peaks."""
EXTRA_PEAK = 0.15
"""Largest peak of an unmatched twin mode (2 % damping assumed) relative to the table's highest."""


@dataclass(frozen=True)
class SeedFitForm:
    """Model form and parameter bounds of :func:`fit_seed_table`.

    The fitted parameters are log factors on priors: the six joint
    stiffnesses (prior: the robot's), two tilt stiffnesses per joint in
    ``tilt_joints`` (prior ``tilt_prior`` x the joint's stiffness), the two
    mount stiffnesses (prior ``mount_prior_Nm_per_rad``), the end-effector
    mass and inertia, each link's mass and inertia (the B and C masses are
    estimates), the load stiffening of the joints in ``load_joints`` (linear,
    not log), the mass distribution of the bodies in ``shape_bodies`` (COM
    offset in units of :data:`COM_UNIT_M`, log factors of the principal
    moments) and the level ``log(k_twin / k_table)`` of modal stiffness.

    Attributes
    ----------
    tilt_joints : tuple of int
        0-based joints given tilt compliance.
    mount : bool
        Whether the end-effector mount is compliant.
    stiffness_bound : float
        Bound on the log factors of all springs.
    ee_mass_bound, link_mass_bound : float
        Bounds on the log factors of the masses; 0 (default) keeps the
        robot file's masses, so that :func:`seed_prior` recovers the prior.
    tilt_prior : float
        Tilt stiffness prior as a multiple of the joint's stiffness prior.
    mount_prior_Nm_per_rad : float
    direction : int
        Axis of the table (1 = y).
    k_level_range : tuple of 2 floats
        Bounds on ``k_twin / k_table`` (table read literally in 1e5 N/m).
    frame : {"tcp", "world"}
        Whether ``direction`` is an axis of the TCP frame (the twin's FRF
        convention) or of the robot base (world) frame.
    load_joints : tuple of int
        0-based joints whose spring stiffens with the gravity torque it
        holds (:func:`robolobe.twin.system.load_stiffened`); the parameter
        of each is its relative stiffening ``y`` at the largest gravity
        torque of the fitted postures (prior masses), ``0 <= y <= load_max``.
    load_max : float
        Largest relative stiffening (3: a stiffness ratio of 4 between no
        load and that torque, about the K3/K1 of reducer catalogue curves).
    k_bounds_Nm_per_rad : tuple of 4 pairs, optional
        Absolute bounds [N m/rad] on the springs, replacing
        ``stiffness_bound`` for them: axes 1-3, axes 4-6, tilt of axes 1-3
        and of axes 4-5 (then also at least the axes' lower bound), mount.
        None: log-factor bounds only.
    shape_bodies : tuple of int
        0-based bodies (0-5 links 1-6, 6 the end effector) whose mass
        distribution is fitted: the centre-of-mass offset from the robot
        file's, in the body's own frame (three parameters in units of
        :data:`COM_UNIT_M`, each within ``com_bound_m``) and the log factors
        of the three principal moments of inertia about the COM (principal
        axes of the file's tensor, within ``inertia_bound``; a penalty keeps
        the triangle inequality). The file's B and C inertias are estimates
        (scaled KUKA data), so these are unknowns of the file, not new physics.
    com_bound_m, ee_com_bound_m : float
        Largest centre-of-mass offset per body axis [m] of a link (about a
        quarter of the 1-1.3 m arms) and of the end effector (spindle and
        bracket, about the spindle's radius).
    inertia_bound : float
        Bound on the log factors of the principal moments of inertia.
    """

    tilt_joints: tuple[int, ...] = (0, 1, 2, 3, 4)
    mount: bool = True
    stiffness_bound: float = 3.0
    ee_mass_bound: float = 0.0
    link_mass_bound: float = 0.0
    tilt_prior: float = 3.0
    mount_prior_Nm_per_rad: float = 1.0e5
    direction: int = 1
    frame: str = "tcp"
    k_level_range: tuple[float, float] = (0.05, 150.0)
    load_joints: tuple[int, ...] = ()
    load_max: float = 3.0
    k_bounds_Nm_per_rad: tuple[tuple[float, float], ...] | None = None
    shape_bodies: tuple[int, ...] = ()
    com_bound_m: float = 0.3
    ee_com_bound_m: float = 0.1
    inertia_bound: float = 1.0


TRIANGLE_TOL = 0.002
"""Scale of the penalty on a principal inertia beyond :data:`TRIANGLE_MARGIN` x the sum
of the other two (a physical rigid body has ``I_a <= I_b + I_c``): a log excess of 0.002
costs as 1 % in frequency."""
TRIANGLE_MARGIN = 0.98
"""The penalty starts at ``I_a = 0.98 (I_b + I_c)``; :func:`fit_seed_table` then moves
any remaining excess to ``I_a = 0.995 (I_b + I_c)`` so that the robot file loads."""


LITERATURE_K_BOUNDS: tuple[tuple[float, float], ...] = (
    (1.0e6, 2.0e7),  # axes 1-3
    (1.0e5, 1.0e6),  # axes 4-6
    (1.0e6, 1.0e9),  # tilt of axes 1-3 (bearings: not softer than the axis)
    (1.0e5, 1.0e9),  # tilt of axes 4-5
    (1.0e5, 1.0e8),  # spindle mount
)
"""Bounds [N m/rad] of :attr:`SeedFitForm.k_bounds_Nm_per_rad` from the literature:
axes 1-3 ~1e6-1e7 (KUKA KR500: 2.3-8.6e6, x1.5 for the 650 kg class), wrist 1e5-1e6
(docs/references.md: robots), tilt at least the axis's lower bound, a spindle mount at
least 1e5 (a stiffer bracket than any wrist axis)."""


class _TableModel:
    """Undamped TCP modes of a robot with the form's DOFs for many parameter vectors.

    The seed-table fit's parametrisation (parameter layout, bounds, load
    stiffening, level, triangle penalty, the robot file it writes) on the
    parametrised-twin core :class:`robolobe.twin.params.BodyMassModel`, which
    gives ``M``, its derivatives and the bodies' gravity torques from
    Jacobians computed once at the postures; ``K`` is diagonal.
    """

    def __init__(
        self, robot: Robot, q: FloatArray, form: SeedFitForm, tau_ref: FloatArray | None = None
    ) -> None:
        r = robot
        for j in form.tilt_joints:
            r = r.with_tilt(j, (1.0, 1.0), (0.0, 0.0))
        r = r.with_mount((1.0, 1.0), (0.0, 0.0)) if form.mount else r.with_mount(None, None)
        for j in set(range(6)) - set(form.tilt_joints):
            r = r.with_tilt(j, None, None)
        r = r.with_load_stiffening(np.zeros(6))
        self.base = r
        self.form = form
        s = nominal_system(r, q)
        # the bodies whose COM offset and principal moments are parameters
        self.shape = body_indices("shape_bodies", form.shape_bodies, len(s.bodies.names))
        self.bodies = BodyMassModel(
            s, com_bodies=form.shape_bodies, moment_bodies=form.shape_bodies
        )
        self.nb = len(self.bodies.mass_kg)
        self.body_mass = self.bodies.mass_kg
        self.nd = s.n_dof
        jac = s.J if form.frame == "tcp" else s.tcp_jv
        self.j = jac[:, form.direction, :]  # (p, nd)
        k6 = robot.stiffness
        tilt = np.repeat(form.tilt_prior * k6[list(form.tilt_joints)], 2)
        mount = [form.mount_prior_Nm_per_rad] * (2 if form.mount else 0)
        self.k0 = np.concatenate([k6, tilt, mount])
        self.load = np.array(form.load_joints, dtype=np.intp)
        nl = len(self.load)
        # scale of the load parameters [N m]: the largest gravity torque at these postures,
        # or the caller's (a sub-model of one posture shares its parent's)
        if tau_ref is None:
            tau = self.bodies.gravity_torques(np.ones(self.nb))  # prior masses and COMs
            tau_ref = np.maximum(np.abs(tau)[:, self.load].max(axis=0), 1.0)
        self.tau_ref = np.asarray(tau_ref, dtype=np.float64)
        ns = self.nd
        nsh = 6 * len(self.shape)
        self.slices = {
            "k": slice(0, ns),
            "ee": slice(ns, ns + 1),
            "links": slice(ns + 1, ns + 7),
            "load": slice(ns + 7, ns + 7 + nl),
            "shape": slice(ns + 7 + nl, ns + 7 + nl + nsh),
        }
        self.n_params = ns + 7 + nl + nsh + 1  # + level
        sh_lo = np.concatenate([
            [-(form.ee_com_bound_m if b == 6 else form.com_bound_m) / COM_UNIT_M] * 3
            + [-form.inertia_bound] * 3
            for b in self.shape
        ]) if len(self.shape) else np.zeros(0)  # fmt: skip
        lo = np.concatenate(
            [np.full(ns, -form.stiffness_bound), [-form.ee_mass_bound],
             np.full(6, -form.link_mass_bound), np.zeros(nl), sh_lo, [-3.0]]
        )  # fmt: skip
        self.lower, self.upper = lo, -lo
        self.upper[self.slices["load"]] = form.load_max
        self.k_hi = np.full(6, np.inf)  # upper bound of the joint springs under load [N m/rad]
        if form.k_bounds_Nm_per_rad is not None:
            kb = np.array(form.k_bounds_Nm_per_rad, dtype=np.float64)
            lo_k = np.concatenate([np.repeat(kb[0:2, 0], 3), np.zeros(ns - 6)])
            hi_k = np.concatenate([np.repeat(kb[0:2, 1], 3), np.zeros(ns - 6)])
            i = 6
            for jt in form.tilt_joints:
                row = kb[2] if jt < 3 else kb[3]
                lo_k[i : i + 2], hi_k[i : i + 2] = row[0], row[1]
                i += 2
            if form.mount:
                lo_k[i : i + 2], hi_k[i : i + 2] = kb[4]
            self.lower[:ns] = np.log(lo_k / self.k0)
            self.upper[:ns] = np.log(hi_k / self.k0)
            self.k_hi = hi_k[:6].copy()
        self.lower[-1], self.upper[-1] = np.log(form.k_level_range)

    def shape_parameters(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """COM offsets [m] (body frame) and log factors of the principal moments of the
        shape bodies, shape (nsb, 3) each."""
        y = x[self.slices["shape"]].reshape(-1, 6)
        return COM_UNIT_M * y[:, :3], y[:, 3:]

    def body_matrices(self, x: FloatArray) -> FloatArray:
        """Each body's mass matrix at the prior masses, shape (p, nb, nd, nd)."""
        return self.bodies.body_matrices(*self.shape_parameters(x))

    def body_gravity(self, x: FloatArray) -> FloatArray:
        """Gravity torque of each body on the six axes at the prior masses, (p, nb, 6)."""
        return self.bodies.body_gravity(self.shape_parameters(x)[0])

    def shape_derivatives(self, x: FloatArray, p: int) -> tuple[FloatArray, FloatArray]:
        """Derivatives at posture ``p`` of the bodies' mass matrices (prior masses) and
        gravity torques with respect to the shape parameters, (nsh, nd, nd) and (nsh, 6)."""
        d, lm = self.shape_parameters(x)
        n, nd = len(self.shape), self.nd
        dm_c, dt_c = self.bodies.com_derivatives(p, d, COM_UNIT_M)
        dm = np.concatenate([dm_c, self.bodies.moment_derivatives(p, lm)], axis=1)
        dt = np.concatenate([dt_c, np.zeros((n, 3, 6))], axis=1)
        return dm.reshape(6 * n, nd, nd), dt.reshape(6 * n, 6)

    def triangle(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Excess ``log(I_a / (m (I_b + I_c)))`` (``m`` :data:`TRIANGLE_MARGIN`) of every
        principal moment of every shape body (> 0 violates the triangle inequality with
        that margin), shape (3 nsb,), and its Jacobian (3 nsb, n_params)."""
        n = len(self.shape)
        out = np.zeros(3 * n)
        jac = np.zeros((3 * n, self.n_params))
        st = self.slices["shape"].start
        for i, lam in enumerate(self.bodies.moments(self.shape_parameters(x)[1])):
            for a in range(3):
                b, c = [k for k in range(3) if k != a]
                out[3 * i + a] = np.log(lam[a] / (lam[b] + lam[c]) / TRIANGLE_MARGIN)
                jac[3 * i + a, st + 6 * i + 3 + a] = 1.0
                jac[3 * i + a, st + 6 * i + 3 + b] = -lam[b] / (lam[b] + lam[c])
                jac[3 * i + a, st + 6 * i + 3 + c] = -lam[c] / (lam[b] + lam[c])
        return out, jac

    def physical(self, x: FloatArray) -> FloatArray:
        """``x`` with any principal moment beyond 0.995 x the sum of the other two
        lowered to it (the robot-file loader's triangle inequality)."""
        out = x.copy()
        st = self.slices["shape"].start
        for i, lam in enumerate(self.bodies.moments(self.shape_parameters(x)[1])):
            a = int(np.argmax(lam))
            cap = 0.995 * (lam.sum() - lam[a])
            if lam[a] > cap:
                out[st + 6 * i + 3 + a] += np.log(cap / lam[a])
        return out

    def stiffness(self, x: FloatArray) -> FloatArray:
        """Spring of every DOF at every posture [N m/rad], shape (p, nd)."""
        k = self.k0 * np.exp(x[self.slices["k"]])
        out = np.repeat(k[None, :], self.bodies.n_postures, axis=0)
        if len(self.load):
            d = self.shape_parameters(x)[0]
            tau = self.bodies.gravity_torques(self.mass_scales(x), d)[:, self.load]
            s = x[self.slices["load"]] / self.tau_ref
            out[:, self.load] = load_stiffened(k[self.load], s, tau)
        return out

    def mass_scales(self, x: FloatArray) -> FloatArray:
        sc = np.ones(self.nb)
        sc[:6] = np.exp(x[self.slices["links"]])
        if self.nb > 6:
            sc[6] = np.exp(x[self.slices["ee"]][0])
        return sc

    def matrices(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """M (p, nd, nd) and K (p, nd, nd) for parameters ``x``."""
        m = self.bodies.mass_matrix(self.mass_scales(x), *self.shape_parameters(x))
        return m, self.stiffness(x)[:, :, None] * np.eye(self.nd)

    def modes(self, x: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """log f [Hz], log k_dir [N/m], shapes phi (p, nd, nd), w [rad/s]."""
        m, k = self.matrices(x)
        w, phi = undamped_modes(m, k)
        u = np.einsum("pi,pir->pr", self.j, phi)
        with np.errstate(divide="ignore"):
            lk = np.log(w**2 / np.maximum(u**2, 1e-300))
        return np.log(w / (2.0 * np.pi)), lk, phi, w

    def robot(self, x: FloatArray, damping: FloatArray | None = None) -> Robot:
        """The robot file for parameters ``x`` (dampers ``damping``, shape (nd,))."""
        k = self.k0 * np.exp(x[self.slices["k"]])
        c = np.zeros(self.nd) if damping is None else damping
        r = self.base.with_stiffness(k[:6]).with_damping(c[:6])
        i = 6
        for j in self.form.tilt_joints:
            r = r.with_tilt(j, k[i : i + 2], c[i : i + 2])
            i += 2
        if self.form.mount:
            r = r.with_mount(k[i : i + 2], c[i : i + 2])
        if len(self.load):
            s = np.zeros(6)
            s[self.load] = x[self.slices["load"]] / self.tau_ref
            r = r.with_load_stiffening(s)
        sc = self.mass_scales(x)
        d, lm = self.shape_parameters(x)
        dist = {
            int(bi): (c, inertia)
            for bi, c, inertia in zip(
                self.shape, self.bodies.coms(d), self.bodies.inertias(lm), strict=True
            )
        }

        def body(n: int, b: RigidBody) -> RigidBody:
            com, inertia = dist.get(n, (b.com_m, b.inertia_kgm2))
            return RigidBody(b.mass_kg * sc[n], com, 0.5 * (inertia + inertia.T) * sc[n])

        joints = tuple(
            dataclasses.replace(jt, body=body(n, jt.body)) for n, jt in enumerate(r.joints)
        )
        r = r.replace(joints=joints)
        ee = r.end_effector
        if ee is not None:
            r = r.replace(end_effector=body(6, ee))
        return r


def seed_fit_parameter_count(robot: Robot, table: SeedTable, form: SeedFitForm) -> int:
    """Number of free parameters of :func:`fit_seed_table` (level included) for ``form``."""
    model = _TableModel(robot, table.postures_rad, form)
    return int(np.sum(model.upper > model.lower))


def _match(lf: FloatArray, lk: FloatArray, f_t: FloatArray, k_t: FloatArray) -> NDArray[np.intp]:
    """Twin mode index for each table mode (one posture): least frequency and level misfit."""
    cost = ((lf[None, :] - f_t[:, None]) / 0.03) ** 2 + ((lk[None, :] - k_t[:, None]) / 0.7) ** 2
    rows, cols = match_modes(cost)
    if rows.size != f_t.size:
        raise InputError(f"seed table: expected finite modes to match, found {f_t}, {k_t}")
    return cols


@dataclass(frozen=True)
class SeedFit:
    """Result of :func:`fit_seed_table`.

    Attributes
    ----------
    robot : Robot
        Fitted robot (springs, dampers, masses, compliances).
    postures : tuple of int
        0-based table postures used in the fit.
    k_level : float
        ``k_twin / k_table`` (table read literally in 1e5 N/m): the level of
        modal stiffness the twin's masses give; the fit uses relative values.
    cost : float
        Robust cost of the stiffness stage.
    x : ndarray
        Parameters (log factors; see :class:`SeedFitForm`).
    """

    robot: Robot
    postures: tuple[int, ...]
    k_level: float
    cost: float
    x: FloatArray


def _soft_l1(r: FloatArray, scale: float) -> FloatArray:
    """Residuals whose squares are the soft-L1 cost ``2 s^2 (sqrt(1 + (r/s)^2) - 1)``."""
    z = r / scale
    # sqrt(1 + z^2) - 1 = z^2 / (sqrt(1 + z^2) + 1): no cancellation near r = 0
    out: FloatArray = scale * np.sqrt(2.0) * z / np.sqrt(np.sqrt(1.0 + z**2) + 1.0)
    return out


def _soft_l1_slope(r: FloatArray, scale: float) -> FloatArray:
    """Derivative of :func:`_soft_l1` with respect to ``r``."""
    g = np.sqrt(1.0 + (r / scale) ** 2)
    out: FloatArray = np.sqrt((g + 1.0) / 2.0) / g
    return out


def _table_residuals(
    model: _TableModel,
    x: FloatArray,
    f_t: FloatArray,
    k_t: FloatArray,
    lz_t: FloatArray,
    ridge: float,
    *,
    jacobian: bool = False,
    with_frac: bool = True,
) -> FloatArray | tuple[FloatArray, FloatArray]:
    """Stage-1 residuals of :func:`fit_seed_table` (and their Jacobian w.r.t. the springs
    and the level, from eigen-sensitivities; masses fixed)."""
    lf, lk, phi, w = model.modes(x)
    ls = x[-1]
    lam = w**2
    k = model.stiffness(x)
    out, rows = [], []
    a_f, a_k = 1.0 / 0.01, K_WEIGHT / _LOG15  # 1 % in f = 1; a factor 1.5 in k = K_WEIGHT
    for p in range(f_t.shape[0]):
        m = _match(lf[p], lk[p], f_t[p], k_t[p] + ls)
        # robust (soft L1, scale 3) on the data; the penalties below stay quadratic
        rf = a_f * (lf[p, m] - f_t[p])
        rk = a_k * (lk[p, m] - k_t[p] - ls)
        out.append(_soft_l1(rf, 3.0))
        out.append(_soft_l1(rk, 3.0))
        other = np.ones(lf.shape[1], dtype=bool)
        other[m] = False
        # other modes below 42 Hz must not add a peak the table lacks: at 2 % damping their
        # peak 1/(2 zeta k) stays below EXTRA_PEAK x the table's highest 1/(2 zeta_t k_t)
        floor = ls - np.log(2.0 * UNMATCHED_ZETA * EXTRA_PEAK) + np.min(k_t[p] + lz_t[p])
        active = other & (lf[p] < np.log(42.0)) & (floor > lk[p])
        out.append(np.where(active, floor - lk[p], 0.0) / _LOG15)
        if jacobian:
            dlf, dlk = _mode_sensitivities(model, x, p, phi[p], lam[p], k[p])
            npar = model.n_params
            jf = np.zeros((5, npar))
            jf[:, :-1] = (_soft_l1_slope(rf, 3.0) * a_f)[:, None] * dlf[:, m].T
            jk = np.zeros((5, npar))
            jk[:, :-1] = (_soft_l1_slope(rk, 3.0) * a_k)[:, None] * dlk[:, m].T
            jk[:, -1] = -_soft_l1_slope(rk, 3.0) * a_k
            jp = np.zeros((lf.shape[1], npar))
            jp[:, :-1] = -dlk.T / _LOG15
            jp[:, -1] = 1.0 / _LOG15
            jp[~active] = 0.0
            rows += [jf, jk, jp]
    out.append(np.sqrt(ridge) * x[:-1])
    # the robot's total mass is known (datasheet) even where its distribution is not
    sc = model.mass_scales(x)[:6]
    total = float(model.body_mass[:6] @ sc)
    out.append(np.array([np.log(total / model.body_mass[:6].sum()) / TOTAL_MASS_TOL]))
    # a spring stiffened by its load stays within the bound too (the literature values are
    # springs under load): log(k_eff / k_hi) > 0 costs as 1 % in frequency per 0.01
    lj = model.load[np.isfinite(model.k_hi[model.load])]
    over = np.log(k[:, lj] / model.k_hi[lj]) if len(lj) else np.zeros((0, 0))
    out.append((np.maximum(over, 0.0) / 0.01).ravel())
    tri, jtri = model.triangle(x)
    out.append(np.maximum(tri, 0.0) / TRIANGLE_TOL)
    fr = np.zeros(0)
    if with_frac:
        fr = FRAC_WEIGHT * (1.0 - _modal_frac(lf, lk, f_t, k_t, lz_t, ls))
        out.append(fr)
    res = np.concatenate(out)
    if not jacobian:
        return res
    jr = np.zeros((model.n_params - 1, model.n_params))
    jr[:, :-1] = np.sqrt(ridge) * np.eye(model.n_params - 1)
    rows.append(jr)
    jm = np.zeros((1, model.n_params))
    jm[0, model.slices["links"]] = model.body_mass[:6] * sc / total / TOTAL_MASS_TOL
    rows.append(jm)
    jb = np.zeros((over.size, model.n_params))
    if over.size:
        pos = list(model.load)
        scall = model.mass_scales(x)
        y = x[model.slices["load"]]
        row = 0
        for p in range(over.shape[0]):
            tau_b = model.body_gravity(x)[p] * scall[:, None]  # (nb, 6)
            tau = tau_b.sum(axis=0)
            for jj, j in enumerate(lj):
                if over[p, jj] > 0:
                    i = pos.index(j)
                    r_ = model.tau_ref[i]
                    g = 1.0 + y[i] * abs(tau[j]) / r_  # k_eff = k0 g
                    jb[row, j] = 1.0 / 0.01
                    jb[row, model.slices["load"].start + i] = abs(tau[j]) / r_ / g / 0.01
                    dmass = y[i] * np.sign(tau[j]) * tau_b[:, j] / r_ / g / 0.01
                    jb[row, model.slices["links"]] = dmass[:6]
                    if model.nb > 6:
                        jb[row, model.slices["ee"]] = dmass[6]
                    if len(model.shape):
                        dts = model.shape_derivatives(x, p)[1][:, j]
                        dts = dts * np.repeat(scall[model.shape], 6)
                        jb[row, model.slices["shape"]] = (
                            y[i] * np.sign(tau[j]) * dts / r_ / g / 0.01
                        )
                row += 1
    rows.append(jb)
    rows.append(np.where((tri > 0)[:, None], jtri / TRIANGLE_TOL, 0.0))
    jfr = np.zeros((len(fr), model.n_params))  # FRAC rows: central differences
    cols = [i for i in range(model.n_params) if model.upper[i] > model.lower[i]]
    for i in cols if with_frac else []:
        for sign in (1.0, -1.0):
            xx = x.copy()
            xx[i] += sign * 1e-5
            lf2, lk2, _, _ = model.modes(xx)
            v = FRAC_WEIGHT * (1.0 - _modal_frac(lf2, lk2, f_t, k_t, lz_t, xx[-1]))
            jfr[:, i] += sign * v / 2e-5
    rows.append(jfr)
    return res, np.concatenate(rows)


def _mode_sensitivities(
    model: _TableModel, x: FloatArray, p: int, ph: FloatArray, lam: FloatArray, k: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Derivatives of ``log f_r`` and ``log k_r`` (along the table direction) at posture
    ``p`` with respect to every parameter but the level, shape (n_params - 1, modes) each.

    First-order eigen-sensitivities of ``K phi = lam M phi`` (mass-normalised
    ``ph``, shape (nd, modes); ``k`` the springs at this posture, shape (nd,)):
    a log factor on spring i gives ``dK = k_i e_i e_i^T``, one on body b's
    mass ``dM = M_b`` (and, with load stiffening, ``dK`` through the gravity
    torque), a load parameter ``y_j`` gives ``dK = k0_j |tau_j| / tau_ref_j
    e_j e_j^T``.
    """
    nd = model.nd
    sc = model.mass_scales(x)
    # dK_i and dM_b projected on the modes: (param, s, r)
    pk = k[:, None, None] * ph[:, :, None] * ph[:, None, :]
    mb = np.einsum("b,bij->bij", sc, model.body_matrices(x)[p])
    pm = np.einsum("is,bij,jr->bsr", ph, mb, ph)
    links, ee = model.slices["links"], model.slices["ee"]
    dk = np.zeros((model.n_params - 1, *pk.shape[1:]))
    dm = np.zeros_like(dk)
    dk[:nd] = pk
    dm[links] = pm[:6]
    if model.nb > 6:
        dm[ee] = pm[6:7]
    shp = model.slices["shape"]
    if len(model.shape):
        dmb, dtau = model.shape_derivatives(x, p)
        scs = np.repeat(sc[model.shape], 6)
        dm[shp] = np.einsum("is,aij,jr->asr", ph, dmb * scs[:, None, None], ph)
    if len(model.load):
        lj = model.load
        k0 = (model.k0 * np.exp(x[model.slices["k"]]))[lj]
        tau_b = model.body_gravity(x)[p][:, lj] * sc[:, None]  # (nb, nl): d tau / d log(mass)
        tau = tau_b.sum(axis=0)
        y = x[model.slices["load"]]
        pp = ph[lj][:, :, None] * ph[lj][:, None, :]  # (nl, s, r)
        dk[model.slices["load"]] = (k0 * np.abs(tau) / model.tau_ref)[:, None, None] * pp
        dmass = tau_b * (k0 * y * np.sign(tau) / model.tau_ref)[None, :]  # (nb, nl)
        proj = np.einsum("bj,jsr->bsr", dmass, pp)
        dk[links] += proj[:6]
        if model.nb > 6:
            dk[ee] += proj[6:7]
        if len(model.shape):
            dts = dtau[:, lj] * scs[:, None] * (k0 * y * np.sign(tau) / model.tau_ref)[None, :]
            dk[shp] += np.einsum("aj,jsr->asr", dts, pp)
    # d lam_r = phi_r^T (dK - lam_r dM) phi_r
    diag = np.einsum("ass->as", dk) - lam[None, :] * np.einsum("ass->as", dm)
    u = model.j[p] @ ph
    gap = lam[None, :] - lam[:, None]  # (s, r): lam_r - lam_s
    np.fill_diagonal(gap, np.inf)
    # du_r = sum_{s != r} u_s phi_s^T (dK - lam_r dM) phi_r / (lam_r - lam_s)
    #        - u_r / 2 phi_r^T dM phi_r
    coup = dk - lam[None, None, :] * dm
    du = np.einsum("s,asr,sr->ar", u, coup, 1.0 / gap) - 0.5 * u[None, :] * np.einsum("ass->as", dm)
    dlf = 0.5 * diag / lam[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        dlk = diag / lam[None, :] - 2.0 * du / u[None, :]
    return dlf, np.nan_to_num(dlk)


_FRAC_GRID_HZ = np.arange(2.0, 40.0 + 1e-9, 0.25)


def _modal_frac(
    lf: FloatArray,
    lk: FloatArray,
    f_t: FloatArray,
    k_t: FloatArray,
    lz_t: FloatArray,
    ls: float,
) -> FloatArray:
    """FRAC per posture of the twin's modal receptance (undamped modes; the damping of
    the matched table mode, 2 % for the others) against the table's, 2-40 Hz."""
    from robolobe.campaign.metrics import frac
    from robolobe.twin.frf import modal_receptance

    z = np.full(lf.shape, UNMATCHED_ZETA)
    for p in range(f_t.shape[0]):
        m = _match(lf[p], lk[p], f_t[p], k_t[p] + ls)
        z[p, m] = np.exp(lz_t[p])
    h = modal_receptance(np.exp(lf), z, np.exp(lk), _FRAC_GRID_HZ)
    ht = modal_receptance(np.exp(f_t), np.exp(lz_t), np.exp(k_t), _FRAC_GRID_HZ)
    out: FloatArray = np.asarray(frac(h, ht, axis=-1), dtype=np.float64)
    return out


def _stage1(
    model: _TableModel,
    f_t: FloatArray,
    k_t: FloatArray,
    lz_t: FloatArray,
    ridge: float,
    cands: list[FloatArray],
    refine: int,
    with_frac: bool,
) -> list[tuple[float, FloatArray]]:
    """Stage 1 of :func:`fit_seed_table` from the starts ``cands``.

    Every start is run for 40 evaluations (without the FRAC term, whose
    Jacobian is by differences); the ``refine`` best are run to convergence
    (with it if ``with_frac``). Returns ``(cost, x)`` of the refined ones,
    best first; ``x`` has all parameters (fixed ones at 0).
    """
    free = model.upper > model.lower  # a zero bound fixes the parameter at 0

    def full(y: FloatArray) -> FloatArray:
        x = np.zeros(model.n_params)
        x[free] = y
        return x

    def resid(y: FloatArray, wf: bool) -> FloatArray:
        r = _table_residuals(model, full(y), f_t, k_t, lz_t, ridge, with_frac=wf)
        assert isinstance(r, np.ndarray)
        return r

    def jac(y: FloatArray, wf: bool) -> FloatArray:
        out = _table_residuals(model, full(y), f_t, k_t, lz_t, ridge, jacobian=True, with_frac=wf)
        assert isinstance(out, tuple)
        return out[1][:, free]

    def solve(c: FloatArray, nfev: int, wf: bool) -> Any:
        return least_squares(
            resid, np.clip(c[free], model.lower[free], model.upper[free]), jac=jac,
            max_nfev=nfev, bounds=(model.lower[free], model.upper[free]), args=(wf,),
        )  # fmt: skip

    scout = sorted((solve(c, 40, False) for c in cands), key=lambda sol: float(sol.cost))
    out = [solve(full(sc.x), 300, with_frac) for sc in scout[:refine]]
    out.sort(key=lambda sol: float(sol.cost))
    return [(float(sol.cost), full(sol.x)) for sol in out]


@with_one_blas_thread
def fit_seed_table(
    robot: Robot,
    table: SeedTable,
    postures: tuple[int, ...] = (0, 1, 2),
    *,
    form: SeedFitForm | None = None,
    starts: int = SEED_FIT_STARTS,
    seed: int = FIT_SEED,
    ridge: float = 0.0025,
    x0: ArrayLike | None = None,
    refine: int = 8,
    by_posture: int = 3,
) -> SeedFit:
    """Fit springs, dampers and masses to a seed table (robust, multi-start).

    Stage 1 (springs, masses, mass distribution, load stiffening, level): least
    squares with a soft-L1 loss (``f_scale`` 3: residuals beyond ~3 % in
    frequency or a factor ~2 in modal stiffness count linearly, so a copy
    error pulls little) over

    * ``log f_twin - log f_table`` per 1 % for each table mode,
    * ``log k_twin - log k_table - level`` per factor 1.5, weight :data:`K_WEIGHT`,
    * the twin's other modes below 42 Hz kept from adding peaks the table
      lacks: at 2 % damping their peak ``1/(2 zeta k)`` below
      :data:`EXTRA_PEAK` x the table's highest (a quadratic penalty),
    * a ridge on the log factors (and the COM offsets in units of
      :data:`COM_UNIT_M`),
    * with ``form.shape_bodies``, a penalty on principal moments beyond the
      triangle inequality (:data:`TRIANGLE_MARGIN`); the result is then
      projected onto it (:meth:`_TableModel.physical`) so that its robot
      file loads.

    Each table mode is matched to a twin mode per posture by the least
    frequency and modal-stiffness misfit (Hungarian assignment). A penalty
    holds the total link mass to the robot file's (:data:`TOTAL_MASS_TOL`)
    when masses are free. Starts: the prior, ``starts`` uniform within 60 %
    of the bounds, ``x0`` if given, and (``by_posture``) the best solutions
    of each posture fitted alone from the same starts; a single posture is
    easy to fit, the joint problem's basins are hard to hit at random.

    Stage 2 (dampers): with the matched undamped modes, ``zeta_r = phi_r^T C
    phi_r / (2 w_r)`` (first order), the log of every damper is fitted to
    the table's damping with a soft-L1 loss in ``log zeta`` (scale log 1.5),
    no mode above 8 % and the unmatched modes below 42 Hz at
    :data:`UNMATCHED_ZETA` or above (stage 1 judged their peaks at it).

    Parameters
    ----------
    robot : Robot
        Prior (kinematics, masses, joint stiffness).
    table : SeedTable
    postures : tuple of int
        0-based table postures to fit (two of them for leave-one-out).
    form : SeedFitForm, optional
    starts : int
        Random starts of stage 1.
    seed : int
    ridge : float
        Weight of the pull of the log factors towards 0.
    x0 : array_like, optional
        An extra start (e.g. the parameters of a previous fit).
    refine : int
        Every start is first run for 40 evaluations; the ``refine`` best
        are then run to convergence.
    by_posture : int
        Solutions per posture (fitted alone) added to the starts of the
        joint fit; 0 turns the seeding off.

    Returns
    -------
    SeedFit
    """
    fm = SeedFitForm() if form is None else form
    idx = list(postures)
    if not idx or any(p not in (0, 1, 2) for p in idx):
        raise InputError(f"postures: expected indices 0..2, found {postures!r}")
    model = _TableModel(robot, table.postures_rad[idx], fm)
    f_t = np.log(table.f_hz[idx])
    k_t = np.log(table.k_N_per_m[idx])
    lz_t = np.log(table.zeta[idx])
    rng = np.random.default_rng(seed)
    cands = [rng.uniform(0.6 * model.lower, 0.6 * model.upper) for _ in range(starts)]
    cands.insert(0, np.zeros(model.n_params))  # the prior itself
    for c in cands:
        c[-1] = np.log(np.sqrt(fm.k_level_range[0] * fm.k_level_range[1]))
    if x0 is not None:
        cands.insert(0, np.clip(np.asarray(x0, dtype=np.float64), model.lower, model.upper))

    if by_posture and len(idx) > 1:
        # every posture alone is easy to fit; its best solutions are the joint fit's
        # most promising starts (the joint problem's basins are hard to hit at random)
        pool: list[FloatArray] = []
        for i, p in enumerate(idx):
            mp = _TableModel(robot, table.postures_rad[[p]], fm, model.tau_ref)
            sols = _stage1(mp, f_t[[i]], k_t[[i]], lz_t[[i]], ridge, cands, refine, False)
            pool += [xs for _, xs in sols[:by_posture]]
        cands = pool + cands
    sols = _stage1(model, f_t, k_t, lz_t, ridge, cands, refine, True)
    cost, x = sols[0]
    x = model.physical(x)
    damping = _fit_table_damping(model, x, table, idx)
    return SeedFit(
        robot=model.robot(x, damping),
        postures=tuple(idx),
        k_level=float(np.exp(x[-1])),
        cost=cost,
        x=x,
    )


def _fit_table_damping(
    model: _TableModel, x: FloatArray, table: SeedTable, idx: list[int]
) -> FloatArray:
    """Dampers [N m s/rad] that give the matched modes the table's damping (robust)."""
    lf, lk, phi, w = model.modes(x)
    f_t = np.log(table.f_hz[idx])
    k_t = np.log(table.k_N_per_m[idx]) + x[-1]
    rows, target, every, others = [], [], [], []
    for p in range(len(idx)):
        every.append((phi[p] ** 2 / (2.0 * w[p])).T)
        m = _match(lf[p], lk[p], f_t[p], k_t[p])
        ph = phi[p][:, m]  # (nd, 5)
        rows.append((ph**2 / (2.0 * w[p, m])).T)  # zeta_r = sum_i c_i row_ri
        target.append(np.log(table.zeta[idx[p]]))
        other = np.ones(lf.shape[1], dtype=bool)
        other[m] = False
        other &= lf[p] < np.log(42.0)
        others.append(every[-1][other])
    a = np.concatenate(rows)
    a_all = np.concatenate(every)
    # stage 1 judged the unmatched modes' peaks at UNMATCHED_ZETA; keep them there or above
    a_other = np.concatenate(others)
    lt = np.concatenate(target)
    # prior: every DOF's own oscillator at 2 % damping
    m_diag = np.einsum("b,pbii->pi", model.mass_scales(x), model.body_matrices(x)).mean(axis=0)
    k = model.k0 * np.exp(x[model.slices["k"]])
    c0 = 2.0 * 0.02 * np.sqrt(k * m_diag)

    def resid(s: FloatArray) -> FloatArray:
        c = c0 * np.exp(s)
        z = a @ c
        # no mode of the twin beyond 8 % damping (robot modes: 0.2-7 %, docs/references.md)
        over = np.maximum(0.0, np.log(np.maximum(a_all @ c, 1e-12) / 0.08)) / _LOG15
        under = np.maximum(0.0, np.log(UNMATCHED_ZETA / np.maximum(a_other @ c, 1e-12))) / _LOG15
        r = _soft_l1((np.log(np.maximum(z, 1e-12)) - lt) / _LOG15, 1.0)
        return np.concatenate([r, 3.0 * over, 3.0 * under, 0.05 * s])

    sol = least_squares(resid, np.zeros(len(c0)), bounds=(-5, 5))
    out: FloatArray = c0 * np.exp(sol.x)
    return out


def lopo_frequency_spread(
    robot: Robot,
    table: SeedTable,
    x: FloatArray,
    *,
    form: SeedFitForm | None = None,
    prior_sd: float = 1.0,
) -> FloatArray:
    """How well two postures determine the third's frequencies, linearised at ``x``.

    For each held-out posture: the Gaussian posterior of the free log factors
    given the other two postures' table values (frequency with a 1 % error,
    relative modal stiffness with a factor 1.5, the level free) and a prior
    ``N(0, prior_sd^2)`` on every log factor, propagated to the held-out
    posture's matched modes. A spread of several per cent means that
    leave-one-posture-out cannot test the model to a few per cent with this
    many parameters, whatever the fit does.

    Parameters
    ----------
    robot : Robot
        The prior of the fit (:func:`seed_prior`).
    table : SeedTable
    x : ndarray, shape (n_params,)
        Parameters of a three-posture fit (:attr:`SeedFit.x`).
    form : SeedFitForm, optional
        The form of that fit.
    prior_sd : float
        Prior standard deviation of each log factor.

    Returns
    -------
    ndarray, shape (3, 5)
        One standard deviation of ``log f`` (about the relative error) per
        held-out posture and table mode.
    """
    fm = SeedFitForm() if form is None else form
    model = _TableModel(robot, table.postures_rad, fm)
    lf, lk, phi, w = model.modes(x)
    k = model.stiffness(x)
    free = np.append((model.upper > model.lower)[:-1], True)
    rf, rk = [], []
    for p in range(3):
        m = _match(lf[p], lk[p], np.log(table.f_hz[p]), np.log(table.k_N_per_m[p]) + x[-1])
        dlf, dlk = _mode_sensitivities(model, x, p, phi[p], w[p] ** 2, k[p])
        rf.append(np.hstack([dlf[:, m].T, np.zeros((5, 1))])[:, free])
        rk.append(np.hstack([dlk[:, m].T, -np.ones((5, 1))])[:, free])
    out = np.zeros((3, 5))
    for held in range(3):
        keep = [p for p in range(3) if p != held]
        a = np.vstack([rf[p] / 0.01 for p in keep] + [rk[p] / _LOG15 for p in keep])
        cov = np.linalg.inv(a.T @ a + np.eye(a.shape[1]) / prior_sd**2)
        out[held] = np.sqrt(np.einsum("ri,ij,rj->r", rf[held], cov, rf[held]))
    return out


@dataclass(frozen=True)
class TableComparison:
    """The twin's modes matched to a seed table, per posture and mode.

    Attributes
    ----------
    f_hz, zeta, k_N_per_m : ndarray, shape (n_post, 5)
        The matched twin modes (exact damped modes; modal stiffness along the
        table's direction) [Hz, fraction, N/m].
    k_level : float
        Median of ``k_twin / k_table`` (table read literally).
    f_err : ndarray, shape (n_post, 5)
        ``f_twin / f_table - 1``.
    zeta_ratio, k_ratio : ndarray, shape (n_post, 5)
        ``zeta_twin / zeta_table`` and ``k_twin / (k_level k_table)``.
    frac : ndarray, shape (n_post,)
        FRAC of the twin's receptance along the direction against the one
        rebuilt from the table (:func:`robolobe.twin.frf.modal_receptance`),
        2-40 Hz in 0.25 Hz steps (the seed's resolution).
    extra_modes : ndarray of int, shape (n_post,)
        Unmatched twin modes in 2-40 Hz whose peak ``1/(2 zeta k)`` along the
        direction exceeds :data:`EXTRA_PEAK` x the table's highest (peaks the
        table lacks).
    """

    f_hz: FloatArray
    zeta: FloatArray
    k_N_per_m: FloatArray
    k_level: float
    f_err: FloatArray
    zeta_ratio: FloatArray
    k_ratio: FloatArray
    frac: FloatArray
    extra_modes: NDArray[np.intp]


def compare_to_table(
    robot: Robot,
    table: SeedTable,
    postures: tuple[int, ...] = (0, 1, 2),
    *,
    k_level: float | None = None,
    direction: int = 1,
) -> TableComparison:
    """Match the twin's modes to a seed table and measure the misfit.

    Parameters
    ----------
    robot : Robot
    table : SeedTable
    postures : tuple of int
        0-based table postures.
    k_level : float, optional
        ``k_twin / k_table`` used in the matching and ``k_ratio``; the median
        ratio over the postures if omitted (a prediction for a held-out
        posture should pass the level of its fit).
    direction : int
        TCP axis (1 = y).

    Returns
    -------
    TableComparison
    """
    from robolobe.campaign.metrics import frac
    from robolobe.twin.frf import modal_receptance, receptance

    idx = list(postures)
    s = nominal_system(robot, table.postures_rad[idx])
    md = compute_modes(s.M, s.K, s.C, s.J)
    lf = np.log(md.f_hz)
    lk = np.log(np.abs(md.k_N_per_m[:, direction, :]))
    f_t, z_t, k_t = table.f_hz[idx], table.zeta[idx], table.k_N_per_m[idx]
    level = k_level
    if level is None:
        # first match at the level that puts the softest modes together
        shift = [lk[p].min() - np.log(k_t[p]).min() for p in range(len(idx))]
        m0 = [_match(lf[p], lk[p], np.log(f_t[p]), np.log(k_t[p]) + shift[p])
              for p in range(len(idx))]  # fmt: skip
        level = float(np.exp(np.median([lk[p, m] - np.log(k_t[p]) for p, m in enumerate(m0)])))
    ms = [_match(lf[p], lk[p], np.log(f_t[p]), np.log(k_t[p] * level)) for p in range(len(idx))]
    take = np.array(ms)
    f = np.take_along_axis(md.f_hz, take, axis=-1)
    z = np.take_along_axis(md.zeta, take, axis=-1)
    k = np.take_along_axis(np.exp(lk), take, axis=-1)
    grid = np.arange(2.0, 40.0 + 1e-9, 0.25)
    h_twin = receptance(s.M, s.K, s.C, s.J, grid)[..., direction, direction]
    h_tab = modal_receptance(f_t, z_t, k_t, grid)
    extra = []
    for p, m in enumerate(ms):
        other = np.ones(lf.shape[1], dtype=bool)
        other[m] = False
        show = other & (md.f_hz[p] >= 2.0) & (md.f_hz[p] <= 40.0)
        peak_t = np.max(1.0 / (2.0 * z_t[p] * k_t[p] * level))
        peak = 1.0 / (2.0 * np.maximum(md.zeta[p], 1e-6) * np.exp(lk[p]))
        extra.append(int(np.sum(show & (peak > EXTRA_PEAK * peak_t))))
    return TableComparison(
        f_hz=f,
        zeta=z,
        k_N_per_m=k,
        k_level=float(level),
        f_err=f / f_t - 1.0,
        zeta_ratio=z / z_t,
        k_ratio=k / (level * k_t),
        frac=np.asarray(frac(h_twin, h_tab, axis=-1), dtype=np.float64),
        extra_modes=np.array(extra, dtype=np.intp),
    )


@dataclass(frozen=True)
class ValueVerdict:
    """Verdict on one table value after the fit.

    Attributes
    ----------
    posture, mode : int
        1-based.
    quantity : {"f", "zeta", "k"}
    table, twin : float
        Table value (f [Hz], zeta [%], k [table unit 1e5 N/m]) and the
        twin's (k divided by the fit's level).
    verdict : {"ok", "outlier", "copy error"}
        ``copy error``: the tables themselves show it
        (:func:`robolobe.twin.seed_tables.table_checks`); ``outlier``: the
        robust fit leaves it beyond 3 % (f) or a factor 2.25 (zeta, k);
        ``ok`` otherwise.
    reason : str
    """

    posture: int
    mode: int
    quantity: str
    table: float
    twin: float
    verdict: str
    reason: str


OUTLIER_F = 0.03
"""Frequency misfit beyond which a table value is an outlier of the fit."""
OUTLIER_FACTOR = 2.25
"""Damping / relative modal-stiffness factor beyond which a value is an outlier (1.5^2)."""


def value_verdicts(name: str, comparison: TableComparison) -> list[ValueVerdict]:
    """A verdict per table value of robot ``name`` ("B" or "C") against its fitted twin.

    Parameters
    ----------
    name : str
    comparison : TableComparison
        :func:`compare_to_table` at all three postures.

    Returns
    -------
    list of ValueVerdict
        45 entries (3 postures x 5 modes x 3 quantities).
    """
    from robolobe.twin.seed_tables import SEED_TABLES, table_checks

    t = SEED_TABLES[name]
    checks = {(c.posture, c.mode, c.quantity): c for c in table_checks() if c.robot == name}
    c = comparison
    out = []
    for p in range(3):
        for m in range(5):
            vals = (
                ("f", t.f_hz[p, m], c.f_hz[p, m], abs(c.f_err[p, m]) > OUTLIER_F,
                 f"twin off by {100 * c.f_err[p, m]:+.1f} %"),
                ("zeta", 100 * t.zeta[p, m], 100 * c.zeta[p, m],
                 max(c.zeta_ratio[p, m], 1 / c.zeta_ratio[p, m]) > OUTLIER_FACTOR,
                 f"twin/table {c.zeta_ratio[p, m]:.2f}"),
                ("k", t.ema[2, p, m], c.k_N_per_m[p, m] / c.k_level / 1e5,
                 max(c.k_ratio[p, m], 1 / c.k_ratio[p, m]) > OUTLIER_FACTOR,
                 f"twin/table (relative) {c.k_ratio[p, m]:.2f}"),
            )  # fmt: skip
            for q, tv, wv, off, why in vals:
                chk = checks.get((p + 1, m + 1, q))
                if chk is not None:
                    verdict = "copy error"
                    reason = f"{chk.kind}: {chk.detail}; fit: {why}"
                elif off:
                    verdict, reason = "outlier", why
                else:
                    verdict, reason = "ok", why
                out.append(ValueVerdict(p + 1, m + 1, q, float(tv), float(wv), verdict, reason))
    return out


def seed_prior(name: str, robot: Robot) -> Robot:
    """The prior of the seed-table fit of built-in robot ``name``.

    ``robot``'s kinematics, masses and end effector with the prior joint
    stiffness (:data:`PRIOR_STIFFNESS`) and no tilt or mount compliance: what
    :func:`fit_seed_table` starts from, so that a refit (e.g. leaving a
    posture out) does not see the shipped fit.
    """
    if name not in PRIOR_STIFFNESS:
        raise InputError(f"name: expected one of {sorted(PRIOR_STIFFNESS)}, found {name!r}")
    return seed_prior_plain(robot.with_stiffness(PRIOR_STIFFNESS[name]))


def seed_parameters(name: str, robot: Robot, form: SeedFitForm | None = None) -> FloatArray:
    """The parameters of :func:`fit_seed_table` that give ``robot``'s springs.

    Log factors of its joint, tilt and mount springs on the priors of
    :func:`seed_prior` (masses: 0) and the log of its modal-stiffness level
    against the table (:func:`compare_to_table`). Used to restart the fit
    from a robot file (e.g. to check that a shipped file is the fit's
    optimum).

    Parameters
    ----------
    name : str
        "B" or "C".
    robot : Robot
        With the form's compliances.
    form : SeedFitForm, optional
    """
    from robolobe.twin.seed_tables import SEED_TABLES

    fm = SeedFitForm() if form is None else form
    model = _TableModel(seed_prior(name, robot), SEED_TABLES[name].postures_rad, fm)
    k = list(robot.stiffness)
    for j in fm.tilt_joints:
        ks = robot.joints[j].tilt_stiffness_Nm_per_rad
        if ks is None:
            raise InputError(f"robot: joint {j + 1} has no tilt compliance, the fit form needs it")
        k += list(ks)
    if fm.mount:
        if robot.mount_stiffness_Nm_per_rad is None:
            raise InputError("robot: no mount compliance, the fit form needs it")
        k += list(robot.mount_stiffness_Nm_per_rad)
    x = np.zeros(model.n_params)
    x[model.slices["k"]] = np.log(np.asarray(k) / model.k0)
    x[model.slices["load"]] = robot.load_stiffening[model.load] * model.tau_ref
    x[-1] = np.log(compare_to_table(robot, SEED_TABLES[name]).k_level)
    return x
