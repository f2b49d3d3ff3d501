"""Calibration of the built-in robots' joint stiffness, damping and end effector.

Robots A, B and C need joint stiffness, damping and an end effector that no
public source gives for these arms. This module holds the procedure that set
them (reproducible from a seed, :func:`calibrate_builtin`) and the report that
checks them against the seed paper's ranges (REFERENCES.md section 1):

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

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, lsq_linear

from robolobe.errors import InputError
from robolobe.robots import RigidBody, Robot, sample_postures
from robolobe.robots.transforms import pose_from_xyz_zyx
from robolobe.twin.designs import TESTED_RANGES_DEG
from robolobe.twin.modes import (
    SEEN_RATIO,
    compute_modes,
    lowest_seen,
    seen_mask,
    undamped_modes,
)
from robolobe.twin.system import nominal_system

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
        source="(est.) like B: the seed gives no table for A (REFERENCES.md section 1)",
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
"""Calibration targets per built-in robot (bands: REFERENCES.md section 1)."""

_GENERIC_TARGETS = CalibrationTargets(
    f_band_hz=(5.0, 40.0),
    zeta_band=(0.002, 0.07),
    k_band_N_per_m=(1e4, 3e6),
    f_anchor_hz=(7.5, 11.0, 15.0, 21.0, 31.0),
    zeta_target=0.02,
    source="REFERENCES.md section 1 (five modes in 5-40 Hz)",
)

PRIOR_STIFFNESS: dict[str, tuple[float, ...]] = {
    # KUKA KR500 joint stiffness from modal testing (REFERENCES.md section 2)
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

    def resid(x: FloatArray) -> FloatArray:
        w, phi = undamped_modes(s.M, np.diag(k0 * np.exp(x)))
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
    res = lsq_linear(rows, np.ones(len(rows)), bounds=(c_min, np.inf))
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
    :data:`TESTED_RANGES_DEG`.

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
    q = np.asarray(q_samples, dtype=np.float64)
    if q.ndim != 2 or q.shape[-1] != 6 or len(q) == 0:
        raise InputError(f"q_samples: expected shape (n, 6) with n >= 1, found {q.shape}")
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
