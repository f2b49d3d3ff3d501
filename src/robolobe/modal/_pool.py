"""Worker-pool tasks of the identification (kept light: a worker imports only this
module, :mod:`robolobe.modal.posture` and :mod:`robolobe._workers`, not pandas or the
campaign code); the pool itself is :func:`robolobe._workers.map_chunks`."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from robolobe.modal.posture import PostureModal, identify_posture, refit_posture

__all__ = ["identify_item", "refit_item"]


def identify_item(a: tuple[Any, ...]) -> PostureModal:
    """:func:`identify_posture` of ``(posture_id, freq_hz, H, coherence, settings)``."""
    pid, f, h, coh, s = a
    return identify_posture(f, h, coherence=coh, settings=s, posture_id=pid)


def refit_item(a: tuple[PostureModal, NDArray[np.complex128]]) -> PostureModal:
    """:func:`refit_posture` of ``(posture, extra_poles)``."""
    return refit_posture(a[0], a[1])
