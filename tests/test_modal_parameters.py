"""The one modal-parameter type: its rules, and round trips through producers and consumers."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from robolobe._directions import DRIVING
from robolobe._modal_parameters import ModalParameters
from robolobe.errors import InputError
from robolobe.modal.modal_csv import read_modal_parameters, write_modal_csv
from robolobe.plan.modes import ParametersSource, TwinSource, as_mode_source
from robolobe.robots import load_robot
from robolobe.sld.frf import ModalModel
from robolobe.tl.dataset import ModalDataset, dataset_from_frame
from robolobe.tl.estimator import ModalPrediction
from robolobe.twin.frf import modal_receptance
from robolobe.twin.model import Twin

EXAMPLES = resources.files("robolobe.data").joinpath("examples")


def _postures(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = np.zeros((n, 6))
    q[:, 0] = rng.uniform(-0.5, 0.5, n)
    q[:, 1] = rng.uniform(-0.9, -0.3, n)
    q[:, 2] = rng.uniform(0.4, 1.2, n)
    q[:, 3] = rng.uniform(-0.5, 0.5, n)
    q[:, 4] = rng.uniform(0.4, 1.2, n)
    return q


def _small() -> ModalParameters:
    f = np.array([[[10.0, 20.0], [11.0, np.nan]]])
    z = np.array([[[0.03, 0.05], [0.04, np.nan]]])
    k = np.array([[[2e6, np.inf], [3e6, np.nan]]])
    return ModalParameters(f, z, k, ("xx", "yy"), posture_ids=("P1",), q_rad=np.zeros((1, 6)))


# ------------------------------------------------------------------ rules
@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            {"f_hz": np.ones((2, 2))},
            "expected shape (n_postures, n_directions, n_modes), found (2, 2)",
        ),
        ({"zeta": np.full((1, 2, 3), 0.03)}, "zeta: expected the shape of f_hz (1, 2, 2)"),
        ({"directions": ("xx", "xx")}, "expected 2 distinct directions"),
        ({"directions": ("xx",)}, "expected 2 distinct directions"),
        ({"directions": ("xx", "yw")}, "direction: expected two letters of x, y, z"),
        ({"directions": "xxyy"}, "found the string 'xxyy'"),
        (
            {"f_hz": np.array([[[10.0, -1.0], [11.0, np.nan]]])},
            "f_hz: expected a frequency > 0 Hz or NaN, found -1.0 at posture 0, "
            "direction 'xx', mode 2",
        ),
        ({"f_hz": np.array([[[10.0, np.inf], [11.0, np.nan]]])}, "f_hz: expected a frequency > 0"),
        (
            {"zeta": np.array([[[0.0, 0.05], [0.04, np.nan]]])},
            "zeta: expected a damping ratio > 0 or NaN, found 0.0",
        ),
        (
            {"k_N_per_m": np.array([[[2e6, 0.0], [3e6, np.nan]]])},
            "k_N_per_m: expected a non-zero stiffness",
        ),
        ({"log_std": np.zeros((1, 2, 2))}, "log_std: expected shape (1, 2, 2, 3)"),
        ({"log_std": -np.ones((1, 2, 2, 3))}, "log_std: expected standard deviations >= 0"),
        ({"posture_ids": ("a", "b")}, "posture_ids: expected 1 ids"),
        ({"q_rad": np.zeros((1, 5))}, "q_rad: expected shape (1, 6), found (1, 5)"),
    ],
)
def test_the_type_refuses_what_breaks_its_rules(change: dict, message: str) -> None:
    base = _small()
    args = {
        "f_hz": base.f_hz,
        "zeta": base.zeta,
        "k_N_per_m": base.k_N_per_m,
        "directions": base.directions,
        "posture_ids": base.posture_ids,
        "q_rad": base.q_rad,
        **change,
    }
    with pytest.raises(InputError) as exc:
        ModalParameters(**args)
    assert message in str(exc.value)


def test_the_type_is_read_only_and_copies_its_input() -> None:
    f = np.full((1, 1, 2), 10.0)
    p = ModalParameters(f, np.full_like(f, 0.02), np.full_like(f, 1e6), ["zz"])
    f[0, 0, 0] = 99.0
    assert p.f_hz[0, 0, 0] == 10.0
    assert p.directions == ("zz",)
    with pytest.raises(ValueError, match="read-only"):
        p.zeta[0, 0, 0] = 0.5


def test_select_puts_the_directions_in_order_and_leaves_others_absent() -> None:
    p = _small()
    s = p.select(("zz", "yy", "xx"))
    assert s.directions == ("zz", "yy", "xx")
    assert np.all(np.isnan(s.stacked()[:, 0]))
    np.testing.assert_array_equal(s.stacked()[:, 1], p.stacked()[:, 1])
    np.testing.assert_array_equal(s.stacked()[:, 2], p.stacked()[:, 0])


# ------------------------------------------------------------------ twin -> lobes
def test_twin_parameters_through_modal_model_give_the_modal_stiffness_frf() -> None:
    """twin -> ModalParameters -> ModalModel -> FRF is the twin's modal-stiffness receptance.

    The receptance of :func:`robolobe.twin.frf.modal_receptance` (another
    kernel) per driving point, from the twin's own f, zeta and k, at every
    posture; cross terms are absent (per-direction modes). The modal form is
    also close to the twin's exact receptance (light damping) at the peaks.
    """
    twin = Twin(load_robot("B"))
    q = _postures(5, seed=1)
    modes = twin.modes(q)
    p = modes.parameters()
    assert p.shape == (5, 3, modes.n_modes)
    assert p.directions == DRIVING
    model = ModalModel.from_parameters(p)
    freq = np.linspace(2.0, 60.0, 400)
    h = model.frf(2 * np.pi * freq)  # (5, n_freq, 3, 3)
    for d in range(3):
        ref = modal_receptance(modes.f_hz, modes.zeta, modes.k_N_per_m[:, d, :], freq)
        np.testing.assert_allclose(h[..., d, d], ref, rtol=1e-10, atol=1e-18)
    off = h[..., 0, 1]
    assert np.all(off == 0)
    exact = twin.receptance(q, freq)
    for d in range(3):
        peak = np.max(np.abs(exact[..., d, d]), axis=-1)
        assert np.all(np.abs(np.max(np.abs(h[..., d, d]), axis=-1) / peak - 1) < 0.1)


def test_twin_parameters_of_one_posture_and_cross_directions() -> None:
    modes = Twin(load_robot("A")).modes(_postures(1)[0])
    p = modes.parameters(("zz", "xx"))
    assert p.shape == (1, 2, modes.n_modes)
    np.testing.assert_array_equal(p.k_N_per_m[0, 0], modes.k_N_per_m[2])
    np.testing.assert_array_equal(p.f_hz[0, 1], modes.f_hz)
    with pytest.raises(InputError, match="expected driving points"):
        modes.parameters(("xy",))


# ------------------------------------------------------------------ modal.csv
def test_modal_csv_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    n, m = 4, 3
    f = np.sort(rng.uniform(5, 40, (n, 2, m)), axis=-1)
    z = rng.uniform(0.01, 0.08, (n, 2, m))
    k = 10 ** rng.uniform(5.5, 8, (n, 2, m))
    f[1, 0, 2] = z[1, 0, 2] = k[1, 0, 2] = np.nan  # a mode posture P2 does not list
    q = _postures(n, seed=2)
    p = ModalParameters(f, z, k, ("yy", "xx"), posture_ids=[f"P{i + 1}" for i in range(n)], q_rad=q)
    path = write_modal_csv(tmp_path / "modal.csv", p.to_frame())
    back = read_modal_parameters(path, directions=("yy", "xx"))
    assert back.posture_ids == p.posture_ids
    assert back.directions == ("yy", "xx")
    np.testing.assert_allclose(back.q_rad, q, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(back.stacked(), p.stacked())  # NaN where absent, exact floats
    default = read_modal_parameters(path)
    assert default.directions == ("xx", "yy")  # the vocabulary's order
    np.testing.assert_array_equal(default.f_hz[:, 0], f[:, 1])
    # the dataset of the learning side is the same table
    ds = dataset_from_frame(p.to_frame(), directions=("yy", "xx"), n_modes=m)
    np.testing.assert_array_equal(ds.y, p.stacked())
    np.testing.assert_array_equal(ModalDataset.from_parameters(ds.parameters).y, ds.y)


def test_to_frame_needs_postures() -> None:
    p = ModalParameters(
        np.full((1, 1, 1), 9.0), np.full((1, 1, 1), 0.02), np.full((1, 1, 1), 1e6), ("xx",)
    )
    with pytest.raises(InputError, match="expected posture_ids and q_rad"):
        p.to_frame()


# ------------------------------------------------------------------ predictors
def test_prediction_parameters_are_physical_values_with_the_log_spread() -> None:
    rng = np.random.default_rng(3)
    vals = np.stack(
        [
            rng.uniform(5, 40, (6, 2, 4)),
            rng.uniform(0.01, 0.1, (6, 2, 4)),
            10 ** rng.uniform(5, 8, (6, 2, 4)),
        ],
        axis=-1,
    )
    std = rng.uniform(0.0, 0.2, vals.shape)
    pred = ModalPrediction(("xx", "yy"), np.log(vals), std, "log")
    p = pred.parameters()
    assert p.shape == (6, 2, 4)
    assert p.directions == ("xx", "yy")
    np.testing.assert_allclose(p.f_hz, vals[..., 0], rtol=1e-12)  # Hz, not log Hz
    np.testing.assert_allclose(p.zeta, vals[..., 1], rtol=1e-12)
    np.testing.assert_allclose(p.k_N_per_m, vals[..., 2], rtol=1e-12)  # N/m
    np.testing.assert_array_equal(p.log_std, std)
    bad = ModalPrediction(
        ("xx",), np.array([[[[-3.0, 0.05, 1e6]]]]), np.zeros((1, 1, 1, 3)), "minmax"
    )
    with pytest.raises(InputError, match="f_hz: expected a frequency > 0 Hz"):
        bad.parameters()


def test_shipped_predictor_parameters_shapes_and_units() -> None:
    from robolobe.tl.models import load_model

    model = load_model("B")
    q = _postures(3, seed=4)
    pred = model.predict(q, warn=False)
    p = pred.parameters()
    assert p.shape == (3, len(model.directions), model.n_modes)
    np.testing.assert_array_equal(p.stacked(), pred.values)
    assert np.all((p.f_hz > 1) & (p.f_hz < 200))  # Hz
    assert np.all((p.zeta > 0) & (p.zeta < 0.5))  # a fraction, not per cent
    assert np.all(p.k_N_per_m > 1e4)  # N/m, not N/mm or N/um
    modes = as_mode_source(model).predict(q)
    np.testing.assert_array_equal(modes.parameters.select(p.directions).f_hz, p.f_hz)


# ------------------------------------------------------------------ identification
def test_posture_modal_parameters_hold_the_identified_modes() -> None:
    from robolobe.modal.posture import identify_posture
    from tests.modal._systems import make_system

    sysm = make_system(0)
    f = np.arange(0.0, 50.0, 0.125)
    pm = identify_posture(f, sysm.H(f), posture_id="S0")
    p = pm.parameters()
    assert p.shape == (1, 3, pm.n_modes)
    assert p.posture_ids == ("S0",)
    np.testing.assert_array_equal(p.k_N_per_m[0], pm.k_N_per_m)
    np.testing.assert_array_equal(p.f_hz[0, 2], pm.f_hz)
    np.testing.assert_array_equal(p.log_std[0, ..., 2], pm.k_rel_std)
    vis = pm.parameters(visible_only=True)
    for d in range(3):
        shown = np.isfinite(vis.f_hz[0, d])
        np.testing.assert_array_equal(np.flatnonzero(shown), pm.modes_for_direction(d))
        # the truth, not the identification: a visible mode's frequency and stiffness
        for r in np.flatnonzero(shown):
            t = int(np.argmin(np.abs(sysm.f_hz - vis.f_hz[0, d, r])))
            assert vis.f_hz[0, d, r] == pytest.approx(sysm.f_hz[t], rel=1e-3)
            # (3 %: a weak mode at the band's edge, seen by the local visibility, 2.2 %)
            assert vis.k_N_per_m[0, d, r] == pytest.approx(sysm.k[d, t], rel=0.03)


# ------------------------------------------------------------------ planning
def test_parameters_as_a_mode_source() -> None:
    robot = load_robot("B")
    q = _postures(6, seed=6)
    twin_modes = TwinSource(robot).predict(q)
    given = twin_modes.parameters
    src = as_mode_source(
        ModalParameters(given.f_hz, given.zeta, given.k_N_per_m, given.directions, q_rad=q)
    )
    assert isinstance(src, ParametersSource)
    back = src.predict(q[::-1])
    np.testing.assert_array_equal(back.parameters.stacked(), given.stacked()[::-1])
    assert back.model.batch_shape == (6,)
    with pytest.raises(InputError, match="is not one of the 6 postures"):
        src.predict(q[:2] + 1e-6)
    one = ParametersSource(
        ModalParameters(given.f_hz[:1], given.zeta[:1], given.k_N_per_m[:1], ("xx", "yy", "zz"))
    ).predict(q)
    np.testing.assert_array_equal(one.f_hz, np.broadcast_to(given.f_hz[:1], (6, *given.shape[1:])))


def test_plan_path_takes_modal_parameters() -> None:
    import robolobe as rl

    job = rl.load_job(EXAMPLES.joinpath("job_B_contour.toml"))
    # the twin's modes at one posture of the path region, for every waypoint
    modes = Twin(load_robot("B")).modes(_postures(1, seed=7)[0]).parameters()
    res = rl.plan_path(EXAMPLES.joinpath("contour.apt"), job, modes=modes)
    s = res.summary.to_dict()
    assert s["n_cut"] == 72
    assert s["min_margin"] >= s["safety_factor"] * (1 - 1e-6)
    assert s["mode_source"] == "given modal parameters"
    f1 = res.table["f1_x_hz"].to_numpy()
    f1 = f1[np.isfinite(f1)]
    assert f1.size >= 72
    assert np.all(f1 == modes.f_hz[0, 0, 0])  # the same modes at every waypoint
