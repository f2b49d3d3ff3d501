"""FRF quality checks, reported per posture and direction (never silently dropped).

Checks on one posture's FRFs (:func:`check_posture_frfs`):

- ``absent``: a driving-point direction is not in the data (info).
- ``nan``: some, but not all, lines of a direction are NaN or inf; the
  direction is left out of the identification (error).
- ``grid``: the frequency grid is not strictly increasing, not uniform, or
  does not cover the analysis band (error when unusable, else warning).
- ``coherence``: lines in the band with coherence below ``coherence_min``
  (warning; needs the coherence).
- ``reciprocity``: ``H_ij`` and ``H_ji`` differ by more than
  ``reciprocity_tol`` (relative RMS difference in the band): sensor axes
  rotated or mislabelled channels (warning).
- ``passivity``: a driving-point receptance has ``Im H_dd > 0`` beyond the
  noise on more than 10 % of the band lines (a sign or direction error,
  warning).

Across postures (:func:`check_campaign_grids`): ``grid`` warnings for
postures whose grid differs from the most common one (each posture is still
identified on its own grid).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import AXES

__all__ = [
    "QualityIssue",
    "check_campaign_grids",
    "check_posture_frfs",
    "usable_directions",
]

Severity = Literal["info", "warning", "error"]


@dataclass(frozen=True)
class QualityIssue:
    """One finding of the FRF checks.

    Attributes
    ----------
    posture_id : str
    dir : str
        Two-letter direction (response, excitation) or ``"*"`` for the whole posture.
    check : str
        ``absent``, ``nan``, ``grid``, ``coherence``, ``reciprocity``, ``passivity``.
    severity : {"info", "warning", "error"}
        ``error``: the direction (or posture) is not used.
    message : str
        What was expected and what was found.
    value : float
        The measured quantity (fraction of lines, relative difference, ...).
    """

    posture_id: str
    dir: str
    check: str
    severity: Severity
    message: str
    value: float = float("nan")

    def __str__(self) -> str:
        return f"posture {self.posture_id!r} {self.dir}: [{self.check}] {self.message}"


def usable_directions(H: ArrayLike, issues: Sequence[QualityIssue] = ()) -> NDArray[np.bool_]:
    """Directions present and finite on every line and not marked ``error``, shape (3, 3)."""
    h = np.asarray(H)
    ok = np.all(np.isfinite(h), axis=0)
    for iss in issues:
        if iss.severity == "error":
            if iss.dir == "*":
                ok[:] = False
            elif len(iss.dir) == 2:
                ok[AXES.index(iss.dir[0]), AXES.index(iss.dir[1])] = False
    return np.asarray(ok)


def check_posture_frfs(
    posture_id: str,
    freq_hz: ArrayLike,
    H: ArrayLike,
    *,
    band_hz: tuple[float, float],
    coherence: ArrayLike | None = None,
    coherence_min: float = 0.9,
    reciprocity_tol: float = 0.2,
) -> list[QualityIssue]:
    """Check one posture's FRFs.

    Parameters
    ----------
    posture_id : str
    freq_hz : array_like, shape (n_freq,)
    H : array_like of complex, shape (n_freq, 3, 3)
        Receptance, NaN for absent directions.
    band_hz : (float, float)
        Analysis band, Hz.
    coherence : array_like, shape (n_freq, 3, 3), optional
    coherence_min : float
        Coherence below this counts as a bad line (docs/references.md: 0.9).
    reciprocity_tol : float
        Largest accepted relative RMS difference between ``H_ij`` and ``H_ji``.

    Returns
    -------
    list of QualityIssue
    """
    pid = str(posture_id)
    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(H, dtype=complex)
    out: list[QualityIssue] = []
    lo, hi = band_hz
    if h.ndim != 3 or h.shape[1:] != (3, 3) or f.ndim != 1 or h.shape[0] != f.size:
        out.append(
            QualityIssue(
                pid,
                "*",
                "grid",
                "error",
                f"expected freq_hz (n,) and H (n, 3, 3), found {f.shape} and {h.shape}",
            )
        )
        return out
    df = np.diff(f)
    if f.size < 8 or np.any(~np.isfinite(f)) or np.any(df <= 0):
        out.append(
            QualityIssue(
                pid,
                "*",
                "grid",
                "error",
                "expected at least 8 finite, strictly increasing frequencies",
            )
        )
        return out
    if np.ptp(df) > 1e-6 * np.mean(df):
        out.append(
            QualityIssue(
                pid,
                "*",
                "grid",
                "warning",
                f"frequency grid is not uniform (steps {df.min():g}..{df.max():g} Hz)",
                float(np.ptp(df)),
            )
        )
    if f[-1] < hi:
        out.append(
            QualityIssue(
                pid,
                "*",
                "grid",
                "warning",
                f"data end at {f[-1]:g} Hz, below the band's upper edge {hi:g} Hz",
                float(f[-1]),
            )
        )
    inband = (f >= lo) & (f <= hi)
    if np.count_nonzero(inband) < 8:
        out.append(
            QualityIssue(
                pid,
                "*",
                "grid",
                "error",
                f"expected at least 8 lines in {lo:g}..{hi:g} Hz, found {np.count_nonzero(inband)}",
            )
        )
        return out

    finite = np.isfinite(h)
    for i in range(3):
        d = AXES[i] * 2
        if not finite[:, i, i].any():
            out.append(QualityIssue(pid, d, "absent", "info", "driving point not measured"))
    for i in range(3):
        for j in range(3):
            d = AXES[i] + AXES[j]
            n_bad = int(np.count_nonzero(~finite[:, i, j]))
            if 0 < n_bad < f.size:
                first = float(f[np.argmax(~finite[:, i, j])])
                out.append(
                    QualityIssue(
                        pid,
                        d,
                        "nan",
                        "error",
                        f"{n_bad} of {f.size} lines are NaN or inf (first at {first:g} Hz); "
                        "direction not used",
                        n_bad / f.size,
                    )
                )
    ok = np.all(finite, axis=0)

    if coherence is not None:
        coh = np.asarray(coherence, dtype=float)
        if coh.shape == h.shape:
            for i in range(3):
                for j in range(3):
                    if not ok[i, j]:
                        continue
                    c = coh[inband, i, j]
                    frac_bad = float(np.mean(~(c >= coherence_min)))
                    if frac_bad > 0.1:
                        out.append(
                            QualityIssue(
                                pid,
                                AXES[i] + AXES[j],
                                "coherence",
                                "warning",
                                f"{100 * frac_bad:.0f} % of the lines in {lo:g}..{hi:g} Hz have "
                                f"coherence below {coherence_min:g}",
                                frac_bad,
                            )
                        )

    for i in range(3):
        for j in range(i + 1, 3):
            if ok[i, j] and ok[j, i]:
                a = h[inband, i, j]
                b = h[inband, j, i]
                den = np.sqrt(np.sqrt(np.sum(np.abs(a) ** 2) * np.sum(np.abs(b) ** 2)))
                rel = float(np.sqrt(np.sum(np.abs(a - b) ** 2)) / den) if den > 0 else 0.0
                if rel > reciprocity_tol:
                    out.append(
                        QualityIssue(
                            pid,
                            AXES[i] + AXES[j],
                            "reciprocity",
                            "warning",
                            f"H_{AXES[i]}{AXES[j]} and H_{AXES[j]}{AXES[i]} differ by "
                            f"{100 * rel:.0f} % "
                            f"(RMS, expected <= {100 * reciprocity_tol:.0f} %): rotated sensor "
                            "axes or mislabelled channels?",
                            rel,
                        )
                    )

    for i in range(3):
        if not ok[i, i]:
            continue
        hd = h[inband, i, i]
        scale = np.max(np.abs(hd))
        frac_pos = float(np.mean(hd.imag > 0.05 * scale)) if scale > 0 else 0.0
        if frac_pos > 0.1:
            out.append(
                QualityIssue(
                    pid,
                    AXES[i] * 2,
                    "passivity",
                    "warning",
                    f"Im H_{AXES[i]}{AXES[i]} > 0 on {100 * frac_pos:.0f} % of the band lines "
                    "(a driving-point receptance has Im <= 0): sign or direction error?",
                    frac_pos,
                )
            )
    return out


def check_campaign_grids(
    posture_ids: Sequence[str], grids: Sequence[ArrayLike]
) -> list[QualityIssue]:
    """Warn about postures whose frequency grid differs from the most common one.

    Parameters
    ----------
    posture_ids : sequence of str
    grids : sequence of array_like, each shape (n_freq_i,)

    Returns
    -------
    list of QualityIssue
    """
    keys = []
    for g in grids:
        a = np.asarray(g, dtype=float)
        keys.append(
            (
                a.size,
                round(float(a[0]), 9) if a.size else 0.0,
                round(float(a[-1]), 9) if a.size else 0.0,
            )
        )
    if not keys:
        return []
    common, _ = Counter(keys).most_common(1)[0]
    out = []
    for pid, k in zip(posture_ids, keys, strict=True):
        if k != common:
            out.append(
                QualityIssue(
                    str(pid),
                    "*",
                    "grid",
                    "warning",
                    f"frequency grid ({k[0]} lines, {k[1]:g}..{k[2]:g} Hz) differs from the "
                    f"campaign's usual grid ({common[0]} lines, {common[1]:g}..{common[2]:g} Hz)",
                )
            )
    return out
