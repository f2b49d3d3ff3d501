"""Fitting one candidate: recovery, uncertainty, identifiability (toy structure)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robolobe.diagnose.candidate import Candidate, ParamSpec, Requirement
from robolobe.diagnose.fitting import fit_candidate
from robolobe.diagnose.residuals import deviance, residual_vector


@pytest.mark.slow
def test_recovers_added_mass_with_honest_uncertainty(toy: SimpleNamespace) -> None:
    obs = toy.obs((("mass", 40.0),), sigma=0.02)
    fit = fit_candidate(toy.candidates()[1], toy.model, obs)
    assert fit.identifiable
    assert fit.params[0] == pytest.approx(40.0, rel=0.01)
    # the error is within 4 standard deviations, and the deviation is not absurdly small
    assert abs(fit.params[0] - 40.0) < 4 * fit.std[0]
    assert fit.std[0] < 0.5
    # at the truth the fit reaches the noise: D/N about 1
    assert 0.7 < fit.deviance / fit.n_resid < 1.3


def test_wrong_candidate_leaves_misfit(toy: SimpleNamespace) -> None:
    obs = toy.obs((("mass", 40.0),), sigma=0.02)
    right = fit_candidate(toy.candidates()[1], toy.model, obs)
    wrong = fit_candidate(toy.candidates()[2], toy.model, obs)
    assert wrong.deviance > 5 * right.deviance
    assert wrong.bic > right.bic


def test_a_fit_next_to_the_null_value_does_not_stop_on_it(toy: SimpleNamespace) -> None:
    # the 150 kg mass shifts the peaks; a delay absorbs part of that phase error, so the
    # delay-only fit has its optimum off the null (0 s). From the +-4 ms grid starts the
    # trust region's first step lands on the null to rounding (1e-18 s): a step relative
    # to |z| was 1e-22 s there, a Jacobian of rounding noise, and the fit stopped at the
    # null with `gtol`. Reference: the deviance on a dense scan of the delay.
    obs = toy.obs((("mass", 150.0), ("delay", 0.0001)), seed=0)
    cand = toy.candidates()[3]
    fit = fit_candidate(cand, toy.model, obs)
    taus = np.linspace(0.0, 0.001, 201)
    scan = [deviance(residual_vector(toy.model((("delay", t),), obs), obs)) for t in taus]
    best = int(np.argmin(scan))
    assert 0 < best < taus.size - 1  # the scan brackets an optimum off the null
    assert abs(fit.params[0] - taus[best]) < 2 * (taus[1] - taus[0])
    assert fit.deviance <= min(scan) * (1 + 1e-6)


def test_none_candidate_is_evaluated_once(toy: SimpleNamespace) -> None:
    obs = toy.obs(())
    fit = fit_candidate(toy.candidates()[0], toy.model, obs)
    assert fit.nfev == 1
    assert fit.k == 0
    assert fit.bic == pytest.approx(fit.deviance)


def test_product_of_parameters_is_not_identifiable(toy: SimpleNamespace) -> None:
    obs = toy.obs((("ab", 1.3, 1.0),))
    fit = fit_candidate(toy.ab(), toy.model, obs)
    assert not fit.identifiable
    assert any("correlated" in n or "separable" in n for n in fit.notes)
    assert fit.params[0] * fit.params[1] == pytest.approx(1.3, rel=0.01)


def test_parameter_without_effect_is_flagged(toy: SimpleNamespace) -> None:
    dead = Candidate(
        name="dead",
        params=(ParamSpec("x", 0.0, 1.0, (0.5,)),),
        build=lambda p: (),
    )
    fit = fit_candidate(dead, toy.model, toy.obs(()))
    assert not fit.identifiable
    assert "do not depend" in fit.notes[0]


def test_bound_is_reported(toy: SimpleNamespace) -> None:
    obs = toy.obs((("mass", 300.0),))  # beyond the 200 kg bound
    fit = fit_candidate(toy.candidates()[1], toy.model, obs)
    assert fit.at_bound == (True,)
    assert fit.params[0] == pytest.approx(200.0, rel=1e-3)


def test_param_spec_validation() -> None:
    with pytest.raises(ValueError, match="lower < upper"):
        ParamSpec("x", 1.0, 1.0, (1.0,))
    with pytest.raises(ValueError, match="log scale"):
        ParamSpec("x", 0.0, 1.0, (0.5,), "log")
    with pytest.raises(ValueError, match="outside"):
        ParamSpec("x", 0.0, 1.0, (2.0,))
    s = ParamSpec("k", 1e3, 1e9, (1e6,), "log")
    assert s.to_physical(s.to_internal(1e6)) == pytest.approx(1e6)


def test_start_grid_is_thinned() -> None:
    c = Candidate(
        name="c",
        params=tuple(ParamSpec(n, 0.0, 1.0, tuple(np.linspace(0, 1, 10))) for n in "abc"),
        build=lambda p: (),
    )
    g = c.start_grid(64)
    assert g.shape == (64, 3)  # 1000 grid points thinned evenly to 64
    assert np.array_equal(g[0], [0.0, 0.0, 0.0])
    assert np.array_equal(g[-1], [1.0, 1.0, 1.0])
    assert len(np.unique(g, axis=0)) == 64
    # every parameter keeps values across its range
    assert all(len(np.unique(g[:, j])) >= 5 for j in range(3))
    assert c.start_grid(2000).shape == (1000, 3)  # no thinning needed


def test_requirement_messages() -> None:
    r = Requirement(min_directions=2, why="rotation")
    assert r.unmet(["xx"], 0) is not None
    assert "2 measured directions" in (r.unmet(["xx"], 0) or "")
    assert r.unmet(["xx", "yy"], 0) is None
    f = Requirement(min_force_levels=2)
    assert "force levels" in (f.unmet(["xx"], 1) or "")
    d = Requirement(any_of_directions=("xx", "xy"))
    assert d.unmet(["yy"], 0) is not None
    assert d.unmet(["xy"], 0) is None
