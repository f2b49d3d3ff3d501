"""A toy structure for testing the diagnosis machinery without the twin.

Three uncoupled single-mode directions whose modal mass depends on the
posture (q1). Effects are tuples understood by ``toy_model``:
``("mass", dm_kg)`` adds a mass to all directions, ``("kx", factor)`` scales
the x stiffness, ``("ab", a, b)`` scales the y stiffness by ``a * b`` (two
parameters acting only through their product: not identifiable),
``("delay", tau)`` delays the response by ``tau`` seconds.
"""

from __future__ import annotations

import sys
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from robolobe.diagnose.candidate import Candidate, ParamSpec
from robolobe.diagnose.noise import roughness_sigma
from robolobe.diagnose.observations import Observations

K = np.array([4e6, 6e6, 9e6])  # N/m
M0 = 400.0  # kg
ZETA = 0.03


def toy_model(effects: tuple[Any, ...], obs: Observations) -> np.ndarray:
    m = M0 * (1.0 + 0.4 * np.sin(obs.q_rad[:, 0]))  # (n,)
    k = K.copy()
    tau = 0.0
    for e in effects:
        if e[0] == "mass":
            m = m + e[1]
        elif e[0] == "kx":
            k = k * np.array([e[1], 1.0, 1.0])
        elif e[0] == "ab":
            k = k * np.array([1.0, e[1] * e[2], 1.0])
        elif e[0] == "delay":
            tau += e[1]
    w = 2 * np.pi * obs.freq_hz
    c = 2 * ZETA * np.sqrt(k[None, :] * m[:, None])  # (n, 3)
    den = (
        k[None, None, :]
        - w[None, :, None] ** 2 * m[:, None, None]
        + 1j * w[None, :, None] * c[:, None, :]
    )
    H = np.zeros((obs.n, w.size, 3, 3), complex)
    for d in range(3):
        H[:, :, d, d] = np.exp(-1j * w * tau) / den[:, :, d]
    return H


def toy_obs(
    effects: tuple[Any, ...] = (), *, n: int = 12, sigma: float = 0.02, seed: int = 0
) -> Observations:
    """Driving-point recordings of the toy with white log-noise of deviation ``sigma``."""
    rng = np.random.default_rng(seed)
    f = np.arange(2.0, 40.0, 0.25)
    q = np.zeros((n, 6))
    q[:, 0] = np.linspace(-1.2, 1.2, n)
    ids = tuple(f"P{i:02d}" for i in range(n))
    shape = (n, f.size, 3, 3)
    dummy = Observations(ids, ids, q, f, np.ones(shape, complex), np.ones(shape))
    H = toy_model(effects, dummy)
    noise = np.exp(sigma * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)))
    H = np.where(np.eye(3, dtype=bool), H * noise, np.nan)
    s = roughness_sigma(f, H, floor=1e-3)
    return Observations(ids, ids, q, f, H, s, source="toy")


def _mass(p: np.ndarray) -> tuple[Any, ...]:
    return (("mass", float(p[0])),)


def _kx(p: np.ndarray) -> tuple[Any, ...]:
    return (("kx", float(p[0])),)


def _ab(p: np.ndarray) -> tuple[Any, ...]:
    return (("ab", float(p[0]), float(p[1])),)


def _delay(p: np.ndarray) -> tuple[Any, ...]:
    return (("delay", float(p[0])),)


def _none(p: np.ndarray) -> tuple[Any, ...]:
    return ()


def toy_candidates() -> list[Candidate]:
    return [
        Candidate(name="none", params=(), build=_none),
        Candidate(
            name="added_mass",
            params=(ParamSpec("mass_kg", 0.1, 200.0, (5.0, 50.0, 150.0), "log"),),
            build=_mass,
        ),
        Candidate(
            name="joint_stiffness",
            variant="x",
            params=(ParamSpec("factor", 0.3, 3.0, (0.6, 1.0, 1.6), scale="log", null=1.0),),
            build=_kx,
        ),
        Candidate(
            name="sensor_delay",
            params=(ParamSpec("delay_s", -0.02, 0.02, (-0.004, 0.004), null=0.0),),
            build=_delay,
        ),
    ]


def ab_candidate() -> Candidate:
    return Candidate(
        name="product",
        params=(
            ParamSpec("a", 0.3, 3.0, (0.8, 1.2), scale="log"),
            ParamSpec("b", 0.3, 3.0, (0.8, 1.2), scale="log"),
        ),
        build=_ab,
    )


@pytest.fixture
def toy() -> SimpleNamespace:
    """The toy structure: ``model``, ``obs(effects, ...)``, ``candidates()``, ``ab()``."""
    return SimpleNamespace(model=toy_model, obs=toy_obs, candidates=toy_candidates, ab=ab_candidate)


# the concealed-campaign generator is study code (studies/diagnose_reference.py), an
# implementation independent of robolobe.twin.effects
_STUDIES = Path(__file__).resolve().parents[2] / "studies"
if str(_STUDIES) not in sys.path:
    sys.path.insert(0, str(_STUDIES))
