"""Calibration of the built-in robots: bands over the tested ranges, reproducibility.

Reference values: REFERENCES.md section 1 (seed Tables 2, 4, 7): five modes
per direction in B ~7-32 Hz, C ~11-26 Hz, damping 0.2-7 %, modal stiffness
0.3e5-27e5 N/m. The shipped robot files are checked on postures the fit did
not see; the thresholds below are what the six-spring model reaches (see
studies/calibration.py and the module docstring of robolobe.twin.calibration).
"""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot, sample_postures
from robolobe.twin.calibration import (
    TARGETS,
    TOOLS,
    CalibrationReport,
    calibrate_builtin,
    calibration_report,
    fit_damping,
)
from robolobe.twin.designs import TESTED_RANGES_DEG


@pytest.fixture(scope="module", params=["A", "B", "C"])
def report(request: pytest.FixtureRequest) -> CalibrationReport:
    name = request.param
    robot = load_robot(name)
    q = sample_postures(robot, 50, np.random.default_rng(11), TESTED_RANGES_DEG[name])
    return calibration_report(robot, q, TARGETS[name])


def _targets_name(report: CalibrationReport) -> str:
    for name, t in TARGETS.items():
        if t is report.targets:
            return name
    raise AssertionError("unknown targets")


def test_five_modes_seen_and_in_the_frequency_band(report: CalibrationReport) -> None:
    # the offset spindle (TOOLS) lets joints 4 and 6 move the TCP: all five seen nearly
    # everywhere (measured on these 50 postures: mode 5 seen at 96-100 %)
    assert len(report.modes) == 5
    for m in report.modes[:4]:
        assert m.seen == 1.0
    assert report.modes[4].seen >= 0.95
    for m in report.modes[1:4]:
        assert m.in_f_band >= 0.95, m
    # mode 1 dips below A's and B's 5 Hz in stretched postures (measured 70-100 %);
    # mode 5 climbs above C's 32 Hz (measured 34-96 %)
    assert report.modes[0].in_f_band >= 0.65
    assert report.modes[4].in_f_band >= 0.3


def test_medians_near_the_seed_anchors(report: CalibrationReport) -> None:
    # the fit trades the anchors for the modal-stiffness cap and the bands (worst: 38 %)
    anchors = np.array(report.targets.f_anchor_hz)
    medians = np.array([m.f_hz[1] for m in report.modes])
    np.testing.assert_allclose(medians, anchors, rtol=0.4)
    assert np.all(np.diff(medians) > 0)


def test_damping_in_band_wherever_seen(report: CalibrationReport) -> None:
    for m in report.modes:
        assert m.in_zeta_band == pytest.approx(m.seen)
        assert 0.005 <= m.zeta[1] <= 0.03  # 0.5-3 % typical
        assert m.zeta[0] >= 0.005  # measured >= 0.57 %
        assert m.zeta[2] <= 0.06  # measured <= 5.8 % (C, mode 5)


def test_modal_stiffness_range(report: CalibrationReport) -> None:
    lo, hi = report.targets.k_band_N_per_m
    for m in report.modes[:2]:
        assert m.in_k_band >= 0.95, m
    for m in report.modes:
        assert m.in_k_band >= 0.25, m  # measured >= 26 % (A, mode 5)
        assert m.k_N_per_m[0] >= lo
        assert m.k_N_per_m[1] <= 2 * hi  # measured medians <= 5.2e6 N/m (A, mode 5)
    # most modes and postures inside 1e4-3e6 N/m (measured: A 68 %, B 80 %, C 86 %)
    assert np.mean([m.in_k_band for m in report.modes]) >= 0.65


def test_frequencies_depend_on_posture(report: CalibrationReport) -> None:
    # tens of percent across the tested ranges (REFERENCES.md: +-20-40 %)
    for m in report.modes:
        assert m.f_spread >= 0.2


@pytest.mark.slow
@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_shipped_values_are_the_procedure_output(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    from robolobe.twin import calibration as cal

    shipped = load_robot(name)
    calls: list[tuple[object, np.ndarray]] = []
    solve = cal.least_squares

    def spy(fun, x0, **kw):  # type: ignore[no-untyped-def]
        sol = solve(fun, x0, **kw)
        calls.append((fun, sol.x))
        return sol

    monkeypatch.setattr(cal, "least_squares", spy)
    fitted = calibrate_builtin(name, shipped)
    # Stiffness: the objective is non-smooth (which modes are "seen" switches)
    # and flat along some joints, so where the solver stops in that valley moves
    # with SciPy/LAPACK versions (up to 20 % on one joint of C between the
    # environment that made the files and today's). The shipped values must be
    # as good an optimum of the same objective: cost within 2 % of the solver's.
    fun, x_fit = calls[-1]
    x_ship = np.log(shipped.stiffness / np.asarray(cal.PRIOR_STIFFNESS[name]))

    def cost(x: np.ndarray) -> float:
        return 0.5 * float(np.sum(fun(x) ** 2))  # type: ignore[operator]

    assert cost(x_ship) <= 1.02 * cost(x_fit), (cost(x_ship), cost(x_fit))
    # Damping is a linear fit given the stiffness: the files hold it to 3 digits.
    q = sample_postures(
        shipped, cal.FIT_POSTURES, np.random.default_rng(cal.FIT_SEED), TESTED_RANGES_DEG[name]
    )
    np.testing.assert_allclose(
        shipped.damping, cal.fit_damping(shipped, q, cal.TARGETS[name]), rtol=6e-3
    )
    np.testing.assert_allclose(shipped.tool, fitted.tool, atol=1e-12)
    xyz, _ = TOOLS[name]
    assert np.hypot(xyz[0], xyz[1]) >= 0.1  # TCP off the joint-6 axis
    assert shipped.end_effector is not None
    assert fitted.end_effector is not None
    assert shipped.end_effector.mass_kg == fitted.end_effector.mass_kg
    np.testing.assert_allclose(shipped.end_effector.com_m, fitted.end_effector.com_m)
    np.testing.assert_allclose(shipped.end_effector.inertia_kgm2, fitted.end_effector.inertia_kgm2)


def test_fit_damping_hits_the_target_on_average() -> None:
    robot = load_robot("B").with_damping(np.full(6, 1.0))
    q = sample_postures(robot, 30, np.random.default_rng(3), TESTED_RANGES_DEG["B"])
    t = TARGETS["B"]
    c = fit_damping(robot, q, t)
    rep = calibration_report(robot.with_damping(c), q, t)
    mean_zeta = np.mean([m.zeta[1] for m in rep.modes])
    assert mean_zeta == pytest.approx(t.zeta_target, rel=0.3)


def test_bad_inputs() -> None:
    robot = load_robot("C")
    with pytest.raises(InputError, match="q_samples"):
        calibration_report(robot, np.zeros((0, 6)))
    with pytest.raises(InputError, match="name"):
        calibrate_builtin("D", robot)


def test_default_targets_follow_the_builtin_robot() -> None:
    robot = load_robot("C")
    q = np.radians([[39, 8, 8, 98, -18, -30], [-3, 48, 20, -129, -57, -2]])  # seed Table 6
    assert calibration_report(robot, q).targets is TARGETS["C"]
    user = robot.replace(source="my_robot.toml")
    assert calibration_report(user, q).targets.f_band_hz == (5.0, 40.0)


def test_markdown_table(report: CalibrationReport) -> None:
    md = report.to_markdown()
    assert md.count("\n| ") == 6  # header + 5 modes
    assert report.robot_name in md
    assert _targets_name(report) in "ABC"
