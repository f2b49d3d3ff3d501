"""Forward selection of several effects on the toy structure."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from robolobe._threads import one_blas_thread
from robolobe.diagnose.candidate import Candidate, ParamSpec
from robolobe.diagnose.forward import ForwardSettings, forward_select


def _names(toy: SimpleNamespace, effects: tuple, seed: int = 0) -> tuple[str, ...]:
    obs = toy.obs(effects, seed=seed)
    fw = forward_select(toy.candidates(), toy.model, obs, obs)
    assert not fw.noise.unexplained
    return tuple(s.candidate.name for s in fw.steps)


def test_a_small_second_effect_next_to_a_large_one_is_named(toy: SimpleNamespace) -> None:
    # the mass puts the nominal model at 10x the noise; the 1 % stiffness error is
    # 0.1 % of that excess but all of what is left after the mass (the mass alone
    # leaves 1.02x the noise: a search that stopped at 1.3x, or asked a share of the
    # nominal excess, did not name it)
    got = _names(toy, (("mass", 150.0), ("kx", 1.01)))
    assert set(got) == {"added_mass", "joint_stiffness"}


@pytest.mark.parametrize("seed", [0, 1])
def test_no_second_effect_is_made_up(toy: SimpleNamespace, seed: int) -> None:
    assert _names(toy, (("mass", 150.0),), seed=seed) == ("added_mass",)
    assert _names(toy, (), seed=seed) == ()


def test_later_rounds_are_not_screened_by_the_nominal_ranking(toy: SimpleNamespace) -> None:
    # a stiffening of x ranks below `none` on the nominal model: the 150 kg mass makes
    # the measured structure look softer, so a factor that can only stiffen stays at its
    # null (1.0) and pays its parameter, like a gravity stiffening next to a large tool
    # mode on robot C; round 2 must still try it on top of the mass (a screen by the
    # round-1 ranking never did). (This was a 0.1 ms delay ranking below `none`: that
    # was a delay fit stopped at its null by a vanishing finite-difference step; a delay
    # does absorb part of the mass's phase error.)
    cands = [
        Candidate(
            name="joint_stiffness",
            variant="x",
            params=(ParamSpec("factor", 1.0, 3.0, (1.2, 1.6), scale="log", null=1.0),),
            build=c.build,
        )
        if c.name == "joint_stiffness"
        else c
        for c in toy.candidates()
    ]
    obs = toy.obs((("mass", 150.0), ("kx", 1.02)), seed=0)
    fw = forward_select(cands, toy.model, obs, obs, settings=ForwardSettings(screen_k=1))
    r1 = sorted(fw.fits, key=lambda f: f.bic)
    names = [f.candidate.name for f in r1]
    assert names.index("joint_stiffness") > names.index("none")  # the premise
    assert not fw.noise.unexplained
    assert tuple(s.candidate.name for s in fw.steps) == ("added_mass", "joint_stiffness")


@pytest.mark.slow
def test_fits_over_workers_are_the_fits_of_one_process(toy: SimpleNamespace) -> None:
    obs = toy.obs((("mass", 150.0), ("kx", 1.01)))
    with one_blas_thread():  # as diagnose() runs it, and as the workers do
        one = forward_select(toy.candidates(), toy.model, obs, obs)
        two = forward_select(toy.candidates(), toy.model, obs, obs, n_jobs=2)
    assert [s.label for s in two.steps] == [s.label for s in one.steps]
    for a, b in zip(one.fits, two.fits, strict=True):
        assert a.candidate.label == b.candidate.label
        np.testing.assert_allclose(a.params, b.params, rtol=1e-9)
        assert a.deviance == pytest.approx(b.deviance, rel=1e-9)
    np.testing.assert_allclose(one.model_fit.params, two.model_fit.params, rtol=1e-9)


def test_an_other_family_alternative_as_good_makes_a_step_ambiguous() -> None:
    """Joint BICs written for the test: within 10 of the step's -> ambiguous, unless same family."""
    from robolobe.diagnose.candidate import Candidate
    from robolobe.diagnose.forward import _alternatives

    def cand(name: str, variant: str = "") -> Candidate:
        return Candidate(name, (), lambda p: (), variant=variant)

    def fit(c: Candidate, bic: float) -> SimpleNamespace:
        return SimpleNamespace(candidate=c, bic=bic)

    win = cand("tcp_offset")
    pool = [
        (fit(win, 100.0), fit(win, 100.0)),
        (fit(cand("added_mass"), 0.0), fit(cand("added_mass"), 105.0)),  # 5 above: as good
        (fit(cand("sensor_gain"), 0.0), fit(cand("sensor_gain"), 130.0)),  # 30 above: worse
        (fit(cand("tcp_offset", "x"), 0.0), fit(cand("tcp_offset", "x"), 101.0)),  # same family
    ]
    st = ForwardSettings()
    assert _alternatives(win, 100.0, pool, st) == ("added_mass",)  # type: ignore[arg-type]
    # the file calibration and the joint families it holds are one explanation by design
    cal = cand("file_parameters")
    pool2 = [(fit(cand("joint_stiffness", "joint 3"), 0.0), fit(cand("joint_stiffness"), 100.0))]
    assert _alternatives(cal, 100.0, pool2, st) == ()  # type: ignore[arg-type]


