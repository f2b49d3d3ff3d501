"""The default transfer's speed-ups give the model the plain computation gives (issue 27).

Three shortcuts make the corrected-twin transfer faster; each is switched off
here in turn (the plain computation: every assignment solved, the twin's
matrices and modes computed afresh at every call, one kernel matrix per
output) and the fitted models must be the same numbers:

- :func:`robolobe._matching.match_modes` solves the problems whose rows'
  least costs are strict and in distinct columns at once;
- :class:`robolobe.twin.params.ParametrizedTwin` reuses the last theta's
  matrices, undamped modes and values;
- the pooled kernel likelihood of :class:`robolobe.tl.residual.CorrectedTwin`
  builds one kernel matrix per group of outputs at the same postures.

The campaign is a concealed robot B outside the twin's form (the out-of-form
study's draw 8, its slowest transfer: a servo mode, a spindle bracket,
load-dependent joints), 8 postures; both the matching's shortcut and its
full assignment take part.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import robolobe._matching
import robolobe.tl.residual
from robolobe.twin.params import ParametrizedTwin, parameter_names

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))


def _campaign() -> Any:
    from out_of_form import draw_truth

    from robolobe.modal.identify import identify_campaign
    from robolobe.robots import load_robot
    from robolobe.tl.design import design_postures
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.designs import TESTED_RANGES_DEG

    base = load_robot("B")
    truth = draw_truth(base, "B", 8)
    q = design_postures(
        base, 8, rng=np.random.default_rng(508), ranges_deg=TESTED_RANGES_DEG["B"]
    ).q_rad
    ids = [f"T{i + 1:02d}" for i in range(len(q))]
    camp = simulate_campaign(
        truth.receptance, "B", ids, q, rng=np.random.default_rng(7008), fmax_hz=150.0
    )
    return identify_campaign(camp).table


def _fit(modal: Any) -> dict[str, np.ndarray]:
    from robolobe.robots import load_robot
    from robolobe.tl.transfer import transfer

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = transfer(modal, robot="B")
    base = load_robot("B")
    u = np.random.default_rng(5).random((50, 6))
    q = np.vstack([model.train_q_rad_, base.q_min + (base.q_max - base.q_min) * u])
    pred = model.predict(q, warn=False)
    return {
        "theta": model.calibration_.theta_,
        "center": pred.center,
        "std": pred.std,
        "alpha": model.alpha_,
        "length_scales": model.length_scales_,
        "rho": model.rho_,
        "held_out": model.train_r_,
        "cover": model.spread_cover_,
    }


def _plain(monkeypatch: pytest.MonkeyPatch) -> None:
    """Switch the three shortcuts off."""

    def no_easy(flat: np.ndarray, gate: float) -> tuple[np.ndarray, ...]:
        n_p, n_a = flat.shape[:2]
        return np.zeros(n_p, bool), np.zeros((n_p, n_a), np.intp), np.zeros((n_p, n_a), bool)

    monkeypatch.setattr(robolobe._matching, "_row_minima", no_easy)
    state, values = ParametrizedTwin._state, ParametrizedTwin.values

    def fresh_state(self: ParametrizedTwin, theta: Any) -> Any:
        self._last_state = None
        return state(self, theta)

    def fresh_values(self: ParametrizedTwin, theta: Any) -> Any:
        self._last_values = None
        return values(self, theta)

    monkeypatch.setattr(ParametrizedTwin, "_state", fresh_state)
    monkeypatch.setattr(ParametrizedTwin, "values", fresh_values)

    def one_per_output(xs: list[np.ndarray], ts: list[np.ndarray]) -> list[Any]:
        return [
            (x, np.asarray([t], float), [o]) for o, (x, t) in enumerate(zip(xs, ts, strict=True))
        ]

    monkeypatch.setattr(robolobe.tl.residual, "_share_postures", one_per_output)


@pytest.mark.slow
def test_fast_transfer_equals_the_plain_computation(monkeypatch: pytest.MonkeyPatch) -> None:
    modal = _campaign()
    row_minima = robolobe._matching._row_minima
    seen = np.zeros(2, int)  # problems solved by the shortcut, by the assignment

    def counted(flat: np.ndarray, gate: float) -> tuple[np.ndarray, ...]:
        out = row_minima(flat, gate)
        seen[:] += [int(out[0].sum()), int((~out[0]).sum())]
        return out

    with monkeypatch.context() as m:
        m.setattr(robolobe._matching, "_row_minima", counted)
        fast = _fit(modal)
    assert np.all(seen > 0), seen
    with monkeypatch.context() as m:
        _plain(m)
        plain = _fit(modal)
    for key, value in plain.items():
        np.testing.assert_array_equal(fast[key], value, err_msg=key)


def test_grouped_likelihood_equals_one_kernel_per_output() -> None:
    from robolobe.tl.residual import _grouped_nll, _kernel, _pooled_nll, _share_postures

    rng = np.random.default_rng(2)
    x = rng.uniform(-1.0, 1.0, (12, 6))
    masks = [np.ones(12, bool)] * 3 + [rng.random(12) < 0.8 for _ in range(3)]
    masks.insert(2, masks[3].copy())  # the same postures apart in the list
    xs = [x[m] for m in masks]
    ts = [rng.normal(0.0, 1.0, int(m.sum())) for m in masks]
    groups = _share_postures(xs, ts)
    assert [g[2] for g in groups] == [[0, 1, 3], [2, 4], [5], [6]]
    hyp = np.r_[np.log(rng.uniform(0.3, 2.0, 6)), 0.4]
    # the negative log marginal likelihood, one output at a time (written for the test)
    ell, rho = np.exp(hyp[:6]), 1.0 / (1.0 + np.exp(-hyp[6]))
    want = 0.0
    for xo, to in zip(xs, ts, strict=True):
        k = rho * _kernel(xo, xo, ell) + (1.0 - rho) * np.eye(len(xo))
        c = np.linalg.cholesky(k)
        a = np.linalg.solve(c, to)
        want += 0.5 * float(a @ a) + float(np.log(np.diag(c)).sum())
    assert _grouped_nll(hyp, groups, 6) == want
    assert _pooled_nll(hyp, xs, ts, 6) == want
    # against the textbook form: 0.5 t^T K^-1 t + 0.5 log det K per output
    ref = sum(
        0.5 * to @ np.linalg.solve(kk, to) + 0.5 * np.linalg.slogdet(kk)[1]
        for xo, to in zip(xs, ts, strict=True)
        for kk in [rho * _kernel(xo, xo, ell) + (1.0 - rho) * np.eye(len(xo))]
    )
    assert want == pytest.approx(ref, rel=1e-10)


def test_twin_reuse_gives_what_a_fresh_twin_gives() -> None:
    from robolobe.robots import load_robot
    from robolobe.tl.graybox import DEFAULT_PARAMS

    base = load_robot("B")
    q = base.q_min + (base.q_max - base.q_min) * np.random.default_rng(3).random((5, 6))
    rng = np.random.default_rng(4)
    thetas = [np.abs(rng.normal(0.0, 0.1, len(parameter_names(DEFAULT_PARAMS)))) for _ in range(3)]
    twin = ParametrizedTwin(base, q, DEFAULT_PARAMS, directions=("xx", "yy"), n_modes=6)
    for th in (thetas[0], thetas[1], thetas[1], thetas[0], thetas[2], thetas[2]):
        v = twin.values(th)
        v[...] = -1.0  # the caller's copy: the kept values stay as they were
        fresh = ParametrizedTwin(base, q, DEFAULT_PARAMS, directions=("xx", "yy"), n_modes=6)
        np.testing.assert_array_equal(twin.values(th), fresh.values(th))
        np.testing.assert_array_equal(twin.log_jacobian(th), fresh.log_jacobian(th))
    th = thetas[2].copy()
    twin.values(th)
    th[0] += 1e-3  # the same array changed in place: a new theta
    fresh = ParametrizedTwin(base, q, DEFAULT_PARAMS, directions=("xx", "yy"), n_modes=6)
    np.testing.assert_array_equal(twin.values(th), fresh.values(th))
    twin.n_modes = 4  # the calibration sets the number of modes after making the twin
    assert twin.values(th).shape == (5, 2, 4, 3)
