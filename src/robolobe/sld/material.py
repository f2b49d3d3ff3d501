"""Work materials: cutting-force coefficients and a small built-in table.

The linear edge-free force model ``F_t = Kt a h``, ``F_n = Kr F_t`` is what
the stability solvers use; ``Kr = Kn / Kt``. The built-in table ships as
``robolobe/data/materials.csv`` with a source for every row; rows marked
``estimated`` are engineering estimates, not published data. User values
override table values (:func:`get_material`). Each row also holds the cutting
data an engineer checks first: a cutting-speed range vc [m/min] and a feed
per tooth range fz [mm] for carbide cutters, with their own source
(``cutting_source``; the plan's limits: :mod:`robolobe.plan.limits`).
"""

from __future__ import annotations

import csv
import functools
import io
import math
import re
from dataclasses import dataclass, replace
from importlib import resources

from robolobe.errors import InputError

__all__ = ["Material", "get_material", "material_table"]

_TABLE = "materials.csv"


#: Physical range of the tangential cutting coefficient Kt [N/m^2]: about
#: 1e8 for soft plastics and wood composites up to ~5e9 for hardened steel
#: and nickel alloys (Altintas, *Manufacturing Automation*, tables of Kt);
#: a value outside it is a unit mistake (N/mm^2 given as N/m^2).
KT_RANGE_N_PER_M2 = (1.0e7, 2.0e10)
#: Largest plausible Kr = Kn/Kt (published ratios are 0.05-1.5).
KR_MAX = 5.0


@dataclass(frozen=True)
class Material:
    """Cutting-force coefficients of a work material.

    Parameters
    ----------
    name : str
        Material name.
    kt : float
        Tangential cutting coefficient Kt [N/m^2].
    kr : float
        Ratio ``Kn / Kt`` of the normal (radial) to the tangential
        coefficient [-].
    source : str
        Where the numbers come from.
    estimated : bool
        True for engineering estimates (not published data).
    vc_range_m_per_min : (float, float) or None
        Cutting-speed range (vc_min, vc_max) [m/min] for carbide cutters;
        None: not known.
    fz_range_mm : (float, float) or None
        Feed per tooth range (fz_min, fz_max) [mm]; None: not known.
    cutting_source : str
        Where the vc and fz ranges come from.

    Raises
    ------
    InputError
        On a non-positive ``kt`` or a negative ``kr``, or a vc or fz range
        that is not ``0 < min < max``.
    """

    name: str
    kt: float
    kr: float
    source: str = "user"
    estimated: bool = False
    vc_range_m_per_min: tuple[float, float] | None = None
    fz_range_mm: tuple[float, float] | None = None
    cutting_source: str = ""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.kt) and self.kt > 0.0):
            raise InputError(f"Kt: expected a positive coefficient in N/m^2, found {self.kt:g}")
        if not KT_RANGE_N_PER_M2[0] <= self.kt <= KT_RANGE_N_PER_M2[1]:
            hint = (
                f" (it looks like N/mm^2: {self.kt:g} N/mm^2 = {self.kt * 1e6:g} N/m^2)"
                if self.kt * 1e6 <= KT_RANGE_N_PER_M2[1]
                else ""
            )
            raise InputError(
                f"Kt: expected {KT_RANGE_N_PER_M2[0]:g} to {KT_RANGE_N_PER_M2[1]:g} N/m^2 "
                f"(plastics to hardened steel), found {self.kt:g} N/m^2{hint}"
            )
        if not (math.isfinite(self.kr) and 0.0 <= self.kr <= KR_MAX):
            raise InputError(f"Kr: expected Kn/Kt in [0, {KR_MAX:g}], found {self.kr:g}")
        for what, rng in (("vc", self.vc_range_m_per_min), ("fz", self.fz_range_mm)):
            if rng is not None and not (
                all(math.isfinite(v) for v in rng) and 0.0 < rng[0] < rng[1]
            ):
                raise InputError(f"{what} range: expected 0 < min < max, found {rng}")

    @property
    def kn(self) -> float:
        """Normal (radial) cutting coefficient Kn = Kr Kt [N/m^2]."""
        return self.kr * self.kt


def _key(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.lower())


@functools.cache
def _load() -> tuple[tuple[Material, ...], dict[str, Material]]:
    text = resources.files("robolobe.data").joinpath(_TABLE).read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    rows = list(csv.DictReader(io.StringIO("\n".join(lines))))
    table: list[Material] = []
    index: dict[str, Material] = {}
    for row in rows:
        m = Material(
            name=row["name"],
            kt=float(row["kt_N_per_mm2"]) * 1e6,
            kr=float(row["kr"]),
            source=row["source"],
            estimated=row["estimated"].strip().lower() in ("yes", "true", "1"),
            vc_range_m_per_min=(float(row["vc_min_m_per_min"]), float(row["vc_max_m_per_min"])),
            fz_range_mm=(float(row["fz_min_mm"]), float(row["fz_max_mm"])),
            cutting_source=row["cutting_source"],
        )
        table.append(m)
        for alias in [m.name, *row["aliases"].split(";")]:
            if alias.strip():
                index[_key(alias)] = m
    return tuple(table), index


def material_table() -> tuple[Material, ...]:
    """The built-in materials, in table order."""
    return _load()[0]


def get_material(name: str, *, kt: float | None = None, kr: float | None = None) -> Material:
    """A built-in material by name (case and punctuation ignored), with overrides.

    Parameters
    ----------
    name : str
        Table name or alias, e.g. ``"Al7075-T6"``, ``"al7075"``, ``"Ti6Al4V"``.
    kt : float, optional
        Tangential coefficient [N/m^2] replacing the table value.
    kr : float, optional
        ``Kn / Kt`` replacing the table value.

    Returns
    -------
    Material
        With ``source`` noting any user override.

    Raises
    ------
    InputError
        When the name is not in the table.
    """
    table, index = _load()
    m = index.get(_key(name))
    if m is None:
        known = ", ".join(t.name for t in table)
        raise InputError(f"material: expected one of {known}, found {name!r}")
    if kt is None and kr is None:
        return m
    changed = [s for s, v in (("Kt", kt), ("Kr", kr)) if v is not None]
    return replace(
        m,
        kt=m.kt if kt is None else float(kt),
        kr=m.kr if kr is None else float(kr),
        source=f"{m.source}; {' and '.join(changed)} given by the user",
        estimated=m.estimated and not (kt is not None and kr is not None),
    )
