"""The candidate library: every family builds valid twin effects; untestable candidates."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.diagnose.library import FAMILIES, build_library
from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.twin.effects import EFFECTS, effect_to_dict
from robolobe.twin.model import Twin

ALL = ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz")


def test_every_twin_effect_has_a_family() -> None:
    assert set(FAMILIES) == {"none", "file_parameters", *EFFECTS}


@pytest.mark.slow
def test_every_candidate_builds_at_its_grid_and_bounds() -> None:
    r = load_robot("B")
    cands, skipped = build_library(r, directions=ALL, n_force_levels=3, band_hz=(2.0, 40.0))
    assert not skipped
    assert cands[0].name == "none"
    assert {c.name for c in cands} == set(FAMILIES)
    q = np.radians([[0, 10, -60, 0, 30, 0]])
    f = np.array([5.0, 15.0])
    for c in cands:
        assert 0 <= c.n_params <= (3 if c.name != "file_parameters" else 19)
        pts = [*c.start_grid(), *(c.to_physical(b) for b in c.bounds_internal)]
        for p in pts:
            effects = c.effects(p)
            for e in effects:
                assert e.name == c.name
                if c.name in ("file_parameters", "tcp_offset", "sensor_gain"):
                    continue  # parameters map onto vector fields
                d = effect_to_dict(e)
                for spec, v in zip(c.params, p, strict=True):
                    assert d[spec.name] == pytest.approx(v)
            if c.name == "coupled_joint_stiffness":
                continue  # the bounds are where K stops being definite
            if c.fixed.get("mass_in_file"):
                # a sprung mass above the arm's effective mass at the TCP is refused
                try:
                    H = Twin(r, effects).receptance(q, f)
                except InputError as exc:
                    msg = str(exc)
                else:
                    msg = ""
                if msg:
                    assert "positive definite" in msg
                    continue
            H = Twin(r, effects).receptance(q, f)
            assert np.all(np.isfinite(H))


def test_untestable_candidates_say_why() -> None:
    r = load_robot("A")
    cands, skipped = build_library(r, directions=("yy",), n_force_levels=1, band_hz=(2.0, 40.0))
    why = {u.label: u.reason for u in skipped}
    assert "friction_damping" in why
    assert "force levels" in why["friction_damping"]
    assert "sensor_misalignment" in why
    assert "2 measured directions" in why["sensor_misalignment"]
    assert "tool_mode[direction x]" in why
    assert "tool_mode[direction y]" not in why
    labels = {c.label for c in cands}
    assert "tool_mode[direction y]" in labels
    assert "friction_damping" not in labels


def test_family_subset_and_unknown_name() -> None:
    r = load_robot("C")
    cands, _ = build_library(
        r, directions=ALL, n_force_levels=0, band_hz=(2.0, 40.0), families=["added_mass"]
    )
    assert [c.name for c in cands] == ["none", "added_mass"]
    with pytest.raises(InputError, match="expected one of"):
        build_library(r, directions=ALL, n_force_levels=0, band_hz=(2, 40), families=["magic"])


def test_one_hit_off_axis_changes_only_its_column() -> None:
    """``hammer_direction[hit x]``: the x hits tilt toward z by 10 deg, y and z hits stay.

    Reference written for the test: column x of the measured receptance is
    ``cos(a) H e_x + sin(a) H e_z`` (the hit's direction vector), the rest is ``H``.
    """
    from robolobe.twin.effects import HammerDirection

    r = load_robot("B")
    cands, _ = build_library(r, directions=ALL, n_force_levels=1, band_hz=(2.0, 40.0))
    hx = next(c for c in cands if c.label == "hammer_direction[hit x]")
    assert [p.name for p in hx.params] == ["ry_rad", "rz_rad"]
    a = np.radians(10.0)
    (eff,) = hx.effects(np.array([-a, 0.0]))  # Ry(-a) e_x = (cos a, 0, sin a)
    assert isinstance(eff, HammerDirection)
    assert eff.hit == "x"
    q = np.radians([[0, 10, -60, 0, 30, 0]])
    f = np.array([5.0, 9.0, 15.0])
    H = Twin(r).receptance(q, f)
    Hh = Twin(r, (eff,)).receptance(q, f)
    assert np.allclose(Hh[..., :, 0], np.cos(a) * H[..., :, 0] + np.sin(a) * H[..., :, 2])
    assert np.array_equal(Hh[..., :, 1:], H[..., :, 1:])
    with pytest.raises(InputError, match="hit"):
        HammerDirection(hit="w")
