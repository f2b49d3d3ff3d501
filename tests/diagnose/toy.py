"""A toy structure for testing the diagnosis machinery without the twin.

Three uncoupled single-mode directions whose modal mass depends on the
posture (q1). Effects are tuples understood by :func:`toy_model`:
``("mass", dm_kg)`` adds a mass to all directions, ``("kx", factor)`` scales
the x stiffness, ``("ab", a, b)`` scales the y stiffness by ``a * b`` (two
parameters that only act through their product: not identifiable).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from robolobe.diagnose.candidate import Candidate, ParamSpec
from robolobe.diagnose.noise import roughness_sigma
from robolobe.diagnose.observations import Observations

K = np.array([4e6, 6e6, 9e6])  # N/m
M0 = 400.0  # kg
ZETA = 0.03


def toy_model(effects: tuple[Any, ...], obs: Observations) -> np.ndarray:
    m = M0 * (1.0 + 0.4 * np.sin(obs.q_rad[:, 0]))  # (n,)
    k = K.copy()
    for e in effects:
        if e[0] == "mass":
            m = m + e[1]
        elif e[0] == "kx":
            k = k * np.array([e[1], 1.0, 1.0])
        elif e[0] == "ab":
            k = k * np.array([1.0, e[1] * e[2], 1.0])
    w = 2 * np.pi * obs.freq_hz
    c = 2 * ZETA * np.sqrt(k[None, :] * m[:, None])  # (n, 3)
    den = k[None, None, :] - w[None, :, None] ** 2 * m[:, None, None] + 1j * w[None, :, None] * c[:, None, :]
    H = np.zeros((obs.n, w.size, 3, 3), complex)
    for d in range(3):
        H[:, :, d, d] = 1.0 / den[:, :, d]
    return H


def toy_obs(
    effects: tuple[Any, ...], *, n: int = 12, sigma: float = 0.02, seed: int = 0
) -> Observations:
    rng = np.random.default_rng(seed)
    f = np.arange(2.0, 40.0, 0.25)
    q = np.zeros((n, 6))
    q[:, 0] = np.linspace(-1.2, 1.2, n)
    ids = tuple(f"P{i:02d}" for i in range(n))
    nan = np.full((n, f.size, 3, 3), np.nan)
    dummy = Observations(ids, ids, q, f, np.ones((n, f.size, 3, 3), complex), np.ones_like(nan))
    H = toy_model(effects, dummy)
    noise = np.exp(sigma * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)))
    eye = np.eye(3, dtype=bool)
    H = np.where(eye, H * noise, np.nan)
    s = roughness_sigma(f, H)
    return Observations(ids, ids, q, f, H, s, source="toy")


def toy_candidates() -> list[Candidate]:
    none = Candidate(name="none", params=(), build=lambda p: ())
    mass = Candidate(
        name="added_mass",
        params=(ParamSpec("mass_kg", 0.0, 200.0, (5.0, 50.0, 150.0), null=0.0),),
        build=lambda p: (("mass", float(p[0])),),
    )
    kx = Candidate(
        name="joint_stiffness",
        variant="x",
        params=(ParamSpec("factor", 0.3, 3.0, (0.6, 1.0, 1.6), scale="log", null=1.0),),
        build=lambda p: (("kx", float(p[0])),),
    )
    return [none, mass, kx]


def ab_candidate() -> Candidate:
    return Candidate(
        name="product",
        params=(
            ParamSpec("a", 0.3, 3.0, (0.8, 1.2), scale="log"),
            ParamSpec("b", 0.3, 3.0, (0.8, 1.2), scale="log"),
        ),
        build=lambda p: (("ab", float(p[0]), float(p[1])),),
    )