def test_two_effects_left_are_taken_together(toy: SimpleNamespace) -> None:
    """A step that removes less than the share because another effect is left is kept with it.

    With a share of 0.9, the 1 % stiffness error and the 0.1 ms delay each
    remove only part of what the mass leaves; neither alone met the share,
    and the search used to stop after the mass.
    """
    obs = toy.obs((("mass", 150.0), ("kx", 1.01), ("delay", 0.0001)), seed=0)
    st = ForwardSettings(min_share=0.9)
    fw = forward_select(toy.candidates(), toy.model, obs, obs, settings=st)
    assert not fw.noise.unexplained
    assert {s.candidate.name for s in fw.steps} == {"added_mass", "joint_stiffness", "sensor_delay"}
    # the premise: the second step alone removed less than 0.9 of what the mass left
    assert fw.steps[1].gain < 0.9 * (fw.steps[0].per_residual - 1.0)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_trial_step_without_a_partner_is_taken_back(toy: SimpleNamespace, seed: int) -> None:
    obs = toy.obs((("mass", 150.0), ("kx", 1.01)), seed=seed)
    st = ForwardSettings(min_share=0.999)
    fw = forward_select(toy.candidates(), toy.model, obs, obs, settings=st)
    got = tuple(s.candidate.name for s in fw.steps)
    # the stiffness step removes nearly all that is left, or it is taken back with a note
    assert got in (("added_mass", "joint_stiffness"), ("added_mass",))
    if got == ("added_mass",):
        assert any("no further step" in r or " and " in r for r in fw.rejected)


def test_the_file_calibration_takes_no_place_among_the_effects(toy: SimpleNamespace) -> None:
    """With ``max_effects=2``, two effects and a file correction are all named.

    The toy's x-stiffness candidate stands in for the file calibration (its
    name); before, the calibration took one of the ``max_effects`` places and
    the third effect was left out (a TCP offset with two hammer directions off,
    in a file 10 % off, needs three effects and the calibration).
    """
    from robolobe.diagnose.calibration import CALIBRATION

    cands = [
        dataclasses.replace(c, name=CALIBRATION) if c.name == "joint_stiffness" else c
        for c in toy.candidates()
    ]
    obs = toy.obs((("mass", 150.0), ("kx", 1.05), ("delay", 0.0005)), seed=0)
    fw = forward_select(cands, toy.model, obs, obs, settings=ForwardSettings(max_effects=2))
    assert not fw.noise.unexplained
    assert {s.candidate.name for s in fw.steps} == {"added_mass", CALIBRATION, "sensor_delay"}
    one = forward_select(cands, toy.model, obs, obs, settings=ForwardSettings(max_effects=1))
    # one effect place: the calibration joins, a second effect does not
    assert sum(s.candidate.name != CALIBRATION for s in one.steps) == 1


def test_a_misfit_concentrated_in_one_band_is_not_explained(toy: SimpleNamespace) -> None:
    """A prediction 11 deg off in phase over 5 Hz of one direction averages under 1.5x the noise.

    The averages pass it (most of the band is predicted within the noise);
    the band test does not: that band misses by over 6 noise deviations RMS
    (damping that grows with the gravity load, named "file off" at 1.5x the
    noise on average, missed the lowest modes by 11-15x). The exact model
    passes both.
    """
    from robolobe.diagnose.forward import noise_test
    from robolobe.diagnose.residuals import deviance_per_record

    obs = toy.obs((), seed=0)
    H = toy.model((), obs)

    def test(Hp: np.ndarray):  # type: ignore[no-untyped-def]
        dev, cnt = deviance_per_record(Hp, obs)
        cv = SimpleNamespace(H=Hp, deviance=dev, count=cnt, per_residual=dev.sum() / cnt.sum())
        return noise_test(cv, obs)  # type: ignore[arg-type]

    off = H.copy()
    off[:, (obs.freq_hz >= 10.0) & (obs.freq_hz < 15.0), 0, 0] *= np.exp(0.2j)
    nt = test(off)
    assert nt.misfit_x_noise < 1.5
    assert nt.nrmse_x_noise < 1.5
    assert nt.band_misfit_x_noise > 6.0
    assert nt.unexplained
    assert nt.worst_bands[0].direction == "xx"
    assert nt.worst_bands[0].f_lo_hz == 10.0
    exact = test(H)
    assert exact.band_misfit_x_noise < 2.0
    assert not exact.unexplained
