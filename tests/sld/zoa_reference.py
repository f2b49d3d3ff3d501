"""An independent zero-order (ZOA) lobe envelope for the tests, written from the textbook.

Nothing here calls robolobe's lobe code. Altintas & Budak (1995), as in
REFERENCES.md section 3: with the directional factors ``alpha`` (the 1/2 [.]
integrals from entry to exit) and the oriented transfer matrix
``G0 = alpha G(w)``, the characteristic equation of regenerative chatter at
spindle speed ``n`` (tooth period ``T = 60 / (N n)``) is ::

    det(I + Lambda G0(w)) = 0,   Lambda = -(N / (4 pi)) a Kt (1 - exp(-i w T))

so ``1 / a = u_j(w) = (N Kt / (4 pi)) (1 - exp(-i w T)) mu_j(w)`` for an
eigenvalue ``mu_j`` of ``G0``: the stability boundary at speed ``n`` is made
of the chatter frequencies ``w`` where some ``u_j`` is real and positive, the
limit being ``1 / u_j`` there. This module finds them per speed directly (no
lobe numbers, no phase ``eps``, no branch tracking): ``F_j(w) = Im u_j``
of each eigenvalue (ordered by real part, and once more by modulus; no tracking),
sampled on a dense grid (20,000 log-spaced points from a fifth of the lowest
mode or a tenth of the lowest tooth-passing frequency to four times the
highest of either, a uniform grid 1/16 of the regeneration period apart,
4,001 points around every mode spaced like ``1e-4 sinh(t)`` zeta w), and
every sign change is bisected to the root. The envelope is the smallest
positive limit over all roots.
"""

from __future__ import annotations

import math

import numpy as np

_TWO_PI = 2.0 * math.pi


def alphas(phi_st: float, phi_ex: float, kr: float) -> np.ndarray:
    """Directional factors (REFERENCES.md section 3), each [.] from entry to exit."""

    def at(p: float) -> np.ndarray:
        return 0.5 * np.array(
            [
                [
                    math.cos(2 * p) - 2 * kr * p + kr * math.sin(2 * p),
                    -math.sin(2 * p) - 2 * p + kr * math.cos(2 * p),
                ],
                [
                    -math.sin(2 * p) + 2 * p + kr * math.cos(2 * p),
                    -math.cos(2 * p) - 2 * kr * p - kr * math.sin(2 * p),
                ],
            ]
        )

    return at(phi_ex) - at(phi_st)


def receptance(f_hz, zeta, residues, w):
    """``sum_r A_r / (w_r^2 - w^2 + 2 i zeta_r w_r w)`` at circular frequencies ``w``: (n, 2, 2)."""
    wr = _TWO_PI * np.asarray(f_hz, float)
    z = np.asarray(zeta, float)
    den = wr[None, :] ** 2 - w[:, None] ** 2 + 2j * (z * wr)[None, :] * w[:, None]
    return np.einsum("nm,mij->nij", 1.0 / den, np.asarray(residues, float))


def eig2(g):
    """Both eigenvalues of each 2x2 matrix of ``g`` (n, 2, 2), in closed form: (n, 2).

    ``mu = tr/2 +- sqrt(((a - d)/2)^2 + b c)``; the one of larger modulus is
    taken with the sign that adds, the other as ``det / mu`` (the stable
    quadratic formula, no cancellation), as accurate as LAPACK's ``geev`` and
    without its per-matrix call (tests/sld/test_zoa_reference.py compares them).
    """
    a, b, c, d = g[:, 0, 0], g[:, 0, 1], g[:, 1, 0], g[:, 1, 1]
    half = 0.5 * (a + d)
    s = np.sqrt((0.5 * (a - d)) ** 2 + b * c)
    s = np.where((half.conjugate() * s).real >= 0.0, s, -s)
    big = half + s
    det = a * d - b * c
    safe = np.where(big == 0.0, 1.0, big)
    small = np.where(big == 0.0, 0.0, det / safe)
    return np.stack([big, small], axis=1)


def order(mu, key="real"):
    """``mu`` (n, 2) ordered by ``key``: the larger real part (``"real"``) or modulus first."""
    k = mu.real if key == "real" else np.abs(mu)
    swap = k[:, 1] > k[:, 0]
    return np.where(swap[:, None], mu[:, ::-1], mu)


