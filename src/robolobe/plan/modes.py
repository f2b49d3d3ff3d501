"""Where the robot's posture-dependent modes come from: a tl model or the twin.

A *mode source* turns postures ``q`` (n, 6) [rad] into :class:`RobotModes`:
modal parameters per TCP direction (x, y, z of the TCP frame) with their
spread, and a 3-D :class:`~robolobe.sld.frf.ModalModel` of the TCP
receptance for the tool-point FRF.

- :class:`PredictorSource`: a :class:`robolobe.tl.estimator.ModalPredictor`
  (the shipped model of A, B or C, or a model file). Driving-point modes per
  direction, no cross terms (that is what a triaxial hammer campaign
  identifies); spread from the ensemble.
- :class:`TwinSource`: the exact nominal modes of the robot file
  (:meth:`robolobe.twin.model.Twin.modes`), coupled 3x3 residues from the
  mode shapes, no spread.
- :class:`CorrectedTwinSource`: a :class:`robolobe.tl.residual.CorrectedTwin`
  (``robolobe transfer modal.csv --robot R -o OUT.npz``): the calibrated
  twin's coupled modes with the learned correction, and the spread of its
  prediction error (:meth:`~robolobe.tl.residual.CorrectedTwin.planning_spread`),
  which robust planning uses by default.

:func:`mode_source` picks one from a job's ``robot.model``; the default is the
twin: the shipped networks miss their own robot's twin by 3-15 % in
frequency and 20-300 % in stiffness over the workspace (README, planning).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import DRIVING
from robolobe._modal_parameters import ModalParameters
from robolobe._text import count
from robolobe.errors import InputError
from robolobe.robots.model import Robot
from robolobe.sld.frf import ModalModel
from robolobe.twin.effects import Effect

if TYPE_CHECKING:
    from robolobe.plan.lobes import DynamicsTolerance

__all__ = [
    "MODE_INTERP_FRACTION",
    "MODE_STRIDE",
    "REGION_CORNERS",
    "CorrectedTwinSource",
    "ModeSource",
    "ParametersSource",
    "PredictorSource",
    "RobotModes",
    "RobustBound",
    "TwinSource",
    "as_mode_source",
    "bound_scenario",
    "interpolated_modes",
    "mode_source",
    "model_file_source",
    "plan_bound",
    "region_confidence",
    "region_corners",
    "region_cover",
    "region_probability",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
#: Largest log spread (per sigma) a robust plan takes from a source: a larger one says
#: the source does not know (e.g. a network's stiffness of a mode it calls not visible),
#: and lowering a stiffness by exp(-k_sigma * 3) would plan on a robot that does not exist.
MAX_LOG_STD = 0.35
#: Largest relative speed window (frequency uncertainty) of a robust plan.
MAX_WINDOW = 0.25
#: Least peak compliance, relative to the posture's largest, of a mode whose frequency
#: spread sets a robust plan's speed window (issue 27: the largest spread of every mode
#: over 5 % gave windows of up to +-17 % on out-of-form robot C, set by weak modes).
WINDOW_SHARE = 0.5
#: Modal stiffness [N/m] from which a mode counts as not visible in a direction.
INVISIBLE_K = 1e11
#: Corners of the joint (frequency, peak compliance) error region a robust plan takes
#: the worst of, besides the frequency-only corner (issue 27: the 2-sigma speed window
#: and the 2-sigma compliance lowering taken together, the corner (2, 2) of a box, put
#: the bound at radius 2.8 sigma: C steel at 0.70 of the oracle's MRR, each alone 0.80).
REGION_CORNERS = 3
#: Whether a robust bound moves each mode that does not lead (peak compliance below
#: WINDOW_SHARE of the largest) by its own frequency spread, down and up, at each corner
#: (issue 27: C14, low-speed titanium; see RobotModes.robust).
MODE_SHIFTS = True
#: Which frequency spread a coupled mode is shifted by (:data:`MODE_SHIFTS`):
#: ``"cut"`` the spreads of the cut's plane (TCP x and y) weighted by the share of the
#: mode's residue each carries (in quadrature, widened for the shifted modes together),
#: ``"largest"`` the largest over the directions that see the mode, ``"pairs"`` (the
#: default) the cut's, and the largest for a mode that can meet another mode that matters
#: within their 2-sigma cut spreads (:func:`_can_meet`: the two may veer and mix their
#: shapes, which driving-point tests do not pin down). Issue 27, out-of-form robots
#: (``studies/out_of_form.py``, draws 0-21): "largest" 0 beyond, median MRR 0.82 of the
#: oracle's; "cut" 0.84 but C14 6 waypoints beyond (a veering pair); "pairs" 0 beyond,
#: 0.84. Of the shifted modes that can meet another, 27 % have a tool-plane shape off the
#: truth's (MAC < 0.9), of the others 4 % (``studies/out_of_form_mrr.py --coverage``).
MODE_SHIFT_SPREAD = "pairs"
#: How the modes' peak compliances are lowered together. ``"independent"`` (the
#: default): their errors taken as independent, the worst point of the ``k_sigma``
#: ball of standardized errors for a limit that weighs each mode by its share of the
#: posture's peak compliance in the cut's plane (the tool's x and y;
#: :func:`joint_lowering`: a lone mode at ``k_sigma``, modes
#: that share the compliance each at less), on a calibrated prediction-error spread
#: (:attr:`RobotModes.spread_calibrated`, where the independence was measured; other
#: spreads, a network ensemble's or a job's assumed one, as ``"each"``: on the in-form
#: robots of ``studies/plan_safety.py`` the network's robust plans lowered together
#: reached a true margin of 0.51 against 0.85). ``"each"``: every mode at ``k_sigma`` of
#: its own spread at once. Issue 27, out-of-form robots (``studies/out_of_form.py``,
#: cached transfers of draws 38-45, 60 postures each): the standardized compliance
#: errors of two modes that matter at one posture correlate at -0.01 (B) and -0.09 (C);
#: with ``"each"`` weak modes with wide spreads set the limit (C's robust plans at 0.77
#: of their plain plans' MRR).
MODE_LOWERING = "independent"


def joint_lowering(peak: ArrayLike, spread: ArrayLike) -> FloatArray:
    """Share of its own lowering each mode takes at the worst point of the joint ball.

    For a stability limit whose log falls with the modes' log peak compliances
    weighted by their shares ``g_r`` of the posture's peak compliance, and
    independent standardized errors ``u_r``, the worst point of the ball
    ``|u| <= k_sigma`` lowers the limit by ``k_sigma sqrt(sum (g_r s_r)^2)``
    (``s_r`` a mode's spread): there ``u_r = k_sigma g_r s_r / sqrt(sum (g s)^2)``.
    A mode that holds the compliance alone takes its full ``k_sigma``; a weak
    mode with a wide spread only as much as its share weighs.

    Parameters
    ----------
    peak : array_like, shape (n, m)
        Each mode's peak compliance [m/N] (>= 0) per posture.
    spread : array_like, shape (n, m)
        Each mode's spread of log peak compliance (any common scale).

    Returns
    -------
    ndarray, shape (n, m)
        ``u_r / k_sigma`` in [0, 1] (0 where no mode has a spread).
    """
    pk = np.nan_to_num(np.asarray(peak, dtype=np.float64), nan=0.0, posinf=0.0)
    sp = np.nan_to_num(np.asarray(spread, dtype=np.float64), nan=0.0, posinf=0.0)
    tot = pk.sum(axis=-1, keepdims=True)
    g = np.divide(pk, tot, out=np.zeros_like(pk), where=tot > 0)
    gs = g * sp
    norm = np.sqrt(np.sum(gs**2, axis=-1, keepdims=True))
    return np.asarray(np.divide(gs, norm, out=np.zeros_like(gs), where=norm > 0))


def region_corners(n: int = REGION_CORNERS) -> FloatArray:
    """Corners of a staircase that holds the quarter disk of radius 1.

    The joint region of a robust bound is the disk of radius ``k_sigma`` in
    standardized errors ``(t, u)``: ``t = |log f_true / f| / s_f`` (the
    speed window) and ``u = log(c_true / c) / s_c`` (``c`` a mode's peak
    compliance ``1 / (2 k zeta)``, ``s_c = sqrt(s_k^2 + s_zeta^2)``). The
    planner takes the smallest limit over a window ``[-t, t]`` and one
    compliance, i.e. over a rectangle ``[0, t] x [0, u]``; the union of the
    rectangles with these corners holds the disk's support in every
    direction: the corners are the vertices, at angles
    ``(j + 1/2) pi / (2 n)``, of the polygon whose edges touch the circle at
    angles ``j pi / (2 n)`` (``t = 1`` and ``u = 1`` among them), so that the
    worst of any limit linear in ``(t, u)`` over them is at least its worst
    over the disk.

    Parameters
    ----------
    n : int
        Number of corners (>= 1).

    Returns
    -------
    ndarray, shape (n, 2)
        ``(t, u)`` per corner, ``t`` decreasing, in units of the radius.
    """
    phi = (np.arange(n) + 0.5) * (0.5 * math.pi / n)
    r = 1.0 / math.cos(0.25 * math.pi / n)
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=1)


def region_confidence(k_sigma: float) -> float:
    """Stated confidence of a robust bound's limit: ``2 Phi(k_sigma) - 1``.

    The limit is non-increasing in the standardized frequency error ``|t|``
    and compliance error ``u``. Where it is linear in them the failure set
    ``{limit < worst over the disk}`` lies in the two half-planes (``t > 0``
    and ``t < 0``) that touch the disk of radius ``k_sigma``, each of normal
    probability ``1 - Phi(k_sigma)``; a limit with no frequency term fails
    only in one (``Phi(k_sigma)``). 95.45 % at ``k_sigma = 2``.
    """
    return math.erf(k_sigma / math.sqrt(2.0))


def region_cover(k_sigma: float, t: FloatArray, u: FloatArray) -> NDArray[np.bool_]:
    """Whether standardized errors ``(t, u)`` lie in the region a bound covers.

    Inside: the disk of radius ``k_sigma`` (``t`` taken as ``|t|``), and every
    point whose compliance error is lower (``u <= 0`` with ``|t| <= k_sigma``):
    the bound's limit is at most the limit there. Its normal probability:
    :func:`region_probability` (90.9 % at ``k = 2``; the limit's confidence,
    :func:`region_confidence`, is higher: a point outside fails the limit only
    beyond the line that touches the disk).
    """
    t = np.abs(np.asarray(t, dtype=np.float64))
    u = np.asarray(u, dtype=np.float64)
    return np.asarray(t**2 + np.maximum(u, 0.0) ** 2 <= k_sigma**2)


def joint_sigma(k_sigma: float, m: ArrayLike) -> FloatArray:
    """Half-width (in sigmas) of ``m`` independent normal intervals that hold together
    with the probability one interval of ``k_sigma`` holds alone (:func:`region_confidence`).

    Each interval then holds with ``c^(1/m)`` (Sidak), ``c = 2 Phi(k_sigma) - 1``:
    ``Phi^-1((1 + c^(1/m)) / 2)``; ``k_sigma`` for ``m = 1`` (2.0 -> 2.50 for 4, 2.68
    for 6).
    """
    c = region_confidence(k_sigma)
    m_arr = np.maximum(np.asarray(m, dtype=np.float64), 1.0)
    inv = statistics.NormalDist().inv_cdf  # the standard library's: no scipy on the plan path
    vals, idx = np.unique(m_arr, return_inverse=True)
    out = np.array([inv(0.5 * (1.0 + c ** (1.0 / v))) for v in vals], dtype=np.float64)
    return np.asarray(out[idx].reshape(m_arr.shape), dtype=np.float64)


def _can_meet(
    omega: FloatArray, spread: FloatArray, matter: NDArray[np.bool_]
) -> NDArray[np.bool_]:
    """Whether each mode can meet another mode that matters within their frequency spreads.

    ``omega`` (n, m) [rad/s], ``spread`` (n, m) the half-width of each mode's
    log-frequency interval (already ``k_sigma`` wide), ``matter`` (n, m) the modes
    that count as partners. Modes ``i`` and ``j`` can meet where
    ``|log(omega_i / omega_j)| <= hypot(spread_i, spread_j)`` (the difference of two
    independent errors): their shapes can then mix (veer), which driving-point tests
    do not pin down. Returns (n, m).
    """
    lw = np.log(np.maximum(omega, 1e-300))
    s2 = spread**2
    out = np.zeros(omega.shape, dtype=bool)
    for j in range(omega.shape[1]):  # m is small: (n, m) work per partner
        near = (lw - lw[:, j : j + 1]) ** 2 <= s2 + s2[:, j : j + 1]
        near[:, j] = False
        out |= near & matter[:, j : j + 1]
    return out


def region_probability(k_sigma: float) -> float:
    """Normal probability of :func:`region_cover`'s region (standard normal errors).

    Half the mass lies at ``u <= 0`` (inside when ``|t| <= k``), half at ``u > 0``
    (inside the half disk: the chi-square tail of 2 degrees of freedom).
    """
    return 0.5 * (math.erf(k_sigma / math.sqrt(2.0)) + 1.0 - math.exp(-0.5 * k_sigma**2))


@dataclass(frozen=True, eq=False)
class RobotModes:
    """Robot modes at a batch of postures, per TCP direction, and their receptance model.

    Attributes
    ----------
    parameters : ModalParameters
        Shape (n, 3, n_modes) on the driving points ``xx, yy, zz`` (TCP
        axes x, y, z): natural frequency [Hz], damping ratio, modal stiffness
        [N/m] (``inf`` stiffness: the mode does not move the TCP that way;
        NaN: no such mode), with the spread (std of log f, log zeta, log k)
        or none.
    model : ModalModel
        TCP-frame receptance model, dim 3, batch (n,).
    extrapolation : ndarray, shape (n,) or None
        How far each posture lies outside the model's training range (0 inside;
        0.1 = 10 % of a joint's range beyond).
    source : str
        Description (``"tl model A (shipped)"``, ``"twin"``, a file name).
    shapes_coupled : bool
        True when ``model`` holds one set of coupled modes (the twin's, the
        same in every direction); False for per-direction modes (a predictor).
    spread_calibrated : bool
        True when the spread is a calibrated prediction error (a ``CorrectedTwin``).

    Notes
    -----
    :attr:`f_hz`, :attr:`zeta`, :attr:`k_N_per_m` and :attr:`log_std` are
    read-only views of :attr:`parameters` (what the planning pipeline reads).
    """

    parameters: ModalParameters
    model: ModalModel
    extrapolation: FloatArray | None
    source: str
    shapes_coupled: bool = False
    spread_calibrated: bool = False

    def __post_init__(self) -> None:
        p = self.parameters
        if not isinstance(p, ModalParameters):
            raise InputError(
                f"RobotModes.parameters: expected ModalParameters, found {type(p).__name__}"
            )
        if p.directions != DRIVING:
            raise InputError(
                f"RobotModes.parameters: expected directions {DRIVING}, found {p.directions}"
            )

    @property
    def f_hz(self) -> FloatArray:
        """Natural frequencies [Hz], shape (n, 3, n_modes) (of :attr:`parameters`)."""
        return self.parameters.f_hz

    @property
    def zeta(self) -> FloatArray:
        """Damping ratios, shape (n, 3, n_modes) (of :attr:`parameters`)."""
        return self.parameters.zeta

    @property
    def k_N_per_m(self) -> FloatArray:
        """Modal stiffness [N/m], shape (n, 3, n_modes) (of :attr:`parameters`)."""
        return self.parameters.k_N_per_m

    @property
    def log_std(self) -> FloatArray | None:
        """Spread (std of log f, log zeta, log k), shape (n, 3, n_modes, 3), or None."""
        return self.parameters.log_std

    def robust(
        self,
        k_sigma: float,
        assumed: Sequence[float] = (),
        override: Sequence[bool] = (False, False, False),
        mode_shifts: bool | None = None,
    ) -> RobustBound | None:
        """The robust bound of these modes: stiffness and damping lowered, a speed window.

        Each visible mode's stiffness and damping are lowered together so that
        their product (the mode's peak compliance ``1 / (2 k zeta)``, which sets
        its stability limit) falls by up to ``k_sigma`` standard deviations of
        its log spread ``sqrt(s_k^2 + s_zeta^2)`` (each spread capped at
        :data:`MAX_LOG_STD` per sigma), shared in proportion to their
        variances (``k_sigma`` spreads of each would lower the product by
        ``k_sigma (s_k + s_zeta)``: up to sqrt(2) times the bound stated).
        The modes are lowered together as :data:`MODE_LOWERING` says: by
        default to the worst point of the ``k_sigma`` ball of their
        independent errors for a limit weighted by each mode's share of the
        posture's peak compliance in the cut's plane, the tool's x and y
        (:func:`joint_lowering`: a mode that holds
        the compliance alone by ``k_sigma`` spreads, weak modes with wide
        spreads by what their share weighs), not every mode at its own
        ``k_sigma`` at once;
        frequencies keep their nominal values
        and their uncertainty becomes a relative speed window
        ``+-k_sigma * std(log f)`` (the lobes of modes all shifted by a factor
        ``r`` are the lobes at speed ``Omega / r``): the planner takes the
        smallest limit inside that window, which keeps speeds away from steep
        lobe walls. The two are not taken at once (a 2.8-sigma corner at
        ``k_sigma = 2``): the bound is the worst over the disk of radius
        ``k_sigma`` in standardized (frequency, compliance) errors, as the
        smallest limit of :data:`REGION_CORNERS` scenarios (a narrower window
        with part of the lowering each, :func:`region_corners`); the plan
        takes the smaller of that and the nominal modes' limit over the
        job's safety factor (a plain plan's); its limit holds with
        :func:`region_confidence` (95.45 % at ``k_sigma = 2``) where the limit
        is linear in the two errors. The window at a posture is that of the modes that set the
        limit there (peak compliance at least :data:`WINDOW_SHARE` of the
        largest), not the widest of every mode: a weak mode's frequency is
        known worse and its lobes lie deeper. Modes that are not visible in a
        direction (stiffness at least :data:`INVISIBLE_K`, or none) keep it: a
        spread of a mode that a test cannot see is not a spread of its stiffness.

        Parameters
        ----------
        k_sigma : float
            Width of the bound in standard deviations (0: no bound).
        assumed : (float, float, float)
            Spread (std of log f, log zeta, log k) used where the source has
            none (the twin); empty: no bound without a source spread.
        override : (bool, bool, bool)
            Per quantity: take ``assumed`` instead of the source's spread (the
            job set that ``spread_*_pct`` key).
        mode_shifts : bool, optional
            Default :data:`MODE_SHIFTS`. Each corner in two scenarios, every
            mode that does not lead moved by ``t`` of its own frequency spread
            (for coupled modes as :data:`MODE_SHIFT_SPREAD` says: by default the
            cut's residue-weighted spread, and the largest of the directions that
            see it for a mode that can meet another within their spreads), all down
            in one and all up in the other; the window still covers the modes
            that lead. The region then holds each mode's frequency error at its
            own spread, not only a shift common to all modes (a weak mode's
            lobe flank can set the limit at a speed, e.g. above every robot
            mode at low speed, issue 27 C14). False: the joint region alone.

        Returns
        -------
        RobustBound or None
            None when ``k_sigma`` is 0 or there is no spread.
        """
        if k_sigma <= 0:
            return None
        n, nd, m = self.f_hz.shape
        job_spread = True  # the job's spread for some quantity (not the source's)
        if self.log_std is not None and np.any(self.log_std > 0):
            std = np.clip(np.nan_to_num(self.log_std, nan=0.0, posinf=0.0), 0.0, MAX_LOG_STD)
            kind = "calibrated prediction-error spread" if self.spread_calibrated else "spread"
            how = f"{self.source}'s {kind}"
            over = [bool(o) for o in override][:3] if len(assumed) == 3 else []
            job_spread = any(over)
            if job_spread:
                a = np.clip(np.asarray(assumed, dtype=np.float64), 0.0, MAX_LOG_STD)
                names = []
                for c, name in enumerate(("f", "zeta", "k")):
                    if c < len(over) and over[c]:
                        std[..., c] = a[c]
                        names.append(name)
                how += f" (the job's spread for {', '.join(names)})"
        elif len(assumed) == 3 and any(a > 0 for a in assumed):
            std = np.broadcast_to(
                np.clip(np.asarray(assumed, dtype=np.float64), 0.0, MAX_LOG_STD), (n, nd, m, 3)
            ).copy()
            how = "the job's assumed spread (the mode source has none)"
        else:
            return None
        s = k_sigma * std
        visible = np.isfinite(self.k_N_per_m) & (np.abs(self.k_N_per_m) < INVISIBLE_K)
        s = np.where(visible[..., None], s, 0.0)
        model = self.model
        if self.shapes_coupled:
            # one set of modes seen in all directions: a mode's spread is that of the
            # direction that sees it most (smallest stiffness); a direction that barely
            # sees a mode knows its stiffness there poorly, which is not the mode's spread
            kv = np.where(visible, np.abs(self.k_N_per_m), np.inf)
            most = np.argmin(kv, axis=1)  # (n, m)
            sm = np.take_along_axis(s, most[:, None, :, None], axis=1)[:, 0]  # (n, m, 3)
        else:
            sm = s.reshape(n, nd * m, 3)
        # stiffness and damping lowered together by k_sigma spreads of their product
        # k zeta (a mode's peak compliance 1 / (2 k zeta), which sets its stability
        # limit), shared in proportion to their variances: k_sigma spreads of each
        # would put the product k_sigma * (s_k + s_z) low, up to sqrt(2) x too far
        both = np.hypot(sm[..., 1], sm[..., 2])
        frac_k = np.divide(sm[..., 2] ** 2, both**2, out=np.zeros_like(both), where=both > 0)
        # a mode's peak compliance: its residue over 2 zeta omega^2
        peak_den = 2.0 * model.zeta * model.omega**2
        peak = np.abs(np.trace(model.residues, axis1=-2, axis2=-1)) / peak_den
        if MODE_LOWERING not in ("independent", "each"):
            raise ValueError(
                f"MODE_LOWERING: expected 'independent' or 'each', found {MODE_LOWERING!r}"
            )
        # the modes' errors are independent where that was measured: the calibrated
        # prediction-error spread (a network ensemble's or a job's assumed spread says
        # nothing of how its modes' errors go together: each mode at its own k_sigma)
        independent = MODE_LOWERING == "independent" and self.spread_calibrated and not job_spread
        if independent:
            # weights: each mode's peak compliance in the cut's plane (the tool's x and
            # y: what the cut's limit sees; a mode along the tool axis does not take a
            # share from them)
            cut = np.abs(model.residues[..., 0, 0]) + np.abs(model.residues[..., 1, 1])
            both = both * joint_lowering(cut / peak_den, both)
        low = np.stack([both * (1.0 - frac_k), both * frac_k], axis=-1)  # log zeta, log k
        # the speed window, per posture: the frequency spread of the modes that set the
        # stability limit (peak compliance at least WINDOW_SHARE of the largest), not
        # the largest of every mode that matters: a weak mode's frequency is known
        # worse (its small share of the compliance) and its lobes lie deeper
        matter = peak >= 0.05 * peak.max(axis=1, keepdims=True)
        lead = peak >= WINDOW_SHARE * peak.max(axis=1, keepdims=True)
        window = np.minimum(np.max(np.where(lead, sm[..., 0], 0.0), axis=1), MAX_WINDOW)
        # the joint region: the worst over the disk of radius k_sigma in standardized
        # (frequency, compliance) errors, one scenario per corner of a staircase that
        # holds it (region_corners); the frequency-only corner is the nominal's window
        # The window covers the modes that lead; each other mode is moved by its own
        # spread, all of them down in one scenario and up in the other, per corner (a weak
        # mode's lobes move alone: no speed window is that wide). Which spread:
        # MODE_SHIFT_SPREAD. The cut's residue-weighted one covers the frequency errors of
        # a mode whose shape the tests pin down; a mode that can meet another may veer
        # with it (issue 27, C14: a servo mode veering with an arm mode, their cross
        # residues 3x the model's) and keeps the largest of the directions that see it
        shift = np.zeros_like(window[:, None] * sm[..., 0])
        if MODE_SHIFTS if mode_shifts is None else bool(mode_shifts):
            f_spread = sm[..., 0]
            if MODE_SHIFT_SPREAD not in ("largest", "cut", "pairs"):
                raise ValueError(
                    "MODE_SHIFT_SPREAD: expected 'largest', 'cut' or 'pairs', found "
                    f"{MODE_SHIFT_SPREAD!r}"
                )
            if self.shapes_coupled and MODE_SHIFT_SPREAD == "largest":
                f_spread = np.max(s[..., 0], axis=1)  # 0 where a direction cannot see it
            elif self.shapes_coupled:
                # the cut (the tool's x/y plane) sees a mode through its residues there:
                # its frequency error as the cut sees it is that of those directions,
                # weighted by the share of the residue each carries
                r = np.abs(np.stack([model.residues[..., a, a] for a in range(2)], axis=1))
                tot = r.sum(axis=1, keepdims=True)
                w = np.divide(r, tot, out=np.zeros_like(r), where=tot > 0)
                f_spread = np.sqrt(np.sum(w * s[:, :2, :, 0] ** 2, axis=1))
                seen = f_spread
                # all shifted modes at once: each mode's interval widened so that the
                # m shifted modes that matter lie in theirs together with the region's
                # confidence (Sidak: each c^(1/m)), not each alone
                m_sh = np.maximum(np.sum(matter & ~lead, axis=1, keepdims=True), 1)
                f_spread = f_spread * (joint_sigma(k_sigma, m_sh) / k_sigma)
                if MODE_SHIFT_SPREAD == "pairs":
                    meet = _can_meet(model.omega, seen, matter)
                    f_spread = np.where(meet, np.max(s[..., 0], axis=1), f_spread)
            shift = np.where(lead, 0.0, f_spread)
        scenarios = []
        for c_t, c_u in region_corners():
            z_c = model.zeta * np.exp(-c_u * low[..., 0])
            r_c = model.residues * np.exp(c_u * low[..., 1])[..., None, None]
            w_c = np.asarray(np.minimum(c_t * window, MAX_WINDOW), dtype=np.float64)
            lowered = ModalModel(model.omega, z_c, r_c)  # the last: lowered the most
            if not np.any(shift > 0):
                scenarios.append((lowered, w_c))
                continue
            for sign in (-1.0, 1.0):
                g = np.exp(sign * np.minimum(c_t * shift, MAX_WINDOW))
                # at the mode's own stiffness: residues scale with omega^2
                r_s = r_c * (g**2)[..., None, None]
                scenarios.append((ModalModel(model.omega * g, z_c, r_s), w_c))
        # the spread stated: what was applied to the modes that matter
        used = sm[matter] / k_sigma if np.any(matter) else np.zeros((1, 3))
        applied = low[matter] if np.any(matter) else np.zeros((1, 2))
        return RobustBound(
            model=lowered,
            window=np.asarray(window, dtype=np.float64),
            k_sigma=float(k_sigma),
            std_max=np.asarray(used.max(axis=0), dtype=np.float64),
            how=how,
            std_median=np.asarray(np.median(used, axis=0), dtype=np.float64),
            lowered_max=np.asarray(applied.max(axis=0), dtype=np.float64),
            scenarios=tuple(scenarios),
            mode_shifts=bool(np.any(shift > 0)),
            independent=independent,
        )


@dataclass(frozen=True, eq=False)
class RobustBound:
    """What robust planning plans on (see :meth:`RobotModes.robust`).

    Attributes
    ----------
    model : ModalModel
        TCP-frame model with stiffness and damping lowered the most (by up to
        ``k_sigma`` spreads of their product, :data:`MODE_LOWERING`), batch (n,).
    window : ndarray, shape (n,)
        Relative half-width of the whole speed window (frequency uncertainty,
        ``k_sigma`` spreads): the first corner's.
    k_sigma : float
    std_max : ndarray, shape (3,)
        Largest spread used (std of log f, log zeta, log k) over the modes
        that matter (peak compliance at least 5 % of the posture's largest).
    how : str
        Where the spread came from.
    std_median : ndarray, shape (3,) or None
        Median of that spread over the same modes and postures.
    lowered_max : ndarray, shape (2,) or None
        Largest log factor by which damping and stiffness were lowered over
        the same modes (their product by ``k_sigma`` spreads of it); None:
        ``k_sigma`` spreads each.
    scenarios : tuple of (ModalModel, ndarray)
        The joint region's corners (:func:`region_corners`): TCP-frame model
        lowered part of the way and its speed window (n,); empty: ``model``
        in ``window`` (one corner, the box). With :attr:`mode_shifts` two per
        corner: every mode that does not lead moved down, then up, by its own
        frequency spread (:meth:`RobotModes.robust`).
    mode_shifts : bool
        Whether the scenarios carry mode shifts.
    independent : bool
        Whether the modes were lowered together to the worst point of the
        ``k_sigma`` ball of their independent errors (:data:`MODE_LOWERING`,
        :func:`joint_lowering`), not each by ``k_sigma`` of its own spread.
    """

    model: ModalModel
    window: FloatArray
    k_sigma: float
    std_max: FloatArray
    how: str
    std_median: FloatArray | None = None
    lowered_max: FloatArray | None = None
    scenarios: tuple[tuple[ModalModel, FloatArray], ...] = ()
    mode_shifts: bool = False
    independent: bool = False

    @property
    def confidence(self) -> float:
        """Stated probability that the true limit lies above the bound's.

        With :attr:`scenarios` the joint region's (:func:`region_confidence`);
        without, the one-sided normal probability of each quantity's bound.
        """
        if self.scenarios:
            return region_confidence(self.k_sigma)
        return 0.5 * (1.0 + math.erf(self.k_sigma / math.sqrt(2.0)))

    def corners(self) -> tuple[tuple[ModalModel, FloatArray], ...]:
        """The scenarios planned on: (lowered model, speed window (n,)) each."""
        return self.scenarios or ((self.model, self.window),)

    def describe(self) -> dict[str, object]:
        """JSON-ready statement of the bound."""
        _, sz, sk = (float(v) for v in self.std_max)
        ks = self.k_sigma
        lz, lk = (ks * sz, ks * sk) if self.lowered_max is None else self.lowered_max
        return {
            "k_sigma": ks,
            "confidence_pct": round(100.0 * self.confidence, 2),
            "spread_from": self.how,
            "frequency_window_pct_max": round(100.0 * float(np.max(self.window, initial=0.0)), 3),
            "frequency_window_pct_median": round(
                100.0 * float(np.median(self.window)) if self.window.size else 0.0, 3
            ),
            "stiffness_lowered_to_pct": round(100.0 * math.exp(-float(lk)), 2),
            "damping_lowered_to_pct": round(100.0 * math.exp(-float(lz)), 2),
            "spread_pct_median": None
            if self.std_median is None
            else {
                q: round(100.0 * math.expm1(float(v)), 3)
                for q, v in zip(("f", "zeta", "k"), self.std_median, strict=True)
            },
            "spread_pct_max": {
                q: round(100.0 * math.expm1(float(v)), 3)
                for q, v in zip(("f", "zeta", "k"), self.std_max, strict=True)
            },
            "statement": (
                f"the frequencies of the modes that set the limit within "
                f"+-{100 * float(np.max(self.window, initial=0.0)):.2g} %, "
                f"stiffness above {100 * math.exp(-float(lk)):.3g} % and damping above "
                f"{100 * math.exp(-float(lz)):.3g} % of the prediction (their product, a "
                + (
                    f"mode's peak compliance, lowered by up to k_sigma = {ks:g} spreads of "
                    f"it: the modes together, at the worst point of the ball of radius {ks:g} "
                    "in their independent errors, each as far as its share of the peak "
                    "compliance in the cut's plane weighs"
                    if self.independent
                    else f"mode's peak compliance, lowered by k_sigma = {ks:g} spreads of it"
                )
                + (
                    f"), not both at once: the worst over the disk of radius {ks:g} in "
                    f"standardized (frequency, compliance) errors ({REGION_CORNERS} "
                    + (
                        "corners, each with every mode that does not lead at the low and at "
                        "the high end of its own frequency spread"
                        if self.mode_shifts
                        else "corners"
                    )
                    + f"; {100 * self.confidence:.1f} % if the spread is normal in log "
                    "and the limit linear in the errors); "
                    if self.scenarios
                    else f": {100 * self.confidence:.1f} % one-sided if the spread is normal "
                    "in log); "
                )
                + "planned at margin 1 on this bound and the safety factor on the prediction"
            ),
        }


def bound_scenario(model: ModalModel, safety_factor: float) -> ModalModel:
    """The robust bound's tool-point model as the planner's scenario: held at margin 1.

    A robust plan keeps the job's safety factor on the nominal modes and a
    margin of at least 1 on the bound (the bound is itself the margin for
    the quantified error: ``k_sigma`` spreads), so that its limit at each
    waypoint is ``min(a_nominal / SF, a_bound)`` (each corner of the bound's
    joint region taken at its smallest over its own speed window,
    :func:`robolobe.plan.lobes.waypoint_lobes`; the nominal term as a plain
    plan takes it, without a window): a robust plan never gives
    less than a plain plan that is stable on the bound, and never more than
    the plain plan. Receptance is linear in the residues and the stability
    limit inverse in them, so dividing the bound's residues by ``SF`` puts
    ``SF * a_bound`` among the scenarios whose smallest limit is divided by
    ``SF``.

    Parameters
    ----------
    model : ModalModel
        The bound's tool-point (feed-frame) model, batch (n,).
    safety_factor : float
        The job's ``plan.safety_factor`` (>= 1).

    Returns
    -------
    ModalModel
    """
    sf = float(safety_factor)
    if sf == 1.0:
        return model
    return ModalModel(model.omega, model.zeta, model.residues / sf)


def plan_bound(
    plan: object, modes: RobotModes, robust: bool | None = None
) -> tuple[RobustBound | None, bool]:
    """The robust bound a job's plan settings ask for on these modes.

    Parameters
    ----------
    plan : PlanSpec
        The job's ``plan`` (``robust``, ``k_sigma``, ``assumed_spread``,
        ``spread_set``).
    modes : RobotModes
    robust : bool, optional
        Overrides ``plan.robust``.

    Returns
    -------
    bound : RobustBound or None
    robust : bool
        Whether the plan is robust: ``plan.robust`` when set, else (the job
        does not say) whether the modes carry a calibrated spread
        (:attr:`RobotModes.spread_calibrated`, a ``CorrectedTwin``).
    """
    want = getattr(plan, "robust", None) if robust is None else robust
    if want is None:
        want = bool(modes.spread_calibrated)
    if not want:
        return None, False
    bound = modes.robust(
        float(getattr(plan, "k_sigma", 2.0)),
        tuple(getattr(plan, "assumed_spread", ())),
        tuple(getattr(plan, "spread_set", (False, False, False))),
    )
    return bound, True


class ModeSource(Protocol):
    """Anything that predicts robot modes at postures."""

    name: str

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        """Modes at postures ``q_rad`` (n, 6)."""
        ...


class PredictorSource:
    """Modes from a fitted :class:`robolobe.tl.estimator.ModalPredictor`.

    Parameters
    ----------
    predictor : ModalPredictor
    name : str
        Description for reports.
    """

    def __init__(self, predictor: object, name: str) -> None:
        self.predictor = predictor
        self.name = name

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        q = np.asarray(q_rad, dtype=np.float64).reshape(-1, 6)
        pred = self.predictor.predict(q, warn=False)  # type: ignore[attr-defined]
        params = pred.parameters()
        bad = [d for d in params.directions if d not in DRIVING]
        if bad:
            raise InputError(f"model direction {bad[0]!r}: expected driving points xx, yy, zz")
        params = params.select(DRIVING)
        # relative spread (std of log value) whatever the model's output kind; unknown: none
        std = np.nan_to_num(np.asarray(params.log_std), nan=0.0, posinf=0.0)
        params = dataclasses.replace(params, log_std=std)
        extr = np.asarray(self.predictor.extrapolation(q))  # type: ignore[attr-defined]
        model = ModalModel.from_parameters(params)
        extra = getattr(self.predictor, "extra_", None)
        if extra is not None and extra.n_tracks_:
            # measured modes beyond the network's (robolobe.tl.extra_modes)
            f, z, k, std, model = _with_extra_modes(
                extra.predict(q, DRIVING), params.f_hz, params.zeta, params.k_N_per_m, std, model
            )
            params = ModalParameters(f, z, k, DRIVING, log_std=std)
        return RobotModes(
            parameters=params,
            model=model,
            extrapolation=extr,
            source=self.name,
        )


class TwinSource:
    """Exact nominal modes of the robot file (no spread unless given).

    Parameters
    ----------
    robot : Robot
    effects : sequence of Effect
        Physics effects added to the twin.
    spread : (float, float, float), optional
        Spread of its modes (std of log f, log zeta, log k), e.g. a calibrated
        twin's residual scatter (:attr:`robolobe.tl.graybox.TwinCalibration.residual_rms_`);
        default none (robust plans then take the job's assumed spread).
    """

    def __init__(
        self,
        robot: Robot,
        effects: Sequence[Effect] = (),
        spread: Sequence[float] | None = None,
    ) -> None:
        from robolobe.twin.model import Twin

        self.twin = Twin(robot, tuple(effects))
        names = ", ".join(e.name for e in effects)
        self.name = f"twin of {robot.name}" + (f" + {names}" if names else "")
        if spread is not None:
            sp = np.asarray(spread, dtype=np.float64)
            if sp.shape != (3,) or not np.all(np.isfinite(sp)) or np.any(sp < 0):
                raise InputError(f"spread: expected 3 non-negative log spreads, found {spread!r}")
            self.spread: FloatArray | None = sp
        else:
            self.spread = None

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        q = np.asarray(q_rad, dtype=np.float64).reshape(-1, 6)
        # an overdamped joint mode (a heavily damped wrist) is kept as its real poles'
        # frequency and damping ratio >= 1: no resonance, but its compliance counts
        md = self.twin.modes(q, overdamped="keep")
        f = np.asarray(md.f_hz)  # (n, m)
        z = np.asarray(md.zeta)
        u = np.asarray(md.tcp_shapes)  # (n, 3, m)
        n, m = f.shape
        keep = np.isfinite(f) & (f > 0) & np.isfinite(z) & (z > 0)
        model = ModalModel.from_shapes(
            2 * np.pi * np.where(keep, f, 1.0),
            np.where(keep, z, 0.05),
            np.swapaxes(np.where(keep[:, None, :], u, 0.0), -1, -2),
        )
        params = md.parameters(DRIVING)
        if self.spread is not None:
            params = dataclasses.replace(params, log_std=np.broadcast_to(self.spread, (n, 3, m, 3)))
        return RobotModes(
            parameters=params,
            model=model,
            extrapolation=None,
            source=self.name,
            shapes_coupled=True,
        )


class CorrectedTwinSource:
    """Modes of a fitted :class:`robolobe.tl.residual.CorrectedTwin`, coupled, with spread.

    The calibrated twin's modes (mode shapes, hence the cross terms a feed
    direction between the axes sees) with the learned correction: each twin
    mode's frequency and damping moved by the correction of the tested
    directions (weighted by how much of the process each uses,
    ``alpha_``), its stiffness at each tested direction by that direction's
    (the shape's component scaled, so ``k = omega^2 / u^2`` takes the
    corrected value). The spread is the model's
    :meth:`~robolobe.tl.residual.CorrectedTwin.planning_spread` (the error of
    the prediction, posture by posture), marked as calibrated: a job that
    leaves ``plan.robust`` unset plans robustly on it.

    Parameters
    ----------
    model : CorrectedTwin
        Fitted.
    name : str, optional
        Description for reports.
    """

    def __init__(self, model: object, name: str | None = None) -> None:
        from robolobe.tl.residual import CorrectedTwin
        from robolobe.twin.model import Twin

        if not isinstance(model, CorrectedTwin) or not hasattr(model, "calibration_"):
            raise InputError("modes: expected a fitted CorrectedTwin")
        self.model = model
        self.twin = Twin(model.robot_)
        self.name = name or f"corrected twin of {model.robot_name}"

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        from robolobe.twin.params import K_MAX

        q = np.asarray(q_rad, dtype=np.float64).reshape(-1, 6)
        ct = self.model
        md = self.twin.modes(q, overdamped="keep")  # as TwinSource
        f = np.asarray(md.f_hz, dtype=np.float64)  # (n, m)
        z = np.asarray(md.zeta, dtype=np.float64)
        u = np.asarray(md.tcp_shapes, dtype=np.float64)  # (n, 3, m)
        k = np.asarray(md.k_N_per_m, dtype=np.float64)  # (n, 3, m)
        n, m = f.shape
        dirs = tuple(ct.directions_)
        mm = min(m, int(ct.n_modes_))
        mean, _ = ct.correction(q)  # (n, n_dir, n_modes, 3), twin mode order
        alpha = np.asarray(ct.alpha_)[:, :mm]  # (n_dir, mm, 3)
        d_f = np.zeros((n, m))
        d_z = np.zeros((n, m))
        for c, out in ((0, d_f), (1, d_z)):
            w = alpha[..., c]
            wsum = w.sum(axis=0)
            num = np.einsum("jm,njm->nm", w, mean[:, :, :mm, c])
            out[:, :mm] = np.where(wsum > 0, num / np.where(wsum > 0, wsum, 1.0), 0.0)
        d_k = np.zeros((n, 3, m))
        visible = np.isfinite(k) & (np.abs(k) < K_MAX)
        for j, d in enumerate(dirs):
            ax = DRIVING.index(d)
            d_k[:, ax, :mm] = np.where(visible[:, ax, :mm], mean[:, j, :mm, 2], 0.0)
        f_new = f * np.exp(d_f)
        z_new = z * np.exp(d_z)
        # k = omega^2 / u^2 per direction: keep it at its corrected value
        u_new = u * np.exp(d_f[:, None, :] - 0.5 * d_k)
        k_new = k * np.exp(d_k)
        keep = np.isfinite(f_new) & (f_new > 0) & np.isfinite(z_new) & (z_new > 0)
        model = ModalModel.from_shapes(
            2 * np.pi * np.where(keep, f_new, 1.0),
            np.where(keep, z_new, 0.05),
            np.swapaxes(np.where(keep[:, None, :], u_new, 0.0), -1, -2),
        )
        std = np.zeros((n, 3, m, 3))
        sp = ct.planning_spread(q, directions=DRIVING, n_modes=m)  # (n, 3, m, 3)
        std[:] = np.nan_to_num(sp, nan=0.0, posinf=0.0)
        f_all = np.broadcast_to(f_new[:, None, :], (n, 3, m))
        z_all = np.broadcast_to(z_new[:, None, :], (n, 3, m))
        extra = getattr(ct, "extra_", None)
        if extra is not None and extra.n_tracks_:
            # measured modes the twin lacks (a servo, a bracket), interpolated over posture
            # with their own spread (robolobe.tl.extra_modes): driving-point residues only
            f_all, z_all, k_new, std, model = _with_extra_modes(
                extra.predict(q, DRIVING), f_all, z_all, k_new, std, model
            )
        return RobotModes(
            parameters=ModalParameters(f_all, z_all, k_new, DRIVING, log_std=std),
            model=model,
            extrapolation=ct.extrapolation(q),
            source=self.name,
            shapes_coupled=True,
            spread_calibrated=True,
        )


def _with_extra_modes(
    extra: tuple[FloatArray, FloatArray],
    f: FloatArray,
    z: FloatArray,
    k: FloatArray,
    std: FloatArray,
    model: ModalModel,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, ModalModel]:
    """Modes and model with extra modes appended (:mod:`robolobe.tl.extra_modes`).

    Parameters
    ----------
    extra : (values, log_std)
        Both of shape (n, 3, n_extra, 3) on ``xx, yy, zz`` (infinite k: not seen there).
    f, z, k : ndarray, shape (n, 3, m)
    std : ndarray, shape (n, 3, m, 3)
    model : ModalModel
        Batch (n,), m modes, dim 3.

    Returns
    -------
    f, z, k, std : ndarray, shapes (n, 3, m + n_extra) and (n, 3, m + n_extra, 3)
    model : ModalModel
        The extra modes with diagonal residues ``omega^2 / k`` per axis.
    """
    ev, es = extra
    fe, ze, ke = ev[:, 0, :, 0], ev[:, 0, :, 1], ev[..., 2]  # (n, T), (n, T), (n, 3, T)
    we = 2.0 * np.pi * fe
    with np.errstate(divide="ignore"):
        diag = np.where(np.isfinite(ke), we[:, None, :] ** 2 / ke, 0.0)  # (n, 3, T)
    res = np.zeros((*fe.shape, 3, 3))
    for a in range(3):
        res[..., a, a] = diag[:, a]
    out = model.concat(ModalModel(we, ze, res))
    return (
        np.concatenate([f, ev[..., 0]], axis=2),
        np.concatenate([z, ev[..., 1]], axis=2),
        np.concatenate([k, ke], axis=2),
        np.concatenate([std, es], axis=2),
        out,
    )


class ParametersSource:
    """Modes given as :class:`~robolobe._modal_parameters.ModalParameters`.

    One posture: the same modes at every posture (a robot whose modes are
    known at the working posture only, a stiff machine). Several postures:
    each queried posture must be one of ``parameters.q_rad`` (within 1e-9
    rad), e.g. modes computed beforehand for a path's postures. The spread
    is the parameters' (unknown spread: none). Per-direction modes, no cross
    terms, as a predictor's.

    Parameters
    ----------
    parameters : ModalParameters
        On driving points (missing ones are absent).
    name : str
        Description for reports.
    """

    def __init__(self, parameters: ModalParameters, name: str = "given modal parameters") -> None:
        if not isinstance(parameters, ModalParameters):
            raise InputError(f"modes: expected ModalParameters, found {type(parameters).__name__}")
        bad = [d for d in parameters.directions if d not in DRIVING]
        if bad:
            raise InputError(
                f"modes: expected driving-point directions xx, yy, zz, found {bad[0]!r}"
            )
        if parameters.n_postures > 1 and parameters.q_rad is None:
            raise InputError(
                f"modes: parameters at {parameters.n_postures} postures need their joint angles "
                "(q_rad) to be looked up; give one posture for modes that do not change"
            )
        p = parameters.select(DRIVING)
        if p.log_std is not None:
            p = dataclasses.replace(p, log_std=np.nan_to_num(p.log_std, nan=0.0, posinf=0.0))
        self.parameters = p
        self.name = name

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        q = np.asarray(q_rad, dtype=np.float64).reshape(-1, 6)
        p = self.parameters
        if p.n_postures == 1:
            idx = np.zeros(q.shape[0], np.intp)
        else:
            from scipy.spatial import cKDTree

            assert p.q_rad is not None
            dist, near = cKDTree(p.q_rad).query(q, p=np.inf)
            idx = np.minimum(np.asarray(near, np.intp), p.n_postures - 1)
            miss = np.flatnonzero(np.asarray(dist) > 1e-9)
            if miss.size:
                raise InputError(
                    f"modes: posture {np.degrees(q[miss[0]]).round(6).tolist()} deg is not one "
                    f"of the {p.n_postures} postures of the given modal parameters "
                    f"({count(miss.size, 'posture')} missing); give modes at every posture of "
                    "the path, or a mode predictor"
                )
        params = ModalParameters(
            p.f_hz[idx],
            p.zeta[idx],
            p.k_N_per_m[idx],
            p.directions,
            log_std=None if p.log_std is None else p.log_std[idx],
        )
        return RobotModes(
            parameters=params,
            model=ModalModel.from_parameters(params),
            extrapolation=None,
            source=self.name,
        )


def as_mode_source(modes: object) -> ModeSource:
    """Any mode predictor as the planner's mode source.

    Parameters
    ----------
    modes : object
        A mode source (``PredictorSource``, ``TwinSource`` or anything with
        ``name`` and ``predict(q) -> RobotModes``); a :class:`Robot` (its
        twin); a fitted ``CorrectedTwin`` (:class:`CorrectedTwinSource`:
        coupled, with its calibrated spread); a fitted ``TwinCalibration``
        (the calibrated twin with its residual spread); or a fitted
        ``ModalPredictor`` (anything whose ``predict(q)`` returns a
        ``ModalPrediction`` and that has ``extrapolation(q)``); or
        :class:`~robolobe._modal_parameters.ModalParameters`
        (:class:`ParametersSource`: one posture's modes everywhere, or modes
        at the path's postures).

    Returns
    -------
    ModeSource

    Raises
    ------
    InputError
        For anything else, or an estimator that is not fitted.
    """
    if isinstance(modes, PredictorSource | TwinSource | CorrectedTwinSource | ParametersSource):
        return modes
    if isinstance(modes, ModalParameters):
        return ParametersSource(modes)
    from robolobe.tl.residual import CorrectedTwin

    if isinstance(modes, CorrectedTwin):
        return CorrectedTwinSource(modes)
    if isinstance(modes, Robot):
        return TwinSource(modes)
    robot = getattr(modes, "robot_", None)
    rms = getattr(modes, "residual_rms_", None)
    if isinstance(robot, Robot) and isinstance(rms, dict) and not hasattr(modes, "extrapolation"):
        spread = [float(rms[c]) for c in ("f", "zeta", "k")]
        return TwinSource(robot, spread=spread)
    if hasattr(modes, "predict") and hasattr(modes, "extrapolation"):
        name = type(modes).__name__
        label = getattr(modes, "robot_name", None) or getattr(modes, "robot", None)
        return PredictorSource(modes, f"{name} ({label})" if isinstance(label, str) else name)
    if hasattr(modes, "predict") and isinstance(getattr(modes, "name", None), str):
        return modes  # type: ignore[return-value]
    raise InputError(
        "modes: expected a mode predictor (CorrectedTwin, TwinCalibration, ModalPredictor, "
        f"ModalParameters, a Robot or a mode source), found {type(modes).__name__}"
    )


def mode_source(
    model: str, robot: Robot, robot_key: str, effects: Sequence[Effect] = ()
) -> tuple[ModeSource, str]:
    """The mode source a job asks for.

    Parameters
    ----------
    model : str
        ``"twin"`` (the robot file's own modes: the default), ``"builtin"``
        (the shipped tl model of A, B or C) or the path of a tl model file (a
        corrected twin from ``robolobe transfer --robot R`` becomes a
        :class:`CorrectedTwinSource`, a network a :class:`PredictorSource`).
    robot : Robot
    robot_key : str
        ``"A"``, ``"B"``, ``"C"`` or the robot file.
    effects : sequence of Effect
        Physics effects added to the twin (``model = "twin"`` only).

    Returns
    -------
    (ModeSource, str)
        The source and a note (non-empty when a fallback was used).

    Raises
    ------
    InputError
        A model file that cannot be read, or ``builtin`` for a robot file.
    """
    if model == "twin":
        return TwinSource(robot, effects), ""
    if effects:
        raise InputError(
            f"robot.effects: physics effects act on the twin; expected robot.model = 'twin', "
            f"found {model!r}"
        )
    from robolobe.tl.models import load_model

    if model == "builtin":
        if robot_key not in ("A", "B", "C"):
            raise InputError(
                "robot.model: 'builtin' models exist for robots A, B and C only; for a robot "
                "file give model = 'twin' or the path of a tl model",
            )
        try:
            pred = load_model(robot_key)
        except InputError as exc:
            note = f"shipped tl model of {robot_key} unavailable ({exc}); using the twin"
            logger.info(note)
            return TwinSource(robot), note
        return PredictorSource(pred, f"tl model {robot_key} (shipped)"), ""
    from robolobe.tl.models import check_model_robot

    pred = load_model(Path(model))
    check_model_robot(pred, robot, "robot.model")
    return model_file_source(pred, Path(model).name), ""


def model_file_source(pred: object, file_name: str) -> ModeSource:
    """The mode source of a loaded model file (:func:`robolobe.tl.models.load_model`).

    A corrected twin becomes a :class:`CorrectedTwinSource`, a network a
    :class:`PredictorSource`; ``file_name`` names it in reports.
    """
    from robolobe.tl.residual import CorrectedTwin

    if isinstance(pred, CorrectedTwin):
        return CorrectedTwinSource(pred, f"corrected twin {file_name}")
    return PredictorSource(pred, f"tl model {file_name}")


#: Exact modes at every ``MODE_STRIDE``-th posture of a long path (and a check posture
#: inside each interval): :func:`interpolated_modes`.
MODE_STRIDE = 32
#: Interpolated modes agree with the exact ones at each interval's check posture within
#: this fraction of the lobe-grouping tolerance (:class:`~robolobe.plan.lobes.DynamicsTolerance`).
MODE_INTERP_FRACTION = 0.02


def _mode_arrays(md: RobotModes) -> dict[str, FloatArray]:
    """The per-posture arrays of ``md`` that :func:`interpolated_modes` interpolates
    (stiffness as compliance ``1/k``: ``inf`` is 0, and it is what the lobes see)."""
    p, m = md.parameters, md.model
    with np.errstate(divide="ignore"):
        c = 1.0 / p.k_N_per_m
    out = {
        "f": np.asarray(p.f_hz),
        "zeta": np.asarray(p.zeta),
        "c": c,
        "omega": np.asarray(m.omega),
        "mzeta": np.asarray(m.zeta),
        "res": np.asarray(m.residues),
    }
    if p.log_std is not None:
        out["log_std"] = np.asarray(p.log_std)
    if md.extrapolation is not None:
        out["extrapolation"] = np.asarray(md.extrapolation)
    return out


def _interp_errors(
    got: dict[str, FloatArray], want: dict[str, FloatArray], tol: DynamicsTolerance
) -> FloatArray:
    """Per posture, the largest error of ``got`` against ``want`` in units of the
    allowed error (:data:`MODE_INTERP_FRACTION` of the grouping tolerance ``tol``);
    ``inf`` where the finite/non-finite pattern differs or a value is non-finite."""
    fr = MODE_INTERP_FRACTION
    n = want["f"].shape[0]
    err = np.zeros(n)

    def worst(e: FloatArray) -> FloatArray:
        return np.asarray(np.fmax.reduce(e.reshape(n, -1), axis=1, initial=0.0))

    def relative(name: str, allowed: float) -> None:
        a, b = got[name], want[name]
        bad = np.isfinite(a) != np.isfinite(b)
        with np.errstate(invalid="ignore", divide="ignore"):
            e = np.abs(a - b) / (np.abs(b) * allowed)
        e = np.where(np.isfinite(b), e, 0.0)
        err[:] = np.maximum(err, np.where(bad.reshape(n, -1).any(axis=1), np.inf, worst(e)))

    relative("f", fr * tol.freq)
    relative("zeta", fr * tol.damping)
    relative("omega", fr * tol.freq)
    relative("mzeta", fr * tol.damping)
    # compliance per direction against the mode's largest (a tiny one is irrelevant)
    c_got, c_want = got["c"], want["c"]
    scale = np.fmax.reduce(np.abs(c_want), axis=1, keepdims=True) * fr * tol.residue
    with np.errstate(invalid="ignore", divide="ignore"):
        e = np.abs(c_got - c_want) / scale
    bad = np.isfinite(c_got) != np.isfinite(c_want)
    err = np.maximum(err, np.where(bad.reshape(n, -1).any(axis=1), np.inf, worst(e)))
    # residues: entries against the mode's trace (its size), a quarter of the residue
    # tolerance as the grouping features' direction entries
    r_got, r_want = got["res"], want["res"]
    tr = np.abs(np.trace(r_want, axis1=-2, axis2=-1))[..., None, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        e = np.abs(r_got - r_want) / (tr * fr * tol.residue / 4.0)
    bad = ~np.isfinite(r_got) | ~np.isfinite(r_want)
    err = np.maximum(err, np.where(bad.reshape(n, -1).any(axis=1), np.inf, worst(e)))
    for name in ("log_std", "extrapolation"):  # absolute: 1e-3 (log units, joint ranges)
        if name in want:
            e = np.abs(got[name] - want[name]) / 1e-3
            e = np.where(np.isfinite(e), e, np.where(np.isnan(want[name]), 0.0, np.inf))
            err = np.maximum(err, worst(e))
    return err


def _rebuild(md: RobotModes, arrs: dict[str, FloatArray], q: FloatArray) -> RobotModes:
    """``md``'s fields with the arrays of :func:`_mode_arrays` ``arrs`` (postures ``q``)."""
    p = md.parameters
    with np.errstate(divide="ignore"):
        k = 1.0 / arrs["c"]
    params = dataclasses.replace(
        p,
        f_hz=arrs["f"],
        zeta=arrs["zeta"],
        k_N_per_m=k,
        log_std=arrs.get("log_std"),
        q_rad=None if p.q_rad is None else q,
    )
    model = ModalModel(arrs["omega"], arrs["mzeta"], arrs["res"])
    return dataclasses.replace(
        md, parameters=params, model=model, extrapolation=arrs.get("extrapolation")
    )


def interpolated_modes(
    source: ModeSource,
    q_rad: FloatArray,
    tol: DynamicsTolerance | None = None,
    stride: int = MODE_STRIDE,
) -> RobotModes:
    """The modes of consecutive postures of a path, exact at some and interpolated between.

    The modes are predicted exactly at every ``stride``-th posture (knots)
    and at one check posture inside each interval between knots (the one
    nearest the interval's middle in joint-space path length). Where the
    linear interpolation between the knots (in joint-space path length)
    agrees with the exact modes at the check posture within
    :data:`MODE_INTERP_FRACTION` of the lobe-grouping tolerance ``tol``
    (:class:`~robolobe.plan.lobes.DynamicsTolerance`: frequency and damping
    ratio relative, the compliance ``1/k`` per direction against the mode's
    largest, each residue entry against the mode's trace, the spread and
    the extrapolation to 1e-3), the interval's other postures are
    interpolated piecewise linearly through the knots and the check
    posture; elsewhere (a mode crossing, a fast change, a check posture off
    the middle, a non-finite value) every posture of the interval is
    predicted exactly. For modes that vary smoothly along the path the
    error between the exact postures is then about a quarter of the error
    checked (half the spacing).

    Parameters
    ----------
    source : ModeSource
    q_rad : ndarray, shape (n, 6)
        Postures in path order [rad].
    tol : DynamicsTolerance, optional
        The grouping tolerance of the lobes these modes feed (default: its
        defaults); an exact one (all zero) predicts every posture exactly.
    stride : int
        Postures per interval; 1 (or a path shorter than ``4 * stride``):
        every posture exact.

    Returns
    -------
    RobotModes
        As ``source.predict(q_rad)``, within the tolerance above.
    """
    from robolobe.plan.lobes import DynamicsTolerance

    tol = DynamicsTolerance() if tol is None else tol
    q = np.asarray(q_rad, dtype=np.float64).reshape(-1, 6)
    n = q.shape[0]
    if stride < 2 or n < 4 * stride or tol.exact or min(tol.freq, tol.damping, tol.residue) <= 0:
        return source.predict(q)
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))]
    knots = np.r_[np.arange(0, n - 1, stride), n - 1]
    a, b = knots[:-1], knots[1:]
    inner = b - a >= 2
    a, b = a[inner], b[inner]
    half = 0.5 * (s[a] + s[b])
    c = np.clip(np.searchsorted(s, half), a + 1, b - 1)
    left = np.maximum(c - 1, a + 1)
    c = np.where(np.abs(s[left] - half) < np.abs(s[c] - half), left, c)
    span = s[b] - s[a]
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(span > 0, (s[c] - s[a]) / span, (c - a) / (b - a))
    exact = np.union1d(knots, c)
    md = source.predict(q[exact])
    if md.parameters.posture_ids is not None:  # named postures: not interpolated
        return source.predict(q)
    arrs = _mode_arrays(md)
    at = {name: v[np.searchsorted(exact, c)] for name, v in arrs.items()}
    va = {name: v[np.searchsorted(exact, a)] for name, v in arrs.items()}
    vb = {name: v[np.searchsorted(exact, b)] for name, v in arrs.items()}
    guess = {}
    for name in arrs:
        ww = w.reshape(-1, *([1] * (arrs[name].ndim - 1)))
        guess[name] = va[name] + ww * (vb[name] - va[name])
    ok = (_interp_errors(guess, at, tol) <= 1.0) & (w >= 0.25) & (w <= 0.75)
    redo = [np.arange(i + 1, j) for i, j in zip(a[~ok], b[~ok], strict=True)]
    more = np.setdiff1d(np.concatenate(redo), exact) if redo else np.empty(0, np.int64)
    if more.size:
        # all postures of the intervals that failed: exact
        md2 = source.predict(q[more])
        arrs2 = _mode_arrays(md2)
        allx = np.r_[exact, more]
        order = np.argsort(allx, kind="stable")
        exact = allx[order]
        arrs = {k: np.concatenate([arrs[k], arrs2[k]])[order] for k in arrs}
    if exact.size == n:
        return _rebuild(md, arrs, q)
    # every other posture: linear between its exact neighbours (in path length)
    rest = np.setdiff1d(np.arange(n), exact)
    j = np.searchsorted(exact, rest)
    lo, hi = exact[j - 1], exact[j]
    span = s[hi] - s[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(span > 0, (s[rest] - s[lo]) / span, 0.0)
    out = {}
    for name, v in arrs.items():
        full = np.empty((n, *v.shape[1:]))
        full[exact] = v
        tt = t.reshape(-1, *([1] * (v.ndim - 1)))
        v_lo, v_hi = v[j - 1], v[j]
        full[rest] = v_lo + tt * (v_hi - v_lo)
        out[name] = full
    return _rebuild(md, out, q)
