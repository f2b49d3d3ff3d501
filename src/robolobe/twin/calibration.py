"""Calibration of the built-in robots' joint stiffness and damping.

Robots A, B and C need joint stiffness, damping and an end effector that no
public source gives for these arms. This module holds the procedure that set
them (reproducible from a seed) and the report that checks them against the
seed paper's ranges (REFERENCES.md section 1):

1. Postures are drawn uniformly within the seed's tested joint ranges
   (Table 2), clipped to the robot's limits and its linear constraints
   (:func:`sample_postures`).
2. The end effector (spindle, holder, tool) is chosen per robot
   (:data:`END_EFFECTORS`, engineering estimates).
3. Stiffness: log-factors ``s_i`` on prior joint stiffnesses
   (:data:`PRIOR_STIFFNESS`, KUKA KR500 values scaled by robot class) are
   fitted so that the geometric mean over the postures of each of the five
   lowest undamped natural frequencies matches anchor frequencies taken
   from the seed's tables (:data:`TARGETS`), with a small ridge penalty on
   ``s`` (:func:`fit_stiffness`).
4. Damping: with mass-normalised undamped shapes ``phi``, modal damping is
   ``zeta_r ~ sum_i c_i phi_ir^2 / (2 w_r)``, linear in the joint damping
   ``c``; ``c >= c_min`` is fitted by bounded least squares to anchor damping
   ratios (:func:`fit_damping`).
5. :func:`calibration_report` then checks the exact damped modes of the
   result: per-mode frequency, damping and modal-stiffness ranges over the
   postures and the fraction inside the target bands.

``studies/calibration.py`` runs steps 1-5 for A, B and C and prints the
table; the values written into ``src/robolobe/data/robots/{A,B,C}.toml`` come
from it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, lsq_linear

from robolobe.errors import InputError
from robolobe.robots import RigidBody, Robot
from robolobe.twin.dynamics import mass_matrix
from robolobe.twin.modes import compute_modes, undamped_modes
from robolobe.twin.system import nominal_system

__all__ = [
    "END_EFFECTORS",
    "PRIOR_STIFFNESS",
    "TARGETS",
    "TESTED_RANGES_DEG",
    "CalibrationReport",
    "CalibrationTargets",
    "ModeSummary",
    "calibrate",
    "calibration_report",
    "fit_damping",
    "fit_stiffness",
    "sample_postures",
]

FloatArray = NDArray[np.float64]

TESTED_RANGES_DEG: dict[str, tuple[tuple[float, float], ...]] = {
    "A": ((-50, 50), (-90, -50), (70, 150), (-300, 300), (-90, 90), (-300, 300)),
    "B": ((-60, 87), (-28, 56), (-127, -16), (-158, 232), (-93, 124), (-283, 201)),
    "C": ((-59, 47), (-10, 48), (-30, 79), (-184, 190), (-116, 114), (-360, 296)),
}
"""Tested joint ranges of the seed paper, Table 2 [deg] (REFERENCES.md section 1)."""


@dataclass(frozen=True)
class CalibrationTargets:
    """Bands the calibrated modes should fall in, and the fit's anchors.

    Attributes
    ----------
    f_band_hz : tuple of 2 floats
        Band for the natural frequencies of the ``n_modes`` lowest modes [Hz].
    zeta_band : tuple of 2 floats
        Band for their damping ratios (fraction).
    k_band_N_per_m : tuple of 2 floats
        Band for their modal stiffness in the dominant TCP direction [N/m].
    f_anchor_hz : tuple of floats
        Geometric-mean frequency of each of the lowest modes over the tested
        postures, the stiffness fit's target [Hz].
    zeta_anchor : tuple of floats
        Damping ratio of each of the lowest modes, the damping fit's target.
    source : str
        Where the anchors come from.
    """

    f_band_hz: tuple[float, float]
    zeta_band: tuple[float, float]
    k_band_N_per_m: tuple[float, float]
    f_anchor_hz: tuple[float, ...]
    zeta_anchor: tuple[float, ...]
    source: str = ""

    @property
    def n_modes(self) -> int:
        """Number of calibrated (lowest) modes."""
        return len(self.f_anchor_hz)

    def __post_init__(self) -> None:
        if len(self.zeta_anchor) != len(self.f_anchor_hz):
            raise InputError(
                f"zeta_anchor: expected {len(self.f_anchor_hz)} values (one per anchor "
                f"frequency), found {len(self.zeta_anchor)}"
            )


TARGETS: dict[str, CalibrationTargets] = {
    # seed Table 4 (robot B, Y direction), mean over its three postures
    "B": CalibrationTargets(
        f_band_hz=(5.0, 40.0),
        zeta_band=(0.002, 0.07),
        k_band_N_per_m=(1e4, 3e6),
        f_anchor_hz=(7.3, 11.3, 14.3, 21.4, 31.1),
        zeta_anchor=(0.011, 0.015, 0.015, 0.030, 0.018),
        source="seed Table 4 (B, mean of postures 1-3)",
    ),
    # seed Table 7 (robot C), mean over its three postures
    "C": CalibrationTargets(
        f_band_hz=(8.0, 32.0),
        zeta_band=(0.002, 0.07),
        k_band_N_per_m=(1e4, 3e6),
        f_anchor_hz=(12.3, 14.1, 21.2, 22.5, 25.3),
        zeta_anchor=(0.017, 0.010, 0.024, 0.006, 0.010),
        source="seed Table 7 (C, mean of postures 1-3)",
    ),
    # robot A: no table in the seed; "similar to B" (REFERENCES.md section 1)
    "A": CalibrationTargets(
        f_band_hz=(5.0, 40.0),
        zeta_band=(0.002, 0.07),
        k_band_N_per_m=(1e4, 3e6),
        f_anchor_hz=(7.5, 10.5, 15.0, 22.0, 32.0),
        zeta_anchor=(0.015, 0.020, 0.020, 0.030, 0.020),
        source="(est.) similar to B",
    ),
}
"""Calibration targets per built-in robot."""

PRIOR_STIFFNESS: dict[str, tuple[float, ...]] = {
    # KUKA KR500 joint stiffness from modal testing (REFERENCES.md section 2)
    "A": (2.3e6, 8.6e6, 2.8e6, 3.0e6, 0.2e6, 0.9e6),
    # x1.5 on axes 1-3 (650 kg class), wrist as KR500 with joint 5 x1.5
    "B": (3.45e6, 12.9e6, 4.2e6, 3.0e6, 0.3e6, 0.9e6),
    # x0.5 (1 t class)
    "C": (1.15e6, 4.3e6, 1.4e6, 1.5e6, 0.1e6, 0.45e6),
}
"""Prior joint stiffnesses [N m/rad] the stiffness fit starts from and is pulled towards."""

END_EFFECTORS: dict[str, RigidBody] = {}
"""End effectors chosen per robot (filled below)."""


# ------------------------------------------------------------- postures
def _ranges_rad(robot: Robot, ranges_deg: ArrayLike) -> tuple[FloatArray, FloatArray]:
    r = np.radians(np.asarray(ranges_deg, dtype=np.float64))
    if r.shape != (6, 2) or np.any(r[:, 0] > r[:, 1]):
        raise InputError(f"ranges_deg: expected 6 (min, max) pairs, found {np.degrees(r).tolist()}")
    lo = np.maximum(r[:, 0], robot.q_min)
    hi = np.minimum(r[:, 1], robot.q_max)
    if np.any(lo > hi):
        raise InputError("ranges_deg: a tested range does not overlap the robot's joint limits")
    return lo, hi


def _feasible(robot: Robot, q: FloatArray) -> NDArray[np.bool_]:
    ok = np.all((q >= robot.q_min) & (q <= robot.q_max), axis=-1)
    for c in robot.constraints:
        v = q @ c.coeffs
        ok &= (v >= c.lo_rad) & (v <= c.hi_rad)
    return np.asarray(ok)


def sample_postures(
    robot: Robot,
    n: int,
    rng: np.random.Generator,
    ranges_deg: ArrayLike,
) -> FloatArray:
    """Uniform random postures within tested ranges, limits and constraints.

    Parameters
    ----------
    robot : Robot
    n : int
        Number of postures.
    rng : numpy.random.Generator
    ranges_deg : array_like, shape (6, 2)
        (min, max) per joint [deg], e.g. ``TESTED_RANGES_DEG["B"]``; clipped
        to the robot's limits.

    Returns
    -------
    ndarray, shape (n, 6)
        Joint angles [rad].
    """
    lo, hi = _ranges_rad(robot, ranges_deg)
    out = np.empty((0, 6))
    for _ in range(100):
        q = rng.uniform(lo, hi, size=(max(2 * n, 16), 6))
        out = np.concatenate([out, q[_feasible(robot, q)]])
        if len(out) >= n:
            return out[:n]
    raise InputError("ranges_deg: fewer than 1 % of the sampled postures satisfy the constraints")


# ------------------------------------------------------------------- fit
def _undamped_f(robot: Robot, q: FloatArray, n_modes: int) -> FloatArray:
    m = mass_matrix(robot, q)
    w, _ = undamped_modes(m, np.diag(robot.stiffness))
    return w[..., :n_modes] / (2.0 * np.pi)


def fit_stiffness(
    robot: Robot,
    q: ArrayLike,
    f_anchor_hz: ArrayLike,
    *,
    prior: ArrayLike | None = None,
    ridge: float = 0.03,
) -> FloatArray:
    """Joint stiffnesses that put the lowest modes at anchor frequencies.

    Minimises ``sum_r (log gmean_q f_r - log f_anchor_r)^2 + ridge sum_i s_i^2``
    over ``k_i = prior_i exp(s_i)`` (undamped frequencies, rank-ordered at
    each posture).

    Parameters
    ----------
    robot : Robot
        Masses, end effector and kinematics used.
    q : array_like, shape (n, 6)
        Postures [rad].
    f_anchor_hz : array_like, shape (n_modes,)
        Target geometric-mean frequencies [Hz] of modes 1..n_modes.
    prior : array_like, shape (6,), optional
        Starting and reference stiffness [N m/rad]; the robot's if omitted.
    ridge : float
        Weight of the penalty pulling ``s`` towards 0.

    Returns
    -------
    ndarray, shape (6,)
        Stiffness [N m/rad].
    """
    qq = np.asarray(q, dtype=np.float64)
    target = np.log(np.asarray(f_anchor_hz, dtype=np.float64))
    k0 = np.asarray(robot.stiffness if prior is None else prior, dtype=np.float64)
    mm = mass_matrix(robot, qq)
    nm = target.size

    def resid(s: FloatArray) -> FloatArray:
        w, _ = undamped_modes(mm, np.diag(k0 * np.exp(s)))
        logf = np.log(w[:, :nm] / (2.0 * np.pi))
        return np.concatenate([logf.mean(axis=0) - target, np.sqrt(ridge) * s])

    sol = least_squares(resid, np.zeros(6), x_scale=1.0, bounds=(-5.0, 5.0))
    k: FloatArray = k0 * np.exp(sol.x)
    return k


def fit_damping(
    robot: Robot,
    q: ArrayLike,
    zeta_anchor: ArrayLike,
    *,
    c_min: float = 20.0,
) -> FloatArray:
    """Joint damping that gives the lowest modes anchor damping ratios.

    First-order (light damping) modal damping ``zeta_r = sum_i c_i phi_ir^2 /
    (2 w_r)`` is linear in ``c``; the relative error to ``zeta_anchor`` over
    all postures is minimised with ``c_i >= c_min``.

    Parameters
    ----------
    robot : Robot
        With the (calibrated) stiffness.
    q : array_like, shape (n, 6)
        Postures [rad].
    zeta_anchor : array_like, shape (n_modes,)
        Target damping ratios of modes 1..n_modes.
    c_min : float
        Lower bound on each joint's damping [N m s/rad].

    Returns
    -------
    ndarray, shape (6,)
        Damping [N m s/rad].
    """
    qq = np.asarray(q, dtype=np.float64)
    za = np.asarray(zeta_anchor, dtype=np.float64)
    w, phi = undamped_modes(mass_matrix(robot, qq), np.diag(robot.stiffness))
    nm = za.size
    # a[n, r, i] = phi_ir^2 / (2 w_r) / zeta_anchor_r
    a = (phi[:, :, :nm] ** 2 / (2.0 * w[:, None, :nm])).transpose(0, 2, 1) / za[None, :, None]
    res = lsq_linear(a.reshape(-1, 6), np.ones(a.shape[0] * nm), bounds=(c_min, np.inf))
    c: FloatArray = res.x
    return c


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
        Postures [rad] (see :func:`sample_postures`).
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
    r = r.with_stiffness(fit_stiffness(r, q, targets.f_anchor_hz, prior=prior))
    return r.with_damping(fit_damping(r, q, targets.zeta_anchor))


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
    in_f_band, in_zeta_band, in_k_band, in_all_bands : float
        Fractions of postures inside each band (all three at once for the last).
    """

    mode: int
    f_hz: tuple[float, float, float]
    zeta: tuple[float, float, float]
    k_N_per_m: tuple[float, float, float]
    f_spread: float
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
        Fraction of postures where every calibrated mode is inside all bands.
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
            "| mode | f min/med/max [Hz] | spread | zeta min/med/max [%] "
            "| k min/med/max [1e5 N/m] | in f / zeta / k band [%] |",
            "|---|---|---|---|---|---|",
        ]
        for m in self.modes:
            f = "/".join(f"{x:.1f}" for x in m.f_hz)
            z = "/".join(f"{100 * x:.2f}" for x in m.zeta)
            k = "/".join(f"{x / 1e5:.2f}" for x in m.k_N_per_m)
            frac = f"{100 * m.in_f_band:.0f} / {100 * m.in_zeta_band:.0f} / {100 * m.in_k_band:.0f}"
            lines.append(
                f"| {m.mode} | {f} | {100 * m.f_spread:.0f} % | {z} | {k} | {frac} |"
            )
        return "\n".join(lines)


