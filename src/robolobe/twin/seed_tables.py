"""The seed paper's measured modes of robots B and C (its Tables 4 and 7).

At postures 1-3 of its Tables 3 (B) and 6 (C), the five lowest modes seen in
the Y direction of a hammer test at the tool: natural frequency, damping
ratio and modal stiffness from experimental modal analysis (EMA), beside the
transfer-learning prediction (TL) and the listed error |EMA - TL| / EMA [%].
These are the only published measurements of B and C; the built-in twins
are calibrated to them (:func:`robolobe.twin.calibration.fit_seed_table`).

The tables hold copy errors. :func:`table_checks` finds them from the
tables alone (no model): a listed error that the EMA and TL columns do not
reproduce (beyond the rounding of the printed digits), and a value that
repeats, to all printed digits, another cell of the tables.

The modal-stiffness column is printed in ``10^5 N/m``; :data:`K_UNIT_N_PER_M`
keeps that literal unit. The README ("Built-in robots") explains why the
column is most likely 10 times larger in SI (``10^6 N/m``); fits use the
relative stiffness (between modes and postures) and report the level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["K_UNIT_N_PER_M", "SEED_TABLES", "SeedTable", "TableCheck", "table_checks"]

FloatArray = NDArray[np.float64]

K_UNIT_N_PER_M = 1e5
"""Unit printed in the tables' modal-stiffness column [N/m]."""


@dataclass(frozen=True, eq=False)
class SeedTable:
    """One robot's table: 3 postures x 5 modes, Y direction.

    Attributes
    ----------
    robot : str
        "B" or "C".
    postures_deg : ndarray, shape (3, 6)
        Controller axis angles [deg] (seed Table 3 or 6, postures 1-3).
    ema, tl, err_pct : ndarray, shape (3, 3, 5)
        ``[quantity, posture, mode]`` with quantity 0 = natural frequency
        [Hz], 1 = damping ratio [%], 2 = modal stiffness [table unit,
        :data:`K_UNIT_N_PER_M`]; the listed error [%].
    source : str
    """

    robot: str
    postures_deg: FloatArray
    ema: FloatArray
    tl: FloatArray
    err_pct: FloatArray
    source: str

    @property
    def f_hz(self) -> FloatArray:
        """Measured natural frequencies [Hz], shape (3, 5)."""
        return self.ema[0]

    @property
    def zeta(self) -> FloatArray:
        """Measured damping ratios (fraction), shape (3, 5)."""
        out: FloatArray = self.ema[1] / 100.0
        return out

    @property
    def k_N_per_m(self) -> FloatArray:
        """Measured modal stiffness read literally (table value x 1e5 N/m), shape (3, 5)."""
        out: FloatArray = self.ema[2] * K_UNIT_N_PER_M
        return out

    @property
    def postures_rad(self) -> FloatArray:
        """Postures [rad], shape (3, 6)."""
        out: FloatArray = np.radians(self.postures_deg)
        return out


def _table(robot: str, postures: list[list[float]], rows: list[list[float]], src: str) -> SeedTable:
    # rows: posture-major, mode-minor; columns f EMA/TL/err, zeta EMA/TL/err, k EMA/TL/err
    a = np.array(rows, dtype=np.float64).reshape(3, 5, 3, 3)  # posture, mode, quantity, column
    col = np.transpose(a, (3, 2, 0, 1))  # column, quantity, posture, mode
    for arr in col:
        arr.setflags(write=False)
    q = np.array(postures, dtype=np.float64)
    q.setflags(write=False)
    return SeedTable(robot, q, col[0], col[1], col[2], src)


