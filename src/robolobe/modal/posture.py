"""Modal identification of one posture: checks, pLSCF, stabilization, selection, LSFD.

Pipeline (:func:`identify_posture`):

1. FRF checks (:mod:`robolobe.modal.quality`); directions with errors are left out.
2. Weights per line: ``1 / (1 + (fmin / f)^2)`` over the FRF's RMS (hammer-test
   receptance is noise below a few Hz: accelerometer noise divided by ``w^2``),
   times the coherence squared when it is given.
3. pLSCF over a range of orders on all usable directions together:
   poly-reference when at least two excitation columns are complete (the
   participation vectors then are the 3-direction shape), otherwise the
   common-denominator form on every usable FRF.
4. Stabilization diagram and clustering selection of physical poles.
5. Nonlinear refinement of the poles on the weighted FRFs (optional).
6. LSFD (residues, lower and upper residuals) on every usable FRF.
7. Corrections: exponential window (``sigma_true = sigma_est - ln(w_end)/T``,
   i.e. ``Re(lambda)`` moved right by the window's decay rate) and, when the
   record length ``T`` is known, the truncation of the windowed response
   (``R = R_est / (1 - exp(lambda_w T))``, exact for DFT lines of a
   transient record).
8. Modal stiffness per driving point ``k = Re(w^2 / (2 i w_d R_dd))`` and
   visibility (peak of the mode's term over the peak of the measured FRF).
9. Residue signs (check ``sign``): a mode is kept whatever the sign of its
   residue, and ``k`` carries that sign.

Sign convention: with ``H(w) = sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i
zeta_r w_r w)``, ``k_r > 0`` means that at resonance the response lags the
force by 90 deg (``Im H < 0``), as it does for every mode of a driving point
measured with consistent sensor and hammer polarity. ``k_r < 0`` at a
driving point is impossible physically: it shows a transfer FRF (response
and excitation at different points, where shape components of opposite sign
give residues of both signs) or a reversed polarity (all residues negative).
Both are reported; the modal dataset cannot hold a negative driving-point
stiffness, so such modes are identified, tracked, numbered and plotted but
left out of ``modal.csv`` with the finding repeated in the summary.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import AXES, DRIVING
from robolobe._modal_parameters import ModalParameters
from robolobe._text import count
from robolobe.campaign.metrics import frac, nrmse
from robolobe.errors import InputError
from robolobe.modal.lsfd import LSFDResult, lsfd, modal_stiffness
from robolobe.modal.plscf import plscf
from robolobe.modal.quality import QualityIssue, check_posture_frfs, usable_directions
from robolobe.modal.refine import refine_poles
from robolobe.modal.selection import SelectedPoles, SelectionSettings, select_poles
from robolobe.modal.stabilization import (
    StabilizationCriteria,
    StabilizationDiagram,
    stabilization_diagram,
)
from robolobe.modal.synthesis import poles_to_modal, synthesize_frf

__all__ = [
    "SIGN_CONVENTION",
    "IdentifySettings",
    "PostureModal",
    "clean_poles",
    "identify_posture",
    "posture_weights",
    "refit_posture",
    "sign_issues",
]

#: One line stating the residue sign convention (printed by ``robolobe identify``).
SIGN_CONVENTION = (
    "sign convention: H(w) = sum_r (w_r^2/k_r) / (w_r^2 - w^2 + 2i zeta_r w_r w); k > 0 for "
    "every mode of a driving point; k < 0: transfer FRF (shape signs differ) or reversed polarity"
)


@dataclass(frozen=True, kw_only=True)
class IdentifySettings:
    """Settings of the modal identification (all keyword-only).

    Parameters
    ----------
    fmin_hz, fmax_hz : float
        Analysis band, Hz: physical poles lie in it and FRAC/NRMSE are
        computed on it. Hammer-test receptance below ~4 Hz is mostly noise.
    fit_margin : float
        The fit uses lines from ``fmin_hz / 2`` to ``fmax_hz * (1 + fit_margin)``
        (when the data reach that far) so that modes at the band edges are
        well captured.
    max_order : int or None
        Highest pLSCF order; default ``ceil(40 / m)`` + 2 for ``m`` references
        (about 40 poles per order at the top).
    criteria : StabilizationCriteria
    selection : SelectionSettings
    refine : bool
        Nonlinear refinement of the selected poles.
    refine_jacobian : {"analytic", "fd"}
        Jacobian of the refinement (:func:`robolobe.modal.refine.refine_poles`);
        ``"fd"`` (finite differences) is the slower reference.
    n_modes : int or None
        Most modes per direction written to the modal dataset (the seed: 5).
        None (the default): every mode the stabilization diagram selects as
        physical (:func:`robolobe.modal.selection.select_poles`) that the
        driving point sees (:meth:`PostureModal.modes_for_direction`:
        visibility and residue precision), however many: a robot measured
        in a lab often shows modes its twin lacks (a servo, a bracket).
    visibility_min : float
        A mode counts at a driving point when the peak of its term
        ``|R_dd| / sigma`` is at least this fraction of the largest
        measured ``|H_dd|`` in the band, or at least ``local_visibility_min``
        of the largest within 10 % of its own frequency and a tenth of
        ``visibility_min`` of the band's (a bracket or tool mode far above
        the arm's: small against the band's peak, the FRF's main feature
        where it is) ...
    local_visibility_min : float
        See ``visibility_min`` (1: the band's peak alone decides).
    k_rel_std_max : float
        ... and the relative standard deviation of its driving-point residue
        (from the LSFD covariance) is at most this.
    window_decay_per_s : float
        Decay rate added by an exponential window, ``-ln(w_end) / T``, 1/s
        (0: no window).
    record_length_s : float or None
        Length ``T`` of the time records the FRFs come from; enables the
        truncation correction of the residues. ``None``: no correction.
    coherence_min : float
        Quality check threshold.
    """

    fmin_hz: float = 4.0
    fmax_hz: float = 40.0
    fit_margin: float = 0.15
    max_order: int | None = None
    criteria: StabilizationCriteria = field(default_factory=StabilizationCriteria)
    selection: SelectionSettings = field(default_factory=SelectionSettings)
    refine: bool = True
    refine_jacobian: str = "analytic"
    n_modes: int | None = None
    visibility_min: float = 0.03
    local_visibility_min: float = 0.5
    k_rel_std_max: float = 0.25
    window_decay_per_s: float = 0.0
    record_length_s: float | None = None
    coherence_min: float = 0.9

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> InputError:
            return InputError(
                f"expected {expected}, found {getattr(self, name)!r}",
                source=f"IdentifySettings.{name}",
            )

        if not (math.isfinite(self.fmin_hz) and self.fmin_hz > 0):
            raise bad("fmin_hz", "a positive number")
        if not (math.isfinite(self.fmax_hz) and self.fmax_hz > self.fmin_hz):
            raise bad("fmax_hz", f"a number > fmin_hz = {self.fmin_hz}")
        if not 0 <= self.fit_margin <= 1:
            raise bad("fit_margin", "a number in [0, 1]")
        if self.max_order is not None and not (
            isinstance(self.max_order, int) and self.max_order >= 2
        ):
            raise bad("max_order", "an integer >= 2 or None")
        if self.refine_jacobian not in ("analytic", "fd"):
            raise bad("refine_jacobian", "'analytic' or 'fd'")
        if self.n_modes is not None and not (
            isinstance(self.n_modes, int)
            and not isinstance(self.n_modes, bool)
            and self.n_modes >= 1
        ):
            raise bad("n_modes", "an integer >= 1 or None")
        if not 0 <= self.visibility_min < 1:
            raise bad("visibility_min", "a number in [0, 1)")
        if not 0 < self.local_visibility_min <= 1:
            raise bad("local_visibility_min", "a number in (0, 1]")
        if not (math.isfinite(self.window_decay_per_s) and self.window_decay_per_s >= 0):
            raise bad("window_decay_per_s", "a number >= 0")
        if self.record_length_s is not None and not (
            math.isfinite(self.record_length_s) and self.record_length_s > 0
        ):
            raise bad("record_length_s", "a positive number or None")


@dataclass(frozen=True, eq=False)
class PostureModal:
    """Modes identified at one posture.

    Attributes
    ----------
    posture_id : str
    modes : ModalParameters
        The identified modes, shape (1, 3, n_modes) on the driving points
        ``xx, yy, zz``: natural frequency (Hz) and damping ratio,
        window-corrected, rising, the same in every direction (one physical
        mode); the driving-point modal stiffness (N/m), signed like the
        residue (module docstring: negative means a transfer FRF or a
        reversed polarity), NaN where the driving point was not measured;
        the spread of log k is the LSFD relative standard deviation of the
        driving-point residue (NaN for log f and log zeta: unknown). Modes
        between ``fmax_hz`` and the top of the fit band are included (fitted
        so that they do not distort the in-band residues) but are never
        "visible" (:meth:`modes_for_direction`). :attr:`f_hz`, :attr:`zeta`,
        :attr:`k_N_per_m` and :attr:`k_rel_std` are views of it.
    poles : ndarray of complex, shape (n_modes,)
        Corrected poles, rad/s.
    poles_measured : ndarray of complex, shape (n_modes,)
        Poles as they appear in the (windowed) measured FRFs, rad/s.
    residues : ndarray of complex, shape (n_modes, 3, 3)
        Residues (corrected for truncation when the record length is known);
        NaN for directions not used.
    visibility : ndarray, shape (3, n_modes)
        Peak of the mode's term over the largest measured ``|H_dd|`` in the
        band, or over the largest within 10 % of its frequency times
        ``visibility_min / local_visibility_min`` when that is larger and the
        first is at least ``visibility_min / 10`` (one threshold,
        ``visibility_min``, for both: :class:`IdentifySettings`).
    shapes : ndarray, shape (n_modes, 3)
        TCP shape estimate ``u`` (m/sqrt(kg)), signed when the full 3x3 FRF
        matrix was measured, else magnitudes ``w / sqrt(k)``.
    signed_shapes : bool
    used : ndarray of bool, shape (3, 3)
        Directions used in the identification.
    issues : tuple of QualityIssue
    diagram : StabilizationDiagram or None
    selected : SelectedPoles or None
    lsfd : LSFDResult or None
        Fit in the measured domain (windowed poles, uncorrected residues).
    freq_hz : ndarray, shape (n_freq,)
        Fitting band lines.
    H : ndarray of complex, shape (n_freq, 3, 3)
        Measured FRFs on the fitting band.
    weights : ndarray, shape (n_freq, 3, 3)
        Noise weights used.
    settings : IdentifySettings
    """

    posture_id: str
    modes: ModalParameters
    poles: NDArray[np.complex128]
    poles_measured: NDArray[np.complex128]
    residues: NDArray[np.complex128]
    visibility: NDArray[np.float64]
    shapes: NDArray[np.float64]
    signed_shapes: bool
    used: NDArray[np.bool_]
    issues: tuple[QualityIssue, ...]
    diagram: StabilizationDiagram | None
    selected: SelectedPoles | None
    lsfd: LSFDResult | None
    freq_hz: NDArray[np.float64]
    H: NDArray[np.complex128]
    weights: NDArray[np.float64]
    settings: IdentifySettings = field(repr=False)

    @property
    def n_modes(self) -> int:
        """Number of identified modes."""
        return self.modes.n_modes

    @property
    def f_hz(self) -> NDArray[np.float64]:
        """Natural frequencies (Hz), window-corrected, rising, shape (n_modes,)."""
        return self.modes.f_hz[0, 0]

    @property
    def zeta(self) -> NDArray[np.float64]:
        """Damping ratios, window-corrected, shape (n_modes,)."""
        return self.modes.zeta[0, 0]

    @property
    def k_N_per_m(self) -> NDArray[np.float64]:
        """Signed driving-point modal stiffness (N/m) per direction x, y, z, shape (3, n_modes).

        NaN where the driving point was not measured.
        """
        return self.modes.k_N_per_m[0]

    @property
    def k_rel_std(self) -> NDArray[np.float64]:
        """Relative standard deviation of the driving-point residue, shape (3, n_modes).

        From the LSFD covariance, about that of the modal stiffness.
        """
        assert self.modes.log_std is not None
        return self.modes.log_std[0, ..., 2]

    def modes_for_direction(self, d: int) -> NDArray[np.intp]:
        """Modes visible at driving point ``d`` (0, 1, 2), whatever the sign of their residue.

        Visible: in the analysis band, ``k`` finite and non-zero,
        ``visibility >= visibility_min`` and the residue's relative standard
        deviation ``<= k_rel_std_max``. ``k < 0`` (see the module's sign
        convention) is kept here and reported by the ``sign`` check.
        """
        k = self.k_N_per_m[d]
        vis = self.visibility[d]
        prec = np.nan_to_num(self.k_rel_std[d], nan=0.0) <= self.settings.k_rel_std_max
        in_band = (self.f_hz >= self.settings.fmin_hz) & (self.f_hz <= self.settings.fmax_hz)
        ok = np.isfinite(k) & (k != 0) & (vis >= self.settings.visibility_min) & prec & in_band
        return np.flatnonzero(ok)

    def parameters(self, *, visible_only: bool = False) -> ModalParameters:
        """The identified modes on the measured driving points (:attr:`modes`, selected).

        Parameters
        ----------
        visible_only : bool, default False
            Leave out (NaN) the modes not visible at a driving point
            (:meth:`modes_for_direction`: what ``modal.csv`` lists).

        Returns
        -------
        ModalParameters
            Shape (1, n_driving_points_measured, n_modes) (order ``xx, yy,
            zz``), posture id set.
        """
        axes = [d for d in range(3) if self.used[d, d]]
        p = self.modes.select(tuple(DRIVING[d] for d in axes))
        if not visible_only:
            return p
        vals = p.stacked()
        assert p.log_std is not None
        std = p.log_std.copy()
        for j, d in enumerate(axes):
            hide = np.ones(self.n_modes, bool)
            hide[self.modes_for_direction(d)] = False
            vals[0, j, hide] = np.nan
            std[0, j, hide] = np.nan
        return ModalParameters.from_stacked(
            vals, p.directions, log_std=std, posture_ids=p.posture_ids
        )

    def negative_modes(self, d: int) -> NDArray[np.intp]:
        """Visible modes of driving point ``d`` with a negative residue (``k < 0``)."""
        idx = self.modes_for_direction(d)
        return idx[self.k_N_per_m[d, idx] < 0]

    def measured_zeta(self) -> NDArray[np.float64]:
        """Damping ratios as seen in the windowed data, shape (n_modes,)."""
        return poles_to_modal(self.poles_measured)[1]

    def synthesize_direction(
        self,
        d: int,
        modes: Sequence[int] | NDArray[np.intp] | None = None,
        freq_hz: ArrayLike | None = None,
        *,
        measured_domain: bool = True,
    ) -> NDArray[np.complex128]:
        """Driving-point FRF from modal parameters (f, zeta, k), shape (n_freq,).

        Parameters
        ----------
        d : int
            Direction 0, 1, 2.
        modes : sequence of int, optional
            Modes to include (default: those visible at ``d``).
        freq_hz : array_like, optional
            Frequencies (default: the fitting band lines).
        measured_domain : bool
            Use the damping as seen in the windowed data (to compare with the
            measured FRF); False gives the true-damping FRF.
        """
        idx = self.modes_for_direction(d) if modes is None else np.asarray(modes, dtype=int)
        f = self.freq_hz if freq_hz is None else np.asarray(freq_hz, dtype=float)
        z = self.measured_zeta() if measured_domain else self.zeta
        fn = self.f_hz if not measured_domain else poles_to_modal(self.poles_measured)[0]
        return synthesize_frf(fn[idx], z[idx], self.k_N_per_m[d, idx], f)

    def fit_quality(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """FRAC and NRMSE per driving point of the modal-parameter FRF vs the measured one.

        Evaluated on the analysis band ``fmin_hz..fmax_hz`` with the modes
        visible at each driving point (what the modal dataset holds), damping
        as seen through the window.

        Returns
        -------
        frac, nrmse : ndarray, shape (3,)
            NaN for directions not measured.
        """
        s = self.settings
        band = (self.freq_hz >= s.fmin_hz) & (self.freq_hz <= s.fmax_hz)
        fr = np.full(3, np.nan)
        nr = np.full(3, np.nan)
        for d in range(3):
            if not self.used[d, d]:
                continue
            hm = self.H[band, d, d]
            hp = self.synthesize_direction(d, freq_hz=self.freq_hz[band])
            fr[d] = float(frac(hp, hm))
            nr[d] = float(nrmse(hp, hm))
        return fr, nr


def posture_weights(
    freq_hz: NDArray[np.float64],
    H: NDArray[np.complex128],
    *,
    coherence: NDArray[np.float64] | None,
    fmin_hz: float,
) -> NDArray[np.float64]:
    """Noise weights (inverse standard deviation, up to a common factor), shape of ``H``.

    ``1 / (rms|H| (1 + (fmin / f)^2))`` per FRF: about uniform in the band, rolling
    off below ``fmin`` where hammer-test receptance is accelerometer noise over
    ``w^2``; times ``g^2`` when the coherence ``g^2`` is given. (Weights
    ``~ 1 / sigma_H`` from the coherence, which grow as ``1 / |H|``, gave worse
    damping estimates in simulated tests: they put nearly all weight on the one
    or two lines at a lightly damped peak.)
    """
    f = np.asarray(freq_hz, dtype=float)
    fin = np.isfinite(H)
    n_fin = np.count_nonzero(fin, axis=0)
    ssq = np.sum(np.where(fin, np.abs(np.where(fin, H, 0.0)) ** 2, 0.0), axis=0)
    rms = np.sqrt(ssq / np.maximum(n_fin, 1))
    rms = np.where(rms > 0, rms, 1.0)
    with np.errstate(divide="ignore"):
        roll = 1.0 / (1.0 + (fmin_hz / np.maximum(f, 1e-9)) ** 2)
    w = roll[:, None, None] / rms[None]
    if coherence is not None:
        # lines of poor coherence count less: weight ~ g^2 (no 1/|H| emphasis,
        # which over-weights the few lines at lightly damped peaks)
        c = np.clip(np.nan_to_num(np.asarray(coherence, dtype=float), nan=0.0), 0.0, 1.0)
        w = w * c**2
    w = np.where(np.isfinite(H), w, 0.0)
    return np.asarray(w, dtype=float)


def _shapes(
    poles: NDArray[np.complex128], residues: NDArray[np.complex128], used: NDArray[np.bool_]
) -> tuple[NDArray[np.float64], bool]:
    """TCP shape per mode from the residues: signed when the 3x3 block is complete."""
    n = poles.size
    wd = poles.imag
    full = bool(used.all())
    u = np.zeros((n, 3))
    for r in range(n):
        A = 2j * wd[r] * residues[r]  # ~ u u^T (proportional damping)
        if full:
            S = 0.5 * (A + A.T).real
            vals, vecs = np.linalg.eigh(S)
            j = int(np.argmax(np.abs(vals)))
            v = vecs[:, j] * np.sqrt(abs(vals[j]))
            u[r] = v * np.sign(v[np.argmax(np.abs(v))])
        else:
            dd = np.diagonal(A).real
            u[r] = np.sqrt(np.clip(np.nan_to_num(dd, nan=0.0), 0.0, None))
    return u, full


def _modes(
    pid: str,
    f_hz: NDArray[np.float64],
    zeta: NDArray[np.float64],
    k_N_per_m: NDArray[np.float64],
    k_rel_std: NDArray[np.float64],
) -> ModalParameters:
    """The :attr:`PostureModal.modes` of per-mode f, zeta (n,) and per-axis k, k_rel_std (3, n)."""
    n = f_hz.size
    std = np.full((1, 3, n, 3), np.nan)
    std[0, ..., 2] = k_rel_std
    return ModalParameters(
        np.broadcast_to(f_hz, (1, 3, n)),
        np.broadcast_to(zeta, (1, 3, n)),
        np.asarray(k_N_per_m, dtype=np.float64)[None],
        DRIVING,
        log_std=std,
        posture_ids=(pid,),
    )


def _empty(
    pid: str,
    issues: list[QualityIssue],
    s: IdentifySettings,
    f: NDArray,
    h: NDArray,
    w: NDArray,
    used: NDArray[np.bool_],
    diagram: StabilizationDiagram | None = None,
    selected: SelectedPoles | None = None,
) -> PostureModal:
    z = np.zeros(0)
    return PostureModal(
        posture_id=pid,
        modes=_modes(pid, z, z, np.zeros((3, 0)), np.zeros((3, 0))),
        poles=z.astype(complex),
        poles_measured=z.astype(complex),
        residues=np.zeros((0, 3, 3), complex),
        visibility=np.zeros((3, 0)),
        shapes=np.zeros((0, 3)),
        signed_shapes=False,
        used=used,
        issues=tuple(issues),
        diagram=diagram,
        selected=selected,
        lsfd=None,
        freq_hz=f,
        H=h,
        weights=w,
        settings=s,
    )


def _fit_top(s: IdentifySettings, f: NDArray[np.float64]) -> float:
    """Highest frequency of a fitted pole: 2 % inside the fit band's upper edge."""
    top = min(s.fmax_hz * (1.0 + s.fit_margin), float(f[-1]) if f.size else s.fmax_hz)
    return max(s.fmax_hz, 0.98 * top)


def _refuse_absurd(pid: str, h: NDArray[np.complex128]) -> None:
    """InputError for a value no measurement gives (one ruins every fit of the posture)."""
    from robolobe._frf_checks import frf_value_problem

    if h.ndim != 3 or h.shape[1:] != (3, 3):
        return
    for r in range(3):
        for e in range(3):
            col = h[:, r, e]
            fin = np.isfinite(col)
            if not fin.any():
                continue
            prob = frf_value_problem(np.where(fin, col, 0.0))
            if prob is not None:
                raise InputError(
                    f"line {prob[0] + 1}: {prob[1]}", source=f"posture {pid!r} {AXES[r]}{AXES[e]}"
                )


def identify_posture(
    freq_hz: ArrayLike,
    H: ArrayLike,
    *,
    coherence: ArrayLike | None = None,
    settings: IdentifySettings | None = None,
    posture_id: str = "",
    extra_poles: ArrayLike | None = None,
) -> PostureModal:
    """Identify the modes of one posture from its FRFs.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies, Hz.
    H : array_like of complex, shape (n_freq, 3, 3)
        Receptance (m/N), rows response, columns excitation; NaN for
        directions not measured.
    coherence : array_like, shape (n_freq, 3, 3), optional
        Ordinary coherence, for weights and checks.
    settings : IdentifySettings, optional
    posture_id : str
        Name used in quality reports.
    extra_poles : array_like of complex, optional
        Poles (as in the measured, windowed data, rad/s) to add to the
        selected ones before refinement: used to recover a mode seen at
        neighbouring postures.

    Returns
    -------
    PostureModal
        With no modes (and an issue) if nothing usable was found.
    """
    s = settings if settings is not None else IdentifySettings()
    pid = str(posture_id)
    f_all = np.asarray(freq_hz, dtype=float)
    h_all = np.asarray(H, dtype=complex)
    coh_all = None if coherence is None else np.asarray(coherence, dtype=float)
    _refuse_absurd(pid, h_all)
    issues = check_posture_frfs(
        pid,
        f_all,
        h_all,
        band_hz=(s.fmin_hz, s.fmax_hz),
        coherence=coh_all,
        coherence_min=s.coherence_min,
    )
    if any(i.severity == "error" and i.dir == "*" for i in issues):
        return _empty(
            pid,
            issues,
            s,
            np.zeros(0),
            np.zeros((0, 3, 3), complex),
            np.zeros((0, 3, 3)),
            np.zeros((3, 3), bool),
        )
    f_hi = s.fmax_hz * (1.0 + s.fit_margin)
    band = (f_all >= 0.5 * s.fmin_hz) & (f_all <= f_hi) & (f_all > 0)
    f = f_all[band]
    h = h_all[band]
    coh = None if coh_all is None or coh_all.shape != h_all.shape else coh_all[band]
    used = usable_directions(h, issues)
    h = np.where(used[None], h, np.nan + 0j)
    w = posture_weights(f, h, coherence=coh, fmin_hz=s.fmin_hz)
    if not used.any():
        issues.append(QualityIssue(pid, "*", "nan", "error", "no usable direction"))
        return _empty(pid, issues, s, f, h, w, used)

    # --- pLSCF on all usable directions together
    full_cols = [j for j in range(3) if used[:, j].all()]
    if len(full_cols) >= 2:
        Hp = h[:, :, full_cols]  # (F, 3, m) poly-reference
        Wp = np.sqrt(np.mean(w[:, :, full_cols] ** 2, axis=2))
    else:
        ii, jj = np.nonzero(used)
        Hp = h[:, ii, jj][:, :, None]  # common denominator, each FRF an output
        Wp = w[:, ii, jj]
    m = Hp.shape[2]
    n_max = s.max_order if s.max_order is not None else math.ceil(40 / m) + 2
    n_max = max(2, min(n_max, (2 * f.size * Hp.shape[1]) // m - 2))
    orders = list(range(1, n_max + 1)) if m > 1 else list(range(2, n_max + 1, 2))
    try:
        pole_sets = plscf(f, Hp, orders, weights=Wp)
    except np.linalg.LinAlgError as exc:
        raise InputError(
            f"the pole estimation failed ({exc}): check the FRF values for outliers or wrong units",
            source=f"posture {pid!r}",
        ) from None
    # poles up to near the fit band's edge: modes just above fmax are fitted (so that
    # they do not leak into the in-band residues) but not reported
    diagram = stabilization_diagram(
        pole_sets, band_hz=(s.fmin_hz, _fit_top(s, f)), criteria=s.criteria
    )
    selected = select_poles(diagram, s.selection)
    lam = selected.poles
    n_extra = 0
    if extra_poles is not None:
        extra = np.asarray(extra_poles, dtype=complex).reshape(-1)
        n_extra = extra.size
        lam = np.concatenate([lam, extra])
    return _finish(pid, f, h, w, used, lam, n_extra, issues, diagram, selected, s)


def refit_posture(pm: PostureModal, extra_poles: ArrayLike) -> PostureModal:
    """Identify a posture again with extra starting poles (neighbour recovery).

    The extra poles (measured domain, rad/s) are refined on the posture's
    FRFs with the poles of ``pm`` fixed; an extra pole that drifts out of its
    box (5 % in frequency) is dropped.

    Parameters
    ----------
    pm : PostureModal
    extra_poles : array_like of complex, shape (n_extra,)

    Returns
    -------
    PostureModal
        ``pm`` itself when extra poles were given and every one of them was
        dropped (nothing new found; the residues are not fitted again).
    """
    extra = np.asarray(extra_poles, dtype=complex).reshape(-1)
    lam = np.concatenate([pm.poles_measured, extra])
    return _finish(
        pm.posture_id,
        pm.freq_hz,
        pm.H,
        pm.weights,
        pm.used,
        lam,
        extra.size,
        [i for i in pm.issues if i.check not in ("poles", "window")],
        pm.diagram,
        pm.selected,
        pm.settings,
        refine_only_extra=True,
        base=pm,
    )


def clean_poles(
    lam: NDArray[np.complex128], s: IdentifySettings, f: NDArray[np.float64]
) -> NDArray[np.complex128]:
    """Poles in the fit band with damping in range, rising, duplicates dropped.

    Two poles within 0.2 % in frequency and 10 % in damping are one.

    Parameters
    ----------
    lam : ndarray of complex, shape (n,)
        Poles, rad/s.
    s : IdentifySettings
    f : ndarray, shape (n_freq,)
        Fitting band lines, Hz.
    """
    fm, zm = poles_to_modal(lam)
    inb = (fm >= s.fmin_hz) & (fm <= _fit_top(s, f)) & (zm > 0) & (zm < s.criteria.zeta_max)
    lam = lam[inb]
    lam = lam[np.argsort(np.abs(lam))]
    if lam.size > 1:
        fm, zm = poles_to_modal(lam)
        dup = np.zeros(lam.size, bool)
        for i in range(1, lam.size):
            if abs(fm[i] - fm[i - 1]) < 0.002 * fm[i] and abs(zm[i] - zm[i - 1]) < 0.1 * zm[i]:
                dup[i] = True
        lam = lam[~dup]
    return lam


def sign_issues(
    pid: str,
    labels: Sequence[str],
    f_hz: NDArray[np.float64],
    k: NDArray[np.float64],
    zeta: NDArray[np.float64] | None = None,
) -> list[QualityIssue]:
    """``sign`` findings for driving-point FRFs: residues of both signs, or all negative.

    A negative mode within :data:`CLOSE_BANDWIDTHS` half-power bandwidths of
    another mode is most likely one of a close pair of complex modes
    (non-proportional damping, e.g. a heavily damped joint): its residue is
    far from -90 deg and the real-mode stiffness of its projection small
    and of either sign; the finding says so rather than blaming the wiring.

    Parameters
    ----------
    pid : str
        Posture (or measurement) name.
    labels : sequence of str, length n_frf
        Name of each driving-point FRF (e.g. ``"xx"``).
    f_hz : ndarray, shape (n_modes,)
    k : ndarray, shape (n_frf, n_modes)
        Signed modal stiffness of the visible modes, NaN where not visible.
    zeta : ndarray, shape (n_modes,), optional
        Damping ratios (for the close-pair test); without them no pair is named.
    """
    out = []
    for lab, kd in zip(labels, k, strict=True):
        vis = np.isfinite(kd) & (kd != 0)
        neg = vis & (kd < 0)
        if not neg.any():
            continue
        fs = ", ".join(f"{x:.4g}" for x in f_hz[neg])
        if neg.sum() == vis.sum():
            msg = (
                f"all {int(neg.sum())} residues negative (modes at {fs} Hz): reversed polarity "
                "(sensor or hammer the other way round, or a direction code without its sign)"
            )
        elif (pair := _close_pair(f_hz, zeta, np.flatnonzero(neg))) is not None:
            msg = (
                f"residues of both signs ({int(neg.sum())} of {int(vis.sum())} negative, at "
                f"{fs} Hz), {pair}: most likely complex modes of a close pair (non-proportional "
                "damping), whose real-mode stiffness is small and of either sign (the mode is "
                "left out of modal.csv); otherwise a transfer FRF or a sign flip"
            )
        else:
            msg = (
                f"residues of both signs ({int(neg.sum())} of {int(vis.sum())} negative, at "
                f"{fs} Hz): not a driving-point FRF (a transfer FRF between two points) or "
                "a sign flip"
            )
        out.append(QualityIssue(pid, lab, "sign", "warning", msg, float(neg.sum())))
    return out


CLOSE_BANDWIDTHS = 3.0
"""Two modes closer than this many half-power bandwidths (``2 zeta f`` of the
more damped) are a close pair for :func:`sign_issues`."""


def _close_pair(
    f_hz: NDArray[np.float64], zeta: NDArray[np.float64] | None, negative: NDArray[np.intp]
) -> str | None:
    """``"x Hz from the mode at y Hz"`` for the first negative mode with a close neighbour."""
    if zeta is None:
        return None
    for i in negative:
        gap = np.abs(f_hz - f_hz[i])
        width = 2.0 * np.maximum(zeta, zeta[i]) * np.maximum(f_hz, f_hz[i])
        near = (gap > 0) & (gap < CLOSE_BANDWIDTHS * width)
        if near.any():
            j = int(np.flatnonzero(near)[np.argmin(gap[near])])
            return f"{gap[j]:.3g} Hz from the mode at {f_hz[j]:.4g} Hz"
    return None


def _finish(
    pid: str,
    f: NDArray[np.float64],
    h: NDArray[np.complex128],
    w: NDArray[np.float64],
    used: NDArray[np.bool_],
    lam: NDArray[np.complex128],
    n_extra: int,
    issues: list[QualityIssue],
    diagram: StabilizationDiagram | None,
    selected: SelectedPoles | None,
    s: IdentifySettings,
    refine_only_extra: bool = False,
    base: PostureModal | None = None,
) -> PostureModal:
    """Refinement, LSFD, corrections, stiffness and visibility for a set of poles.

    ``base``: returned as it is when ``n_extra`` extra poles were refined and all
    were dropped (a refit that found nothing).
    """
    if lam.size == 0:
        issues.append(
            QualityIssue(pid, "*", "poles", "warning", "no stable poles found in the band")
        )
        return _empty(pid, issues, s, f, h, w, used, diagram, selected)
    if s.refine or n_extra:
        free = None
        if n_extra and refine_only_extra:
            free = np.zeros(lam.size, bool)
            free[-n_extra:] = True
        ref = refine_poles(
            f,
            h,
            lam,
            weights=w,
            zeta_max=s.criteria.zeta_max,
            free=free,
            jacobian=s.refine_jacobian,
        )
        keep = np.ones(lam.size, bool)
        if n_extra:
            keep[-n_extra:] = ~ref.at_bound[-n_extra:]
            if base is not None and not keep[-n_extra:].any():
                return base
        lam = ref.poles[keep]
    lam = clean_poles(lam, s, f)
    if lam.size == 0:
        issues.append(QualityIssue(pid, "*", "poles", "warning", "no poles left in the band"))
        return _empty(pid, issues, s, f, h, w, used, diagram, selected)
    fit = lsfd(f, h, lam, weights=w)

    # --- corrections
    lam_true = lam + s.window_decay_per_s
    R = fit.residues.copy()
    if s.record_length_s is not None:
        trunc = 1.0 - np.exp(lam * s.record_length_s)
        R = R / trunc[:, None, None]
    R = np.where(used[None], R, np.nan + 0j)
    f_true, z_true = poles_to_modal(lam_true)
    ok = (z_true > 0) & np.isfinite(z_true)
    if not ok.all():
        issues.append(
            QualityIssue(
                pid,
                "*",
                "window",
                "warning",
                f"{count(int(np.count_nonzero(~ok)), 'mode')} with less damping than the window "
                "adds: dropped",
            )
        )
    lam, lam_true, R, f_true, z_true = lam[ok], lam_true[ok], R[ok], f_true[ok], z_true[ok]
    fit = LSFDResult(
        poles=fit.poles[ok],
        residues=fit.residues[ok],
        upper=fit.upper,
        lower2=fit.lower2,
        lower1=fit.lower1,
        rel_residual=fit.rel_residual,
        residue_std=None if fit.residue_std is None else fit.residue_std[ok],
    )
    rstd = np.full((lam.size, 3, 3), np.nan) if fit.residue_std is None else fit.residue_std
    with np.errstate(invalid="ignore", divide="ignore"):
        k_rel = np.stack([rstd[:, d, d] / np.abs(fit.residues[:, d, d]) for d in range(3)], axis=0)
    k_rel = np.where(used.diagonal()[:, None], k_rel, np.nan)
    Rdd = np.stack([R[:, d, d] for d in range(3)], axis=0)  # (3, n)
    k = modal_stiffness(lam_true, Rdd.T).T  # (3, n)
    # visibility in the measured domain
    inb_lines = (f >= s.fmin_hz) & (f <= s.fmax_hz)
    peak = np.abs(np.stack([fit.residues[:, d, d] for d in range(3)], 0)) / np.abs(lam.real)
    hmax = np.array(
        [np.nanmax(np.abs(h[inb_lines, d, d])) if used[d, d] else np.nan for d in range(3)]
    )
    vis = peak / hmax[:, None]
    if s.local_visibility_min < 1:
        # a mode far above the arm's (a bracket, a tool) is small against the band's
        # largest peak but the FRF's main feature near its own frequency
        fr_meas = np.abs(lam) / (2 * np.pi)
        near = inb_lines[:, None] & (np.abs(f[:, None] - fr_meas[None, :]) <= 0.1 * fr_meas)
        hdd = np.abs(np.nan_to_num(np.stack([h[:, d, d] for d in range(3)], axis=1)))  # (F, 3)
        hloc = np.max(np.where(near[:, None, :], hdd[:, :, None], 0.0), axis=0)  # (3, n)
        with np.errstate(invalid="ignore", divide="ignore"):
            loc = peak / hloc * (s.visibility_min / s.local_visibility_min)
        # ... but not a mode that barely moves this point (an antiresonance's floor)
        loc = np.where(np.isfinite(loc) & (hloc > 0) & (vis >= 0.1 * s.visibility_min), loc, np.nan)
        vis = np.fmax(vis, loc)
    shapes, signed = _shapes(lam_true, R, used)
    vis_ok = (np.where(np.isfinite(vis), vis, 0.0) >= s.visibility_min) & (
        np.nan_to_num(k_rel, nan=0.0) <= s.k_rel_std_max
    )
    in_band = (f_true >= s.fmin_hz) & (f_true <= s.fmax_hz)
    dpts = [d for d in range(3) if used[d, d]]
    issues = [i for i in issues if i.check != "sign"]
    issues.extend(
        sign_issues(
            pid,
            [AXES[d] * 2 for d in dpts],
            f_true,
            np.array([np.where(vis_ok[d] & in_band, k[d], np.nan) for d in dpts]).reshape(
                len(dpts), f_true.size
            ),
            z_true,
        )
    )
    return PostureModal(
        posture_id=pid,
        modes=_modes(pid, f_true, z_true, k, k_rel),
        poles=lam_true.astype(np.complex128),
        poles_measured=lam.astype(np.complex128),
        residues=R.astype(np.complex128),
        visibility=np.where(np.isfinite(vis), vis, 0.0),
        shapes=shapes,
        signed_shapes=signed,
        used=used,
        issues=tuple(issues),
        diagram=diagram,
        selected=selected,
        lsfd=fit,
        freq_hz=f,
        H=h,
        weights=w,
        settings=s,
    )
