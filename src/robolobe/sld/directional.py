"""Directional factors of the milling force (Altintas & Budak 1995).

Frame and sign convention (Altintas, *Manufacturing Automation*, ch. 3-4):
x is the feed direction, y the normal direction, z the tool axis pointing
from the tool tip toward the spindle, so that (x, y, z) is right-handed. The
cutter turns clockwise seen from +z (a right-hand cutter, M03). The immersion
angle phi of a tooth is measured clockwise from +y; the chip is
``h = f_z sin(phi) + (dq_x sin(phi) + dq_y cos(phi))`` with ``dq`` the
displacement of the tool now minus one tooth period ago.

The dynamic force of one tooth at angle ``phi`` is
``F = a Kt / 2 * A(phi) dq`` with ::

    A(phi) = [[-sin2phi - Kr (1 - cos2phi),  -(1 + cos2phi) - Kr sin2phi],
              [ (1 - cos2phi) - Kr sin2phi,   sin2phi - Kr (1 + cos2phi)]]

and the zero-order factors are its integrals over the cut,
``alpha = int_{phi_st}^{phi_ex} A(phi) dphi`` (docs/references.md: stability lobes)::

    a_xx = 1/2 [ cos2phi - 2 Kr phi + Kr sin2phi ]
    a_xy = 1/2 [ -sin2phi - 2 phi + Kr cos2phi ]
    a_yx = 1/2 [ -sin2phi + 2 phi + Kr cos2phi ]
    a_yy = 1/2 [ -cos2phi - 2 Kr phi - Kr sin2phi ]

Everything here is vectorised: arguments broadcast against each other and the
result gets two trailing axes ``(..., 2, 2)`` ordered ``[[xx, xy], [yx, yy]]``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "directional_antiderivative",
    "directional_factors",
    "directional_matrix",
    "interval_directional_average",
]

FloatArray = NDArray[np.float64]


def directional_antiderivative(phi: ArrayLike, kr: ArrayLike) -> FloatArray:
    """Antiderivative ``P(phi)`` of :func:`directional_matrix` (the bracket terms).

    Parameters
    ----------
    phi : array_like
        Immersion angle [rad].
    kr : array_like
        Radial-to-tangential cutting coefficient ratio ``Kr = Kn / Kt`` [-];
        broadcast against ``phi``.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``P`` with ``alpha = P(phi_ex) - P(phi_st)``.
    """
    p, k = np.broadcast_arrays(np.asarray(phi, dtype=np.float64), np.asarray(kr, dtype=np.float64))
    c2, s2 = np.cos(2.0 * p), np.sin(2.0 * p)
    out = np.empty((*p.shape, 2, 2))
    out[..., 0, 0] = 0.5 * (c2 - 2.0 * k * p + k * s2)
    out[..., 0, 1] = 0.5 * (-s2 - 2.0 * p + k * c2)
    out[..., 1, 0] = 0.5 * (-s2 + 2.0 * p + k * c2)
    out[..., 1, 1] = 0.5 * (-c2 - 2.0 * k * p - k * s2)
    return out


def directional_matrix(phi: ArrayLike, kr: ArrayLike) -> FloatArray:
    """Instantaneous directional matrix ``A(phi)`` of one cutting tooth.

    Parameters
    ----------
    phi : array_like
        Immersion angle [rad] (the tooth is assumed to be cutting).
    kr : array_like
        ``Kn / Kt`` [-].

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``A(phi)``; the force of the tooth is ``a Kt / 2 * A(phi) dq``.
    """
    p, k = np.broadcast_arrays(np.asarray(phi, dtype=np.float64), np.asarray(kr, dtype=np.float64))
    c2, s2 = np.cos(2.0 * p), np.sin(2.0 * p)
    out = np.empty((*p.shape, 2, 2))
    out[..., 0, 0] = -s2 - k * (1.0 - c2)
    out[..., 0, 1] = -(1.0 + c2) - k * s2
    out[..., 1, 0] = (1.0 - c2) - k * s2
    out[..., 1, 1] = s2 - k * (1.0 + c2)
    return out


def directional_factors(phi_entry: ArrayLike, phi_exit: ArrayLike, kr: ArrayLike) -> FloatArray:
    """Zero-order directional factors ``alpha`` (Altintas & Budak 1995).

    Parameters
    ----------
    phi_entry, phi_exit : array_like
        Entry and exit angles [rad], ``0 <= phi_entry < phi_exit <= pi``.
    kr : array_like
        ``Kn / Kt`` [-].

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``[[a_xx, a_xy], [a_yx, a_yy]]``. The mean force over one tooth
        period is ``a Kt N / (4 pi) * alpha @ dq``.

    Examples
    --------
    Slotting gives ``[[-Kr pi, -pi], [pi, -Kr pi]]``:

    >>> import numpy as np
    >>> np.round(directional_factors(0.0, np.pi, 0.5) / np.pi, 12)
    array([[-0.5, -1. ],
           [ 1. , -0.5]])
    """
    return directional_antiderivative(phi_exit, kr) - directional_antiderivative(phi_entry, kr)


def interval_directional_average(
    phi_start: ArrayLike,
    dphi: float,
    phi_entry: float,
    phi_exit: float,
    kr: float,
    teeth: int,
) -> FloatArray:
    """Mean of the summed directional matrix of all teeth over an angle interval.

    Tooth ``j`` sits at ``phi + 2 pi j / teeth``; it cuts while its angle
    (mod 2 pi) lies in ``[phi_entry, phi_exit]``. The mean over
    ``[phi_start, phi_start + dphi]`` is computed exactly from the
    antiderivative (no sampling).

    Parameters
    ----------
    phi_start : array_like
        Angle [rad] of tooth 0 at the start of each interval.
    dphi : float
        Interval length [rad], ``0 < dphi <= 2 pi / teeth``.
    phi_entry, phi_exit : float
        Entry and exit angles [rad].
    kr : float
        ``Kn / Kt`` [-].
    teeth : int
        Number of teeth.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``(1/dphi) * sum_j int A(phi_j) g(phi_j) dphi`` over the interval.
    """
    p0 = np.asarray(phi_start, dtype=np.float64)
    pitch = 2.0 * np.pi / teeth
    start = (p0[..., None] + pitch * np.arange(teeth)) % (2.0 * np.pi)  # (..., teeth)
    total = np.zeros((*p0.shape, 2, 2))
    # the interval may wrap past 2 pi: test it and its copy shifted by -2 pi
    for shift in (0.0, -2.0 * np.pi):
        lo = np.maximum(start + shift, phi_entry)
        hi = np.minimum(start + shift + dphi, phi_exit)
        cut = hi > lo
        hi = np.where(cut, hi, lo)
        part = directional_antiderivative(hi, kr) - directional_antiderivative(lo, kr)
        total += part.sum(axis=-3)
    return total / dphi