def _mmm(x: FloatArray) -> tuple[float, float, float]:
    return (float(np.min(x)), float(np.median(x)), float(np.max(x)))


def _inside(x: FloatArray, band: tuple[float, float]) -> NDArray[np.bool_]:
    return np.asarray((x >= band[0]) & (x <= band[1]))


def calibration_report(
    robot: Robot, q_samples: ArrayLike, targets: CalibrationTargets | None = None
) -> CalibrationReport:
    """Frequency, damping and modal-stiffness ranges of the lowest modes.

    Parameters
    ----------
    robot : Robot
    q_samples : array_like, shape (n, 6)
        Postures [rad], e.g. from :func:`sample_postures`.
    targets : CalibrationTargets, optional
        Bands and the number of modes; robot B's if omitted.

    Returns
    -------
    CalibrationReport
        Computed from the exact damped modes of the nominal model.
    """
    t = TARGETS["B"] if targets is None else targets
    q = np.asarray(q_samples, dtype=np.float64)
    if q.ndim != 2 or q.shape[-1] != 6 or len(q) == 0:
        raise InputError(f"q_samples: expected shape (n, 6) with n >= 1, found {q.shape}")
    s = nominal_system(robot, q)
    md = compute_modes(s.M, s.K, s.C, s.J)
    nm = t.n_modes
    f = md.f_hz[:, :nm]
    z = md.zeta[:, :nm]
    k = md.k_dominant_N_per_m()[:, :nm]
    fin, zin, kin = _inside(f, t.f_band_hz), _inside(z, t.zeta_band), _inside(k, t.k_band_N_per_m)
    allin = fin & zin & kin
    modes = tuple(
        ModeSummary(
            mode=r + 1,
            f_hz=_mmm(f[:, r]),
            zeta=_mmm(z[:, r]),
            k_N_per_m=_mmm(k[:, r]),
            f_spread=float(np.max(f[:, r]) / np.min(f[:, r]) - 1.0),
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
