"""Planning the program's own depth in passes, and lobes at each move's own engagement (issue 26).

References are written here: the depth-share table by hand, pass counts by
``ceil``, per-waypoint lobes against ``tests/sld/zoa_reference.py`` (the
boundary solved per speed with the textbook directional factors), and the
bundled pocket's full-width slot against the same reference.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.plan.lobes import DynamicsTolerance, waypoint_lobes
from robolobe.plan.optimize import LobeTable
from robolobe.plan.passes import program_depth, section_passes, sections
from robolobe.sld.frf import ModalModel

from ..sld.zoa_reference import alphas, reference_envelope


def _table() -> LobeTable:
    rpm = np.linspace(1000.0, 4000.0, 7)
    a = np.array([np.full(7, 2e-3), np.linspace(1e-3, 4e-3, 7), np.full(7, np.inf)])

    def exact(rows: np.ndarray, groups: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(r, rpm, a[g]) for r, g in zip(rows, groups, strict=True)])

    return LobeTable(rpm=rpm, a_lim=a, group=np.array([0, 0, 1, 1, 2]), exact=exact)


def test_per_depth_divides_each_limit_by_its_share_rounded_up() -> None:
    t = _table()
    share = np.array([1.0, 0.5, 0.25, 0.999, 0.7])
    s = t.per_depth(share, step=0.01)
    got = s.query(np.full(5, 2500.0))
    base = np.array([2e-3, 2e-3, 2.5e-3, 2.5e-3, np.inf])
    # each limit over a share rounded up by less than one step: never above a_lim / share
    ratio = got[:4] * share[:4] / base[:4]
    assert np.all(ratio <= 1 + 1e-12)
    assert np.all(ratio >= 1 / 1.01 - 1e-12)
    assert got[0] == base[0]  # the deepest move: its own limit
    assert np.isinf(got[4])  # the unbounded row stays unbounded
    # never above the move's own limit over its share
    assert np.all(got[:4] <= base[:4] / share[:4] * (1 + 1e-12))
    # the grid too
    np.testing.assert_allclose(s.a_lim[s.group[1]] * got[0], t.a_lim[0] * got[1], rtol=1e-12)


def test_per_depth_air_and_refusals() -> None:
    t = _table()
    s = t.per_depth(np.array([1.0, 0.0, np.nan, 1.0, 1.0]))
    assert np.isinf(s.query(np.full(5, 2000.0))[1:3]).all()
    with pytest.raises(Exception, match="share"):
        t.per_depth(np.array([np.inf, 1, 1, 1, 1]))
    # a move deeper than the planned depth (share above 1): its limit goes down
    assert t.per_depth(np.array([2.0, 1, 1, 1, 1])).query(np.full(5, 2000.0))[0] <= 1e-3
    with pytest.raises(Exception, match="share"):
        t.per_depth(np.ones(3))


def test_sections_and_passes_by_hand() -> None:
    depth = np.array([0.0, 5e-3, 5e-3, 5e-3, 2e-3, 2e-3])
    z = np.array([1e-3, -5e-3, -5e-3, -5e-3, -2e-3, -2e-3])
    bounded = np.array([False, True, True, True, True, True])
    sec = sections(np.array([3, 5, 6, 7, 10, 11]))  # rows of the waypoint table
    assert sec.tolist() == [0, 1, 1, 1, 2, 2]
    pd_ = program_depth(depth, z, bounded, sec)
    assert pd_ is not None
    assert not pd_.fixed.any()
    assert pd_.deepest_m == 5e-3
    a_lim = np.array([np.nan, 4e-3, 2.4e-3, 3e-3, 1e-3, 5e-3])
    passes, set_by = section_passes(pd_, a_lim, bounded, 1.2, 0.1)
    # ceil(5 * 1.2 / 2.4) = 3 (move 2), ceil(2 * 1.2 / 1) = 3 (move 4)
    assert passes.tolist() == [1, 3, 3]
    assert set_by.tolist() == [-1, 2, 4]
    # the depth cap per pass binds: 5 mm at most 1 mm a pass
    passes, _ = section_passes(pd_, np.full(6, 1.0), bounded, 1.0, 1e-3)
    assert passes.tolist() == [1, 5, 2]
    assert program_depth(np.zeros(3), np.zeros(3), np.ones(3, bool), np.zeros(3, int)) is None


def test_a_section_that_steps_down_itself_keeps_one_pass_at_its_own_depth() -> None:
    # one run of cutting moves: 3 mm at Z-3, then (a ramp) 3 mm at Z-6
    depth = np.array([3e-3, 3e-3, 3e-3, 3e-3])
    z = np.array([-3e-3, -3e-3, -6e-3, -6e-3])
    bounded = np.ones(4, bool)
    pd_ = program_depth(depth, z, bounded, np.zeros(4, np.int64))
    assert pd_ is not None
    assert pd_.fixed.all()
    # shifting it up whole would cut the lower level deeper than a pass: one pass, and
    # each move is planned at its own full depth whatever the planned depth per pass
    np.testing.assert_allclose(pd_.share(3) * pd_.deepest_m / 3, depth)
    passes, _ = section_passes(pd_, np.full(4, 1e-3), bounded, 1.0, 1.0)
    assert passes.tolist() == [1]


def _model(n: int) -> ModalModel:
    rng = np.random.default_rng(7)
    f = np.array([[180.0, 260.0]]).repeat(n, 0) * (1 + 0.001 * rng.standard_normal((n, 1)))
    zeta = np.full((n, 2), 0.04)
    k = np.array([2.0e7, 3.0e7])
    u = np.array([[1.0, 0.3], [-0.2, 1.0]])
    res = np.empty((n, 2, 2, 2))
    w = 2 * np.pi * f
    for r in range(2):
        v = u[r] / np.linalg.norm(u[r])
        # a real mode of modal stiffness k: residue phi phi^T w^2 / k
        res[:, r] = np.outer(v, v)[None] * w[:, r, None, None] ** 2 / k[r]
    return ModalModel(w, zeta, res)


def test_waypoint_lobes_at_each_waypoints_own_angles_match_the_reference() -> None:
    n = 6
    m = _model(n)
    pe = np.radians([0.0, 0.0, 90.0, 60.0, 120.0, 0.0])
    px = np.radians([180.0, 90.0, 180.0, 180.0, 180.0, 30.0])
    rpm = np.linspace(3000.0, 12000.0, 40)
    g = waypoint_lobes(
        [m], teeth=3, kt=8e8, kr=0.3, phi_entry=pe, phi_exit=px, rpm=rpm,
        immersion=0.25, tol=DynamicsTolerance(freq=0.0, damping=0.0, residue=0.0),
    )  # fmt: skip
    speeds = np.array([4100.0, 7300.0, 11000.0])
    got = g.table.query_shared(speeds)
    for i in range(n):
        ref = reference_envelope(
            m.f_hz[i], m.zeta[i], m.residues[i], alphas(pe[i], px[i], 0.3),
            teeth=3, kt=8e8, rpm=speeds,
        )  # fmt: skip
        np.testing.assert_allclose(got[i], ref, rtol=0.005, err_msg=f"waypoint {i}")
    # a full slot and a 30 deg arc are different groups whatever the tolerance
    g2 = waypoint_lobes(
        [m], teeth=3, kt=8e8, kr=0.3, phi_entry=pe, phi_exit=px, rpm=rpm, immersion=0.25,
        tol=DynamicsTolerance(freq=0.05),
    )  # fmt: skip
    assert g2.table.group[0] != g2.table.group[5]


def test_waypoint_lobes_refuse_bad_angles_on_bounded_waypoints() -> None:
    m = _model(2)
    rpm = np.linspace(3000.0, 12000.0, 10)
    with pytest.raises(Exception, match="phi_entry"):
        waypoint_lobes(
            [m], teeth=3, kt=8e8, kr=0.3, phi_entry=np.array([0.0, np.nan]),
            phi_exit=np.array([np.pi, np.nan]), rpm=rpm, immersion=1.0,
        )  # fmt: skip
    # NaN is fine where the waypoint is unbounded (air)
    g = waypoint_lobes(
        [m], teeth=3, kt=8e8, kr=0.3, phi_entry=np.array([0.0, np.nan]),
        phi_exit=np.array([np.pi, np.nan]), rpm=rpm, immersion=1.0,
        unbounded=np.array([False, True]),
    )  # fmt: skip
    assert np.isinf(g.table.query(np.array([5000.0, 5000.0]))[1])


def test_a_program_that_starts_with_a_cut_keeps_one_pass_there_and_is_written(tmp_path) -> None:
    import robolobe as rl
    from robolobe.plan.program import write_program

    prog = tmp_path / "startcut.nc"
    prog.write_text(
        "%\nO1\nG90 G21 G17\nS18000 M3\nG1 X0. Y0. Z-3. F1000.\nX40. F5400.\nY10.\nX0.\n"
        "G0 Z10.\nM30\n%\n"
    )
    job = rl.load_job(Path(__file__).parents[2] / "src/robolobe/data/examples/job_A_pocket.toml")
    res = rl.plan_path(prog, job)
    (sec,) = res.summary.passes
    assert sec["passes"] == 1
    assert sec["program_depth_mm"] == pytest.approx(3.0)
    assert any("starts with a cutting move (startcut.nc:5)" in n for n in res.summary.notes)
    # every move at its own full depth, at the safety factor
    assert res.summary.min_margin >= job.plan.safety_factor
    out = write_program(res, tmp_path / "out" / "prog")  # no passes to refuse
    assert out.is_file()


@pytest.mark.parametrize(
    ("dz_m", "steps_down"),
    [(0.0, False), (1e-7, False), (5e-6, False), (9e-6, False), (2e-5, True), (1e-3, True)],
)
def test_which_sections_step_down_themselves(dz_m: float, steps_down: bool) -> None:
    # one run of cutting moves whose tip heights differ by dz: float noise and a
    # program's own rounding (4 decimals in inch: 2.5 um) are one height, the same
    # height the stock's engagement calls one level; 20 um and more is a step down
    depth = np.full(4, 3e-3)
    z = np.array([-3e-3, -3e-3 + dz_m, -3e-3, -3e-3 + dz_m / 2])
    pd_ = program_depth(depth, z, np.ones(4, bool), np.zeros(4, np.int64))
    assert pd_ is not None
    assert bool(pd_.fixed.all()) is steps_down
    assert not (pd_.fixed.any() and not pd_.fixed.all())


def test_one_level_tolerance_for_sections_and_the_stock() -> None:
    from robolobe.plan import passes
    from robolobe.stock import engagement

    assert passes.LEVEL_TOL_M is engagement.LEVEL_TOL_M
