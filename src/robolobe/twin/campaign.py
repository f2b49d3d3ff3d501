"""Simulated hammer-test campaigns: the twin's receptance through a simulated test.

The data model and its files are :mod:`robolobe.campaign`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import AXES
from robolobe.campaign import ALL_DIRS, Campaign
from robolobe.errors import InputError
from robolobe.twin.hammer import HammerTestSettings, simulate_hammer_test

__all__ = ["simulate_campaign"]

FloatArray = NDArray[np.float64]


def simulate_campaign(
    receptance: Callable[[FloatArray, FloatArray], ArrayLike],
    robot: str,
    posture_ids: Sequence[str],
    q_rad: ArrayLike,
    *,
    rng: np.random.Generator,
    settings: HammerTestSettings | None = None,
    exact: bool = False,
    dirs: Iterable[str] = ALL_DIRS,
    fmax_hz: float = 40.0,
    on_posture: Callable[[int], None] | None = None,
) -> Campaign:
    """A campaign of simulated hammer tests (or of exact receptances).

    Parameters
    ----------
    receptance : callable
        ``receptance(q_rad (6,), freq_hz (n,)) -> (n, 3, 3)`` [m/N], e.g.
        ``Twin(robot).receptance``.
    robot : str
        Robot reference stored in the campaign ("A", "B", "C" or a path).
    posture_ids : sequence of str, length n
    q_rad : array_like, shape (n, 6)
        Joint angles [rad].
    rng : numpy.random.Generator
        One child generator is spawned per posture (a posture's test does not
        depend on the others).
    settings : HammerTestSettings, optional
        The test (default: the seed's).
    exact : bool
        Store the receptance itself (no test, no noise) instead of H1.
    dirs : iterable of str
        Directions kept (response, excitation); only the excitation
        directions they need are hit.
    fmax_hz : float
        Band 0..fmax_hz [Hz], on the test's grid (step 1 / duration_s).
    on_posture : callable, optional
        Called with the posture index after each posture (progress).

    Returns
    -------
    Campaign
        ``test`` holds sample_rate_hz, duration_s, impacts and window_end of
        a simulated test (empty when exact).
    """
    s = settings if settings is not None else HammerTestSettings()
    want = sorted({str(d).lower() for d in dirs}, key=ALL_DIRS.index)
    if not want or any(d not in ALL_DIRS for d in want):
        raise InputError(
            f"expected directions like xx, xy, found {list(dirs)!r}", source="simulate_campaign"
        )
    if not 0 < fmax_hz <= s.sample_rate_hz / 2:
        raise InputError(
            f"expected 0 < fmax_hz <= {s.sample_rate_hz / 2:g}, found {fmax_hz:g}",
            source="simulate_campaign",
        )
    q = np.asarray(q_rad, dtype=float).reshape(len(posture_ids), 6)
    excite = "".join(sorted({d[1] for d in want}, key=AXES.index))
    children = rng.spawn(len(posture_ids))
    full = s.freq_hz
    freq = full[full <= fmax_hz * (1 + 1e-12)]
    H = np.empty((len(posture_ids), freq.size, 3, 3), dtype=complex)
    for i in range(len(posture_ids)):
        qi = q[i]
        if exact:
            H[i] = np.asarray(receptance(qi, freq))
        else:
            res = simulate_hammer_test(
                lambda f, qi=qi: receptance(qi, f),  # type: ignore[misc]
                rng=children[i],
                settings=s,
                excite=excite,
            )
            H[i] = res.H1[: freq.size]
        if on_posture is not None:
            on_posture(i)
    if exact:
        notes = "exact receptance (no test)"
        test: dict[str, Any] = {}
    else:
        notes = (
            f"simulated hammer test: H1, exponential window to {s.window_end:g}, "
            f"noise {s.force_noise_n:g} N / {s.accel_noise_m_per_s2:g} m/s^2 rms, "
            f"double-hit probability {s.double_hit_probability:g}"
        )
        test = {
            "sample_rate_hz": float(s.sample_rate_hz),
            "duration_s": float(s.duration_s),
            "impacts": int(s.impacts),
            "window_end": float(s.window_end),
        }
    return Campaign.from_arrays(robot, posture_ids, q, freq, H, dirs=want, notes=notes, test=test)
