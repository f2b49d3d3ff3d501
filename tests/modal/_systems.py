"""Synthetic modal systems for the modal tests (analytic FRFs, known truth)."""
# (a helper module, imported by the tests as tests.modal._systems)

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class ModalSystem:
    """Proportionally damped modes seen at a triaxial TCP sensor.

    ``H_ij(s) = sum_r R_r,ij / (s - lambda_r) + conj``, ``R_r = u_r u_r^T / (2 i w_d,r)``
    so that ``k_r,d = w_r^2 / u_r,d^2`` exactly.
    """

    f_hz: NDArray[np.float64]
    zeta: NDArray[np.float64]
    u: NDArray[np.float64]  # (n_modes, 3)

    @property
    def poles(self) -> NDArray[np.complex128]:
        w = 2 * np.pi * self.f_hz
        return -self.zeta * w + 1j * w * np.sqrt(1 - self.zeta**2)

    @property
    def residues(self) -> NDArray[np.complex128]:
        wd = self.poles.imag
        return np.einsum("ri,rj->rij", self.u, self.u) / (2j * wd)[:, None, None]

    @property
    def k(self) -> NDArray[np.float64]:
        """Driving-point modal stiffness, shape (3, n_modes)."""
        return ((2 * np.pi * self.f_hz)[:, None] ** 2 / self.u**2).T

    def H(self, freq_hz: NDArray[np.float64], decay: float = 0.0) -> NDArray[np.complex128]:
        s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
        lam = self.poles - decay
        g = 1 / (s[:, None] - lam[None])
        gc = 1 / (s[:, None] - np.conj(lam)[None])
        R = self.residues
        return np.einsum("fr,rij->fij", g, R) + np.einsum("fr,rij->fij", gc, np.conj(R))


def make_system(seed: int = 0) -> ModalSystem:
    """Six modes in 4-40 Hz (7.0/7.35 Hz close, 0.2 % damping) plus two above the band."""
    rng = np.random.default_rng(seed)
    f = np.array([7.0, 7.35, 12.0, 18.5, 26.0, 33.0, 60.0, 95.0])
    z = np.array([0.002, 0.03, 0.02, 0.04, 0.05, 0.03, 0.03, 0.03])
    u = rng.normal(size=(f.size, 3)) / np.sqrt(rng.uniform(200, 2000, size=(f.size, 1)))
    return ModalSystem(f, z, u)


def add_noise(
    H: NDArray, rel: float, rng: np.random.Generator, *, proportional: bool = False
) -> NDArray:
    """Complex Gaussian noise of std ``rel * max|H|`` per FRF (or ``rel * |H|`` per line)."""
    scale = rel * (np.abs(H) if proportional else np.max(np.abs(H), axis=0, keepdims=True))
    return H + scale * (rng.normal(size=H.shape) + 1j * rng.normal(size=H.shape)) / np.sqrt(2)


def drifting_campaign(n: int, seed: int = 0):
    """Postures along q2: five modes drift by up to 15 %; shapes rotate with q6."""
    rng = np.random.default_rng(seed)
    q = np.zeros((n, 6))
    q[:, 1] = np.linspace(-0.5, 0.5, n)
    q[:, 5] = np.linspace(0, 0.8, n)
    f = np.arange(0.25, 50.01, 0.25)
    systems, Hs = [], []
    base_u = rng.normal(size=(5, 3)) / 25.0
    for i in range(n):
        fn = np.array([6.0, 9.5, 15.0, 22.0, 31.0]) * (1 + 0.15 * np.sin(q[i, 1] + np.arange(5)))
        c, s = np.cos(q[i, 5]), np.sin(q[i, 5])
        Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        sysm = ModalSystem(fn, np.array([0.01, 0.02, 0.015, 0.03, 0.02]), base_u @ Rz.T)
        systems.append(sysm)
        Hs.append(add_noise(sysm.H(f), 0.005, rng, proportional=True))
    return q, f, Hs, systems
