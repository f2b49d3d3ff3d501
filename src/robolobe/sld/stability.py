"""One entry point for stability lobes: cutter + material + conditions + dynamics."""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from robolobe.errors import InputError, InputTypeError
from robolobe.sld.conditions import CuttingConditions
from robolobe.sld.converged import converged_lobes
from robolobe.sld.cutter import Cutter
from robolobe.sld.directional import directional_factors
from robolobe.sld.frf import ModalModel
from robolobe.sld.lobes import LobeDiagram
from robolobe.sld.material import Material
from robolobe.sld.sdm import sdm_lobes
from robolobe.sld.zoa import zoa_lobes

__all__ = ["stability_lobes"]


def stability_lobes(
    dynamics: ModalModel | tuple[ArrayLike, ArrayLike],
    *,
    cutter: Cutter | int,
    material: Material,
    conditions: CuttingConditions,
    rpm: ArrayLike,
    method: Literal["zoa", "sdm"] = "zoa",
    max_lobe: int | None = None,
    intervals: int = 40,
) -> LobeDiagram:
    """Stability lobes of a tool point (or a batch of them).

    Parameters
    ----------
    dynamics : ModalModel or (omega, frf)
        2-D feed-frame dynamics: a modal model (any batch shape; ZOA: its
        lobes are converged in frequency to
        :data:`robolobe.sld.converged.LOBE_TOL`, see
        :func:`robolobe.sld.converged.converged_lobes`) or sampled FRFs,
        ``omega`` [rad/s] of shape (n_freq,) or (..., n_freq) and ``frf``
        [m/N] of shape (..., n_freq, 2, 2) (ZOA only; the lobes are then as
        fine as those samples: nothing between them is known).
    cutter : Cutter or int
        The cutter, or just its number of teeth (all the solvers need).
    material : Material
        Gives Kt and Kr.
    conditions : CuttingConditions
        Engagement (entry/exit angles).
    rpm : array_like, shape (n_speed,)
        Spindle-speed grid [rpm].
    method : {"zoa", "sdm"}, default "zoa"
        Zero-order approximation (fast, batched) or semi-discretization
        (reference; loops over batch entries).
    max_lobe : int or None, default None
        Highest ZOA lobe number (None: every lobe that reaches the lowest
        speed, see :func:`zoa_lobes`).
    intervals : int, default 40
        SDM intervals per tooth period.

    Returns
    -------
    LobeDiagram
    """
    if not isinstance(cutter, Cutter | int):
        raise InputTypeError("cutter", "a Cutter or a number of teeth", cutter)
    if not isinstance(material, Material):
        raise InputTypeError("material", "a Material", material)
    if not isinstance(conditions, CuttingConditions):
        raise InputTypeError("conditions", "CuttingConditions", conditions)
    teeth = cutter if isinstance(cutter, int) else cutter.teeth
    if isinstance(teeth, bool) or teeth < 1:
        raise InputError(f"cutter: expected a Cutter or a number of teeth >= 1, found {cutter!r}")
    alpha = directional_factors(conditions.phi_entry, conditions.phi_exit, material.kr)
    if method == "zoa":
        if isinstance(dynamics, ModalModel):
            if dynamics.dim != 2:
                raise InputError(
                    f"dynamics: expected feed-frame (2-D) modes, found dim {dynamics.dim}"
                )
            return converged_lobes(
                dynamics,
                alpha,
                teeth=teeth,
                kt=material.kt,
                rpm=rpm,
                max_lobe=max_lobe,
                immersion=conditions.immersion,
            )
        omega_s, frf_s = _sampled(dynamics)
        return zoa_lobes(
            omega_s,
            frf_s,
            alpha=alpha,
            teeth=teeth,
            kt=material.kt,
            rpm=rpm,
            max_lobe=max_lobe,
            immersion=conditions.immersion,
        )
    if method == "sdm":
        if not isinstance(dynamics, ModalModel):
            raise InputError("method 'sdm' needs modal dynamics (a ModalModel), not sampled FRFs")
        batch = dynamics.batch_shape
        kw = dict(
            teeth=teeth,
            kt=material.kt,
            kr=material.kr,
            conditions=conditions,
            rpm=rpm,
            intervals=intervals,
        )
        if not batch:
            return sdm_lobes(dynamics, **kw)  # type: ignore[arg-type]
        flat = ModalModel(
            dynamics.omega.reshape(-1, dynamics.n_modes),
            dynamics.zeta.reshape(-1, dynamics.n_modes),
            dynamics.residues.reshape(-1, dynamics.n_modes, 2, 2),
        )
        # the reference solver: one entry at a time (seconds each)
        parts = [sdm_lobes(flat.take(i), **kw) for i in range(flat.batch_shape[0])]  # type: ignore[arg-type]
        a = np.stack([p.a_lim for p in parts]).reshape(*batch, -1)
        first = parts[0]
        import dataclasses

        return dataclasses.replace(first, a_lim=a)
    raise InputError(f"method: expected 'zoa' or 'sdm', found {method!r}")


def _sampled(dynamics: object) -> tuple[np.ndarray, np.ndarray]:
    """Sampled FRFs ``(omega, frf)`` checked as the file readers check measured ones."""
    from robolobe.errors import InputTypeError

    if not (isinstance(dynamics, tuple | list) and len(dynamics) == 2):
        raise InputTypeError("dynamics", "a ModalModel or a pair (omega, frf)", dynamics)
    try:
        omega = np.asarray(dynamics[0], dtype=np.float64)
        frf = np.asarray(dynamics[1], dtype=np.complex128)
    except (TypeError, ValueError) as exc:
        raise InputError(f"dynamics: expected numeric arrays (omega, frf), found {exc}") from None
    if frf.ndim < 3 or frf.shape[-2:] != (2, 2) or frf.shape[-3] != omega.shape[-1]:
        raise InputError(
            f"dynamics: expected frf of shape (..., {omega.shape[-1] if omega.ndim else '?'}, 2, "
            f"2) for omega of shape {omega.shape}, found {frf.shape}"
        )
    bad_w = ~np.isfinite(omega) | (omega < 0)
    if bad_w.any():
        i = int(np.argmax(bad_w.reshape(-1)))
        raise InputError(
            f"dynamics: omega: expected finite frequencies >= 0 rad/s, found "
            f"{omega.reshape(-1)[i]!r} at index {i}"
        )
    bad = ~np.isfinite(frf)
    if bad.any():
        i = int(np.argmax(bad.reshape(-1)))
        raise InputError(
            f"dynamics: frf: expected finite receptances (m/N), found {frf.reshape(-1)[i]!r} "
            f"at flat index {i}"
        )
    return omega, frf
