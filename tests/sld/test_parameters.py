"""Cutter, material table and cutting conditions."""

from __future__ import annotations

import math

import pytest

from robolobe.errors import InputError
from robolobe.sld import (
    Cutter,
    CuttingConditions,
    Material,
    engagement_angles,
    get_material,
    material_table,
    radial_immersion,
)


def test_material_table_has_sources() -> None:
    table = material_table()
    names = {m.name for m in table}
    assert {"Al7075-T6", "Al7050", "Al6061-T6", "steel", "Ti6Al4V"} <= names
    for m in table:
        assert m.source
        assert m.kt > 1e8
        assert 0 < m.kr < 1
    # REFERENCES.md section 3
    al7075 = get_material("Al7075-T6")
    assert al7075.kt == pytest.approx(767.01e6)
    assert al7075.kr == pytest.approx(168.8 / 767.01, rel=1e-3)
    al7050 = get_material("al7050")
    assert (al7050.kt, al7050.kr) == (pytest.approx(796e6), pytest.approx(0.212))
    assert get_material("steel").estimated
    assert get_material("titanium").estimated
    assert not al7075.estimated


def test_material_lookup_and_override() -> None:
    assert get_material("AL-7075 T6") is get_material("7075")
    m = get_material("Ti6Al4V", kt=2.2e9)
    assert m.kt == 2.2e9
    assert m.kr == get_material("Ti6Al4V").kr
    assert "given by the user" in m.source
    assert m.kn == pytest.approx(m.kr * m.kt)
    with pytest.raises(InputError, match="Al7075-T6"):
        get_material("unobtainium")
    with pytest.raises(InputError, match="Kt"):
        Material("x", kt=-1.0, kr=0.3)
    # 700 N/mm^2 given where N/m^2 is expected: a unit mistake, named as such
    with pytest.raises(InputError, match=r"looks like N/mm\^2: 700 N/mm\^2 = 7e\+08 N/m\^2"):
        Material("x", kt=700.0, kr=0.3)
    with pytest.raises(InputError, match="Kr"):
        Material("x", kt=7e8, kr=30.0)


def test_builtin_materials_are_inside_the_plausible_range() -> None:
    from robolobe.sld.material import KT_RANGE_N_PER_M2

    table = material_table()
    assert len(table) >= 5
    for m in table:
        assert KT_RANGE_N_PER_M2[0] < m.kt < KT_RANGE_N_PER_M2[1]


def test_cutter_validation() -> None:
    c = Cutter(diameter=0.02, teeth=3, flute_length=0.04)
    assert c.radius == 0.01
    assert c.max_depth == 0.04
    assert Cutter(diameter=0.02, teeth=2).max_depth == math.inf
    for bad in (
        {"diameter": -0.01, "teeth": 2},
        {"diameter": 0.01, "teeth": 0},
        {"diameter": 0.01, "teeth": 2.5},
        {"diameter": 0.01, "teeth": 2, "helix": 2.0},
    ):
        with pytest.raises(InputError):
            Cutter(**bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("immersion", [1.0, 0.5, 0.25, 0.1, 0.05])
@pytest.mark.parametrize("milling", ["up", "down"])
def test_engagement_round_trip(immersion: float, milling: str) -> None:
    st, ex = engagement_angles(immersion, milling)
    assert radial_immersion(st, ex) == pytest.approx(immersion)
    if milling == "up":
        assert st == 0.0
    else:
        assert ex == math.pi
    c = CuttingConditions.from_immersion(immersion, milling, feed_per_tooth=1e-4)
    assert c.immersion == pytest.approx(immersion)
    assert c.milling == milling


def test_conditions_from_width_and_errors() -> None:
    c = CuttingConditions.from_radial_width(0.005, 0.02, "down")
    assert c.immersion == pytest.approx(0.25)
    assert c.phi_entry == pytest.approx(math.acos(-0.5))
    with pytest.raises(InputError, match="immersion"):
        engagement_angles(1.5, "down")
    with pytest.raises(InputError, match="milling"):
        engagement_angles(0.5, "climb")
    with pytest.raises(InputError, match="radial width"):
        CuttingConditions.from_radial_width(0.03, 0.02, "up")
    with pytest.raises(InputError, match="phi_entry"):
        CuttingConditions(2.0, 1.0)
