"""Modal identification of one measurement: any set of FRFs between numbered points.

A campaign (:mod:`robolobe.modal.identify`) holds the FRFs of a robot's TCP
at many postures. A single structure tested with a roving hammer or a roving
accelerometer gives instead FRFs between numbered nodes and directions, most
of them transfer FRFs (response and excitation at different points), as in a
UFF file with several references (:func:`robolobe.campaign.uff.read_uff_frfs`).
:func:`identify_measurement` finds the modes of such a set: pLSCF on all
FRFs together (common denominator), stabilization diagram, clustering
selection, pole refinement and LSFD residues, the same steps as a posture.

Sign convention (as :mod:`robolobe.modal.posture`): every FRF ``j`` is
described by ``H_j(w) = sum_r (w_r^2 / k_rj) / (w_r^2 - w^2 + 2 i zeta_r w_r
w)`` with ``k_rj = Re(w_r^2 / (2 i w_d R_rj))`` signed like the residue.
At a driving point every ``k_rj > 0``; at a transfer FRF ``k_rj`` is negative
where the mode shape has opposite signs at the two points (it is then a
signed transfer stiffness, not a modal stiffness of a point). Modes are kept
whatever their signs; the ``transfer`` and ``sign`` checks say what the data
are.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from robolobe._text import count
from robolobe._threads import with_one_blas_thread
from robolobe.errors import InputError
from robolobe.modal.lsfd import LSFDResult, lsfd, modal_stiffness
from robolobe.modal.plscf import plscf
from robolobe.modal.posture import IdentifySettings, clean_poles, sign_issues
from robolobe.modal.quality import QualityIssue
from robolobe.modal.refine import refine_poles
from robolobe.modal.selection import SelectedPoles, select_poles
from robolobe.modal.stabilization import StabilizationDiagram, stabilization_diagram
from robolobe.modal.synthesis import poles_to_modal

__all__ = ["MEASUREMENT_COLUMNS", "MeasurementModal", "identify_measurement"]

#: Columns of the table written for a measurement (one row per FRF and mode).
MEASUREMENT_COLUMNS: tuple[str, ...] = (
    "frf",
    "rsp_node",
    "rsp_dir",
    "ref_node",
    "ref_dir",
    "driving_point",
    "mode",
    "f_hz",
    "zeta",
    "k_N_per_m",
    "visibility",
)


@dataclass(frozen=True, eq=False)
class MeasurementModal:
    """Modes of one measurement.

    Attributes
    ----------
    name : str
    f_hz, zeta : ndarray, shape (n_modes,)
        Modes in the analysis band, rising; ``mode`` numbers are 1..n_modes
        in this order, the same in every FRF.
    poles : ndarray of complex, shape (n_modes,)
        rad/s.
    k_N_per_m : ndarray, shape (n_frf, n_modes)
        Signed stiffness of each mode in each FRF (module docstring).
    visibility : ndarray, shape (n_frf, n_modes)
        Peak of the mode's term over the FRF's peak in the band.
    visible : ndarray of bool, shape (n_frf, n_modes)
        Visibility and residue precision above the settings' thresholds.
    table : pandas.DataFrame
        :data:`MEASUREMENT_COLUMNS`, one row per FRF and visible mode.
    issues : tuple of QualityIssue
    diagram : StabilizationDiagram
    selected : SelectedPoles
    lsfd : LSFDResult
        Fit of every mode the refinement kept (in and above the band).
    freq_hz : ndarray, shape (n_freq,)
        Fitting band lines.
    H : ndarray of complex, shape (n_freq, n_frf)
        FRFs on the fitting band.
    labels : tuple of str
    settings : IdentifySettings
    """

    name: str
    f_hz: NDArray[np.float64]
    zeta: NDArray[np.float64]
    poles: NDArray[np.complex128]
    k_N_per_m: NDArray[np.float64]
    visibility: NDArray[np.float64]
    visible: NDArray[np.bool_]
    table: pd.DataFrame
    issues: tuple[QualityIssue, ...]
    diagram: StabilizationDiagram
    selected: SelectedPoles
    lsfd: LSFDResult
    freq_hz: NDArray[np.float64]
    H: NDArray[np.complex128]
    labels: tuple[str, ...]
    settings: IdentifySettings = field(repr=False)

    @property
    def n_modes(self) -> int:
        """Modes in the band."""
        return int(self.f_hz.size)

    @property
    def transfer_only(self) -> bool:
        """No FRF of the measurement is a driving point."""
        return not bool(self.table["driving_point"].any()) if len(self.table) else True


@with_one_blas_thread
def identify_measurement(
    freq_hz: ArrayLike,
    H: ArrayLike,
    nodes: Sequence[tuple[int, int, int, int]],
    *,
    settings: IdentifySettings | None = None,
    name: str = "",
) -> MeasurementModal:
    """Identify the modes of a set of FRFs between numbered points.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Common frequency grid, Hz.
    H : array_like of complex, shape (n_freq, n_frf)
        Receptance [m/N] of each FRF.
    nodes : sequence of (rsp_node, rsp_dir, ref_node, ref_dir), length n_frf
        Response and reference node and direction (1, 2, 3 = X, Y, Z) of
        each FRF; equal pairs make a driving point.
    settings : IdentifySettings, optional
        Band, orders, thresholds (window and truncation corrections are applied).
    name : str
        Name used in the findings.

    Returns
    -------
    MeasurementModal

    Raises
    ------
    InputError
        Shapes that do not match, values that are not finite, no stable pole.
    """
    s = settings if settings is not None else IdentifySettings()
    f_all = np.asarray(freq_hz, dtype=float)
    h_all = np.asarray(H, dtype=complex)
    if h_all.ndim == 1:
        h_all = h_all[:, None]
    n_frf = h_all.shape[1] if h_all.ndim == 2 else 0
    if h_all.ndim != 2 or h_all.shape[0] != f_all.size or len(nodes) != n_frf or n_frf == 0:
        raise InputError(
            f"expected freq_hz (n,), H (n, n_frf) and n_frf node tuples, found {f_all.shape}, "
            f"{h_all.shape} and {len(nodes)}",
            source=name or "identify_measurement",
        )
    if not np.all(np.isfinite(h_all)) or not np.all(np.isfinite(f_all)):
        raise InputError("expected finite FRF values", source=name or "identify_measurement")
    keys = [tuple(int(v) for v in k) for k in nodes]
    ax = "XYZ"
    labels = tuple(f"{a}+{ax[b - 1]}/{c}+{ax[d - 1]}" for a, b, c, d in keys)
    driving = np.array([a == c and b == d for a, b, c, d in keys])
    band = (f_all >= 0.5 * s.fmin_hz) & (f_all <= s.fmax_hz * (1 + s.fit_margin)) & (f_all > 0)
    f = f_all[band]
    h = h_all[band]
    in_lines = (f >= s.fmin_hz) & (f <= s.fmax_hz)
    if np.count_nonzero(in_lines) < 8:
        raise InputError(
            f"expected at least 8 lines in the band {s.fmin_hz:g}-{s.fmax_hz:g} Hz, found "
            f"{np.count_nonzero(in_lines)} (the data span {f_all[0]:g}-{f_all[-1]:g} Hz)",
            source=name or "identify_measurement",
        )
    # per-FRF weights as for a posture: level-normalised, rolled off below fmin
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=0))
    rms = np.where(rms > 0, rms, 1.0)
    roll = 1.0 / (1.0 + (s.fmin_hz / f) ** 2)
    w = roll[:, None] / rms[None, :]
    n_max = s.max_order if s.max_order is not None else 42
    n_max = max(2, min(n_max, (2 * f.size * n_frf) - 2))
    try:
        pole_sets = plscf(f, h[:, :, None], list(range(2, n_max + 1, 2)), weights=w)
    except np.linalg.LinAlgError as exc:
        raise InputError(
            f"the pole estimation failed ({exc}): check the FRF values", source=name or "FRFs"
        ) from None
    top = max(s.fmax_hz, 0.98 * min(s.fmax_hz * (1 + s.fit_margin), float(f[-1])))
    diagram = stabilization_diagram(pole_sets, band_hz=(s.fmin_hz, top), criteria=s.criteria)
    selected = select_poles(diagram, s.selection)
    lam = selected.poles
    if lam.size and s.refine:
        lam = refine_poles(
            f, h, lam, weights=w, zeta_max=s.criteria.zeta_max, jacobian=s.refine_jacobian
        ).poles
    lam = clean_poles(lam, s, f)
    if lam.size == 0:
        raise InputError(
            f"no stable poles in {s.fmin_hz:g}-{s.fmax_hz:g} Hz; check the band and the data",
            source=name or "identify_measurement",
        )
    fit = lsfd(f, h, lam, weights=w)
    R = fit.residues  # (n, n_frf)
    if s.record_length_s is not None:
        R = R / (1.0 - np.exp(lam * s.record_length_s))[:, None]
    lam_true = lam + s.window_decay_per_s
    f_true, z_true = poles_to_modal(lam_true)
    k = modal_stiffness(lam_true, R).T  # (n_frf, n)
    hmax = np.max(np.abs(h[in_lines]), axis=0)
    vis = (np.abs(fit.residues) / np.abs(lam.real)[:, None]).T / hmax[:, None]
    rstd = fit.residue_std
    rel = (
        np.zeros_like(vis)
        if rstd is None
        else np.nan_to_num((rstd / np.abs(fit.residues)).T, nan=0.0)
    )
    in_band = (f_true >= s.fmin_hz) & (f_true <= s.fmax_hz) & (z_true > 0)
    visible = (
        (vis >= s.visibility_min)
        & (rel <= s.k_rel_std_max)
        & np.isfinite(k)
        & (k != 0)
        & in_band[None, :]
    )
    # report the modes of the band seen in at least one FRF
    keep = visible.any(axis=0)
    f_r, z_r, lam_r = f_true[keep], z_true[keep], lam_true[keep]
    k_r, vis_r, visible_r = k[:, keep], vis[:, keep], visible[:, keep]
    rows = []
    for j, (key, lab) in enumerate(zip(keys, labels, strict=True)):
        for m in range(f_r.size):
            if not visible_r[j, m]:
                continue
            rows.append(
                {
                    "frf": lab,
                    "rsp_node": key[0],
                    "rsp_dir": key[1],
                    "ref_node": key[2],
                    "ref_dir": key[3],
                    "driving_point": bool(driving[j]),
                    "mode": m + 1,
                    "f_hz": float(f_r[m]),
                    "zeta": float(z_r[m]),
                    "k_N_per_m": float(k_r[j, m]),
                    "visibility": float(vis_r[j, m]),
                }
            )
    table = pd.DataFrame(rows, columns=list(MEASUREMENT_COLUMNS))
    issues: list[QualityIssue] = []
    pid = name or "measurement"
    transfer = [lab for lab, dp in zip(labels, driving, strict=True) if not dp]
    if transfer:
        both = [
            lab
            for j, lab in enumerate(labels)
            if not driving[j]
            and (k_r[j][visible_r[j]] < 0).any()
            and (k_r[j][visible_r[j]] > 0).any()
        ]
        msg = (
            f"{len(transfer)} of {n_frf} FRFs are transfer FRFs (response and reference at "
            f"different nodes or directions: {', '.join(transfer[:6])}"
            f"{', ...' if len(transfer) > 6 else ''}); their k_N_per_m is a signed transfer "
            "term, not a modal stiffness"
            + (f"; residues of both signs in {len(both)} of them" if both else "")
        )
        if not driving.any():
            msg += "; no driving point: modal stiffness and mass are not identifiable"
        issues.append(QualityIssue(pid, "*", "transfer", "warning", msg, float(len(transfer))))
    dp = np.flatnonzero(driving)
    issues.extend(
        sign_issues(
            pid,
            [labels[j] for j in dp],
            f_r,
            np.where(visible_r[dp], k_r[dp], np.nan).reshape(dp.size, f_r.size),
        )
    )
    unseen = [lab for j, lab in enumerate(labels) if not visible_r[j].any()]
    if unseen:
        issues.append(
            QualityIssue(
                pid,
                "*",
                "poles",
                "warning",
                f"no mode visible in {count(len(unseen), 'FRF')}: {', '.join(unseen[:6])}",
            )
        )
    return MeasurementModal(
        name=pid,
        f_hz=f_r,
        zeta=z_r,
        poles=lam_r.astype(np.complex128),
        k_N_per_m=k_r,
        visibility=vis_r,
        visible=visible_r,
        table=table,
        issues=tuple(issues),
        diagram=diagram,
        selected=selected,
        lsfd=fit,
        freq_hz=f,
        H=h,
        labels=labels,
        settings=s,
    )
