"""Model selection: folds, ranking, and the 'none' answer (toy structure)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robolobe.diagnose.fitting import fit_candidate
from robolobe.diagnose.selection import SelectionSettings, make_folds, select
from robolobe.errors import InputError


def test_folds_keep_groups_together() -> None:
    groups = ("a", "a", "b", "c", "b", "d", "e")
    folds = make_folds(groups, 3)
    assert sorted(np.concatenate(folds).tolist()) == list(range(7))
    for f in folds:
        gs = {groups[i] for i in f}
        for g in gs:
            assert all(i in f for i, x in enumerate(groups) if x == g)
    with pytest.raises(InputError, match="at least 2 postures"):
        make_folds(("a", "a"), 3)


def _select(toy: SimpleNamespace, effects: tuple, seed: int = 0):  # type: ignore[no-untyped-def]
    obs = toy.obs(effects, seed=seed)
    fits = [fit_candidate(c, toy.model, obs) for c in toy.candidates()]
    return select(fits, toy.model, obs, obs, SelectionSettings(n_folds=4))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("effects", "name"),
    [((("mass", 25.0),), "added_mass"), ((("delay", 0.002),), "sensor_delay")],
)
def test_names_the_concealed_effect(toy: SimpleNamespace, effects: tuple, name: str) -> None:
    sel = _select(toy, effects)
    assert sel.name == name
    assert sel.verdict.passed
    assert sel.verdict.gain is not None
    assert sel.verdict.gain > 1.0
    assert sel.verdict.explained > 0.9
    assert sel.ranking[0] is sel.verdict
    assert [r.rank for r in sel.ranking] == list(range(1, len(sel.ranking) + 1))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_answers_none_on_null_data(toy: SimpleNamespace, seed: int) -> None:
    sel = _select(toy, (), seed=seed)
    assert sel.name == "none"
    assert sel.verdict is sel.baseline
    # every candidate fails at least one condition
    assert all(r.reasons for r in sel.ranking if r.fit.candidate.name != "none")


def test_held_out_predictions_cover_every_record(toy: SimpleNamespace) -> None:
    sel = _select(toy, (("mass", 25.0),))
    cv = sel.verdict.cv
    assert cv is not None
    assert np.isfinite(cv.H[:, :, 0, 0]).all()
    assert cv.fold_params.shape == (4, 1)
    assert np.allclose(cv.fold_params[:, 0], 25.0, rtol=0.05)


def _mass_kx(p: np.ndarray) -> tuple:  # type: ignore[type-arg]
    return (("mass", float(p[0])), ("kx", float(p[1])))


@pytest.mark.slow
def test_simplest_of_equally_good_candidates_is_named(toy: SimpleNamespace) -> None:
    from robolobe.diagnose.candidate import Candidate, ParamSpec

    # a two-parameter candidate that contains the one-parameter truth
    both = Candidate(
        name="mass_and_stiffness",
        params=(
            ParamSpec("mass_kg", 0.1, 200.0, (5.0, 50.0), "log"),
            ParamSpec("factor", 0.3, 3.0, (0.8, 1.2), "log"),
        ),
        build=_mass_kx,
    )
    obs = toy.obs((("mass", 25.0),), seed=4)
    fits = [fit_candidate(c, toy.model, obs) for c in [*toy.candidates(), both]]
    sel = select(fits, toy.model, obs, obs, SelectionSettings(n_folds=4))
    assert sel.name == "added_mass"
    assert sel.ranking[0] is sel.verdict
    assert sel.runner_up is not None
    assert sel.runner_up.fit.candidate.name == "mass_and_stiffness"
