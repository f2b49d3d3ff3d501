"""Lobe plots (matplotlib, Agg; no pyplot state; matplotlib loads on first use)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from robolobe._atomic import atomic_path
from robolobe.errors import InputError
from robolobe.sld.lobes import LobeDiagram

if TYPE_CHECKING:  # matplotlib is imported when a plot is made, not with the package
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["plot_lobes", "save_lobe_plot"]


def plot_lobes(
    diagram: LobeDiagram,
    *,
    index: int | None = None,
    ax: Axes | None = None,
    operating_points: tuple[ArrayLike, ArrayLike] | None = None,
    safety_factor: float | None = None,
    depth_max: float | None = None,
    show_lobes: bool = False,
    title: str | None = None,
) -> Figure:
    """Plot the lobe envelope with the stable region shaded.

    Parameters
    ----------
    diagram : LobeDiagram
        Lobes; a batched diagram needs ``index``.
    index : int, optional
        Batch entry to plot (first batch axis).
    ax : matplotlib Axes, optional
        Axes to draw into; a new Agg figure otherwise.
    operating_points : (rpm, depth [m]), optional
        Points to mark; green when below the envelope (queried exactly),
        red otherwise.
    safety_factor : float, optional
        Draw ``a_lim / safety_factor`` as a dashed safety line (>= 1).
    depth_max : float, optional
        Upper limit of the depth axis [m]; default 3x the median envelope.
    show_lobes : bool, default False
        Also draw the individual ZOA lobes (thin lines).
    title : str, optional
        Axes title.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    d = diagram
    if d.batch_shape:
        if index is None:
            raise InputError(f"index: the diagram holds a batch {d.batch_shape}; pick one entry")
        d = d.take(index)
    if ax is None:
        fig = Figure(figsize=(8.0, 4.8), layout="constrained")
        FigureCanvasAgg(fig)
        ax = fig.add_subplot()
    else:
        fig = ax.get_figure()  # type: ignore[assignment]
    rpm = d.rpm
    a_mm = d.a_lim * 1e3
    finite = a_mm[np.isfinite(a_mm)]
    if depth_max is not None:
        top = depth_max * 1e3
    elif finite.size:
        top = 3.0 * float(np.median(finite))
    else:
        top = 1.0
    shown = np.minimum(np.where(np.isfinite(a_mm), a_mm, top), top)
    ax.fill_between(rpm, 0.0, shown, color="#cfe8cf", label="stable", linewidth=0)
    ax.fill_between(rpm, shown, top, color="#f4d0d0", label="chatter", linewidth=0)
    ax.plot(rpm, shown, color="k", lw=1.2, label=f"a_lim ({d.method.upper()})")
    if show_lobes and d.depth is not None:
        for k in range(d.max_lobe + 1):
            n_k, a_k = d.lobe(k)
            for j in range(n_k.shape[0]):
                ax.plot(n_k[j], a_k[j] * 1e3, color="0.6", lw=0.5)
    if safety_factor is not None:
        if not safety_factor >= 1.0:
            raise InputError(f"safety_factor: expected >= 1, found {safety_factor!r}")
        safe = np.minimum(a_mm / safety_factor, top)  # inf / factor clips to the top too
        ax.plot(rpm, safe, "k--", lw=1.0, label=f"a_lim / {safety_factor:g}")
    if operating_points is not None:
        op_n = np.atleast_1d(np.asarray(operating_points[0], dtype=float))
        op_a = np.atleast_1d(np.asarray(operating_points[1], dtype=float))
        lim = d.query(op_n)
        ok = op_a < lim
        ax.scatter(
            op_n[ok], op_a[ok] * 1e3, c="tab:green", edgecolors="k", zorder=5, label="stable point"
        )
        ax.scatter(
            op_n[~ok],
            op_a[~ok] * 1e3,
            c="tab:red",
            edgecolors="k",
            marker="X",
            zorder=5,
            label="unstable point",
        )
    ax.set_xlim(float(rpm.min()), float(rpm.max()))
    ax.set_ylim(0.0, top)
    ax.set_xlabel("spindle speed [rpm]")
    ax.set_ylabel("axial depth a_p [mm]")
    if title:
        ax.set_title(title)
    if not d.valid:
        ax.text(
            0.01,
            0.98,
            "ZOA unreliable at this immersion",
            transform=ax.transAxes,
            va="top",
            fontsize=8,
            color="darkred",
        )
    ax.legend(loc="upper right", fontsize=8)
    return fig


def save_lobe_plot(diagram: LobeDiagram, path: str | os.PathLike[str], **kwargs: object) -> None:
    """:func:`plot_lobes` written atomically to ``path`` (format from the suffix)."""
    fig = plot_lobes(diagram, **kwargs)  # type: ignore[arg-type]
    suffix = os.path.splitext(os.fspath(path))[1].lstrip(".") or "png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=suffix, dpi=120)