def eigs(f_hz, zeta, residues, alpha, w, key="real"):
    """Both eigenvalues of ``alpha G(w)``, shape (n, 2), ordered by ``key``.

    ``key="real"``: the larger real part first; ``"abs"``: the larger modulus
    first. Not tracked along ``w``: where the keys tie the order swaps, which
    makes a jump, not a root, of ``Im u_j`` (rejected); a root next to such a
    tie is found with the other key.
    """
    g0 = np.einsum("ij,njk->nik", alpha, receptance(f_hz, zeta, residues, w))
    return order(eig2(g0), key)


def reference_envelope(f_hz, zeta, residues, alpha, *, teeth, kt, rpm, bisections=60):
    """Smallest positive ZOA limit [m] at each speed of ``rpm`` (inf where none).

    Parameters
    ----------
    f_hz, zeta : array_like, shape (m,)
        Natural frequencies [Hz] and damping ratios.
    residues : array_like, shape (m, 2, 2)
        Residue matrices [1/kg] in the feed frame.
    alpha : ndarray, shape (2, 2)
        Directional factors.
    teeth : int
    kt : float
        Tangential coefficient [N/m^2].
    rpm : array_like, shape (s,)
    """
    f = np.asarray(f_hz, float)
    z = np.asarray(zeta, float)
    wr = _TWO_PI * f
    rpm = np.asarray(rpm, float)
    w_tooth = 2 * math.pi * teeth / 60.0 * rpm
    lo = min(0.2 * wr.min(), 0.1 * w_tooth.min())
    hi = max(4.0 * wr.max(), 4.0 * w_tooth.max())
    t_max = 60.0 / (teeth * rpm.min())
    step = _TWO_PI / t_max / 16.0
    parts = [np.geomspace(lo, hi, 20_000), np.arange(lo, hi, step)]
    t = np.linspace(-1.0, 1.0, 4001) * math.asinh(60.0 / 1e-4)
    for w0, z0 in zip(wr, z, strict=True):
        s = 1e-4 * np.sinh(t)
        parts.append(w0 * (1.0 + z0 * s))
    w = np.unique(np.concatenate(parts))
    w = w[(w >= lo) & (w <= hi)]
    c = teeth * kt / (4.0 * math.pi)
    out = np.full(rpm.size, np.inf)
    # the grid's eigenvalues once; each key orders them its own way
    mu_w = eig2(np.einsum("ij,njk->nik", alpha, receptance(f, z, residues, w)))
    for key in ("real", "abs"):
        mu = order(mu_w, key)
        for s_i, n in enumerate(rpm):
            tau = 60.0 / (teeth * n)

            def fun(ww, mm, tau=tau):
                return c * (1.0 - np.exp(-1j * ww * tau))[:, None] * mm

            fv = fun(w, mu).imag  # (n_w, 2)
            ii, jj = np.nonzero(np.sign(fv[:-1]) * np.sign(fv[1:]) < 0)
            if ii.size == 0:
                continue
            a, b = w[ii].copy(), w[ii + 1].copy()
            fa = fv[ii, jj]
            sel = np.arange(ii.size)
            for _ in range(bisections):
                m = 0.5 * (a + b)
                fm = fun(m, eigs(f, z, residues, alpha, m, key))[sel, jj].imag
                left = np.sign(fm) == np.sign(fa)
                a = np.where(left, m, a)
                fa = np.where(left, fm, fa)
                b = np.where(left, b, m)
            m = 0.5 * (a + b)
            u = fun(m, eigs(f, z, residues, alpha, m, key))
            uj = u[sel, jj]
            # a root (not a jump where the order swapped) of an eigenvalue that is not
            # the rounding-level zero of a rank-1 receptance
            ok = (
                (uj.real > 0)
                & (np.abs(uj.imag) <= 1e-6 * np.abs(uj))
                & (np.abs(uj) > 1e-9 * np.abs(u).max(axis=1))
            )
            if np.any(ok):
                out[s_i] = min(out[s_i], float(np.min(1.0 / uj.real[ok])))
    return out