SEED_TABLES: dict[str, SeedTable] = {
    "B": _table(
        "B",
        [[-2, 21, -27, 5, 1, -29], [-60, 50, -120, 115, -66, -197], [23, -28, -101, -82, 124, 168]],
        [
            [7.352, 7.282, 0.944, 0.872, 0.980, 12.379, 1.34682, 1.35139, 0.339],
            [12.056, 12.012, 0.367, 2.138, 2.085, 2.450, 6.06784, 6.19108, 2.031],
            [14.530, 14.520, 0.068, 0.224, 0.221, 1.365, 17.96839, 18.20931, 1.341],
            [19.365, 19.301, 0.332, 3.643, 3.735, 2.551, 15.46110, 15.32584, 0.875],
            [31.493, 31.556, 0.198, 1.533, 1.548, 0.984, 10.00344, 9.93391, 0.695],
            [6.965, 7.020, 0.803, 1.020, 1.046, 2.582, 1.32453, 1.32285, 0.127],
            [11.263, 11.239, 0.210, 0.407, 0.482, 18.354, 0.74342, 0.72240, 2.828],
            [14.730, 14.806, 0.515, 6.895, 6.817, 1.133, 4.56509, 4.54101, 0.527],
            [23.769, 23.832, 0.265, 2.334, 2.442, 4.656, 26.90947, 26.90342, 0.022],
            [30.273, 30.278, 0.017, 2.932, 2.954, 0.761, 14.55168, 14.47240, 0.545],
            [7.48, 7.374, 1.428, 1.493, 1.533, 2.667, 1.27141, 1.28871, 1.361],
            [10.564, 10.538, 0.248, 2.412, 2.498, 3.566, 1.07695, 1.20460, 11.852],
            [13.602, 13.682, 0.587, 1.024, 1.039, 1.469, 4.56509, 4.52221, 0.939],
            [21.070, 21.089, 0.089, 3.582, 3.548, 0.946, 15.87799, 15.95576, 0.490],
            [31.453, 31.450, 0.011, 1.107, 1.107, 0.057, 19.92689, 19.97029, 0.218],
        ],
        "seed paper Table 4 (Comau NJ 650-2.7, Y direction) at Table 3 postures 1-3",
    ),
    "C": _table(
        "C",
        [[39, 8, 8, 98, -18, -30], [47, -10, 36, 74, -89, -13], [-3, 48, 20, -129, -57, -2]],
        [
            [13.7, 13.5, 0.851, 1.960, 1.957, 0.171, 1.27141, 1.27116, 0.019],
            [16.2, 16.21, 0.064, 1.050, 1.053, 0.277, 0.37339, 0.35082, 6.043],
            [22.3, 22.1, 0.642, 1.080, 1.027, 4.947, 13.78216, 13.56449, 1.579],
            [24.1, 24.15, 0.224, 0.160, 0.122, 23.85, 12.94221, 12.87258, 0.538],
            [25.3, 25.45, 0.622, 0.870, 0.871, 0.084, 25.30907, 25.18429, 0.493],
            [11.4, 11.42, 0.170, 1.720, 1.712, 0.490, 1.23723, 1.23706, 0.013],
            [12.4, 12.3, 0.310, 0.012, 0.015, 25.00, 0.35768, 0.38600, 7.918],
            [21.2, 21.3, 0.757, 3.290, 3.374, 2.547, 25.08313, 24.60109, 1.922],
            [22.6, 22.5, 0.224, 0.370, 0.376, 1.581, 15.87798, 12.87258, 0.538],
            [25.2, 25.1, 0.245, 1.720, 1.727, 0.412, 22.89233, 22.91483, 0.098],
            [11.8, 11.7, 0.282, 1.460, 1.510, 3.418, 1.19254, 1.19275, 0.017],
            [12.7, 12.702, 0.012, 1.320, 1.315, 0.374, 0.32806, 0.33172, 1.118],
            [20.1, 20.122, 0.108, 2.830, 2.866, 1.290, 15.58686, 15.49222, 0.607],
            [20.8, 20.87, 0.361, 0.430, 0.412, 4.167, 22.89233, 23.03473, 0.622],
            [25.5, 25.53, 0.118, 0.500, 0.500, 0.005, 27.24097, 27.08077, 0.588],
        ],
        "seed paper Table 7 (ABB IRB 4400, Y direction) at Table 6 postures 1-3",
    ),
}
"""Tables 4 (B) and 7 (C) of the seed paper, as printed."""

QUANTITIES = ("f", "zeta", "k")


@dataclass(frozen=True)
class TableCheck:
    """A problem the tables show by themselves.

    Attributes
    ----------
    robot : str
    posture, mode : int
        1-based.
    quantity : {"f", "zeta", "k"}
    kind : {"error column", "repeat"}
        The listed error disagrees with the EMA and TL columns, or the EMA
        value repeats another cell to all printed digits.
    detail : str
    """

    robot: str
    posture: int
    mode: int
    quantity: str
    kind: str
    detail: str


def _decimals(x: float) -> int:
    s = f"{x:.6f}".rstrip("0")
    return len(s.split(".")[1]) if "." in s else 0


def _printed(x: float) -> str:
    return f"{x:.6f}".rstrip("0").rstrip(".")


def table_checks(tables: dict[str, SeedTable] | None = None) -> list[TableCheck]:
    """Copy errors visible in the tables alone (no model involved).

    * error column: ``|EMA - TL| / EMA * 100`` (also ``/ TL``) is compared
      with the listed error; the allowed gap is what the rounding of the
      printed EMA and TL digits and of the printed error can explain.
    * repeat: an EMA value with at least 5 significant digits that equals
      another EMA cell of either table (same quantity) to all printed digits.

    Parameters
    ----------
    tables : dict, optional
        :data:`SEED_TABLES` if omitted.

    Returns
    -------
    list of TableCheck
    """
    tabs = SEED_TABLES if tables is None else tables
    out: list[TableCheck] = []
    cells: dict[tuple[int, str], list[tuple[str, int, int]]] = {}
    for name, t in tabs.items():
        for qi, qn in enumerate(QUANTITIES):
            for p in range(3):
                for m in range(5):
                    ema, tl, err = t.ema[qi, p, m], t.tl[qi, p, m], t.err_pct[qi, p, m]
                    round_abs = 0.5 * 10.0 ** -_decimals(ema) + 0.5 * 10.0 ** -_decimals(tl)
                    tol = 100.0 * round_abs / abs(ema) + 0.5 * 10.0 ** -_decimals(err) + 1e-9
                    calc = (100.0 * abs(ema - tl) / abs(ema), 100.0 * abs(ema - tl) / abs(tl))
                    if min(abs(c - err) for c in calc) > tol:
                        out.append(
                            TableCheck(name, p + 1, m + 1, qn, "error column",
                                       f"EMA {_printed(ema)}, TL {_printed(tl)} give "
                                       f"{calc[0]:.3f} %, listed {_printed(err)} %")
                        )  # fmt: skip
                    digits = len(_printed(ema).replace(".", "").lstrip("0"))
                    if digits >= 5:
                        key = (qi, _printed(ema))
                        cells.setdefault(key, []).append((name, p + 1, m + 1))
    for (qi, text), where in cells.items():
        if len(where) < 2:
            continue
        for name, p, m in where[1:]:
            first = where[0]
            out.append(
                TableCheck(name, p, m, QUANTITIES[qi], "repeat",
                           f"EMA {text} repeats {first[0]} posture {first[1]} mode {first[2]}")
            )  # fmt: skip
    return out
