"""The compiled ZOA kernel against the numpy reference path (same envelopes to 1e-12)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robolobe import _jit
from robolobe.sld import (
    CuttingConditions,
    ModalModel,
    directional_factors,
    feed_frame,
    get_material,
    tool_point_model,
    zoa_lobes,
)

pytestmark = pytest.mark.skipif(not _jit.available(), reason="numba not installed")

MAT = get_material("Al7075-T6")


def _models(n: int, seed: int) -> ModalModel:
    """Robot modes (5-40 Hz, random 3-D shapes, random feed frames) plus tool modes."""
    rng = np.random.default_rng(seed)
    w = 2 * math.pi * rng.uniform(5.0, 40.0, (n, 6))
    z = rng.uniform(0.01, 0.05, (n, 6))
    k = rng.uniform(0.3e5, 27e5, (n, 6, 1))
    shapes = rng.normal(size=(n, 6, 3))
    shapes *= w[..., None] / np.sqrt(k) / np.linalg.norm(shapes, axis=-1, keepdims=True)
    robot = ModalModel.from_shapes(w, z, shapes)
    tool = ModalModel.from_directional(
        [700.0, 2200.0, 750.0, 2300.0], [0.03, 0.02, 0.03, 0.02],
        [3e7, 5e7, 3.2e7, 5e7], ["xx", "xx", "yy", "yy"],
    )  # fmt: skip
    ang = rng.uniform(0.0, 2 * math.pi, n)
    frame = feed_frame(np.stack([np.cos(ang), np.sin(ang), np.zeros(n)], axis=-1))
    return tool_point_model(frame, robot, tool)


def _compare(a: np.ndarray, b: np.ndarray, rtol: float) -> None:
    assert a.shape == b.shape
    fa, fb = np.isfinite(a), np.isfinite(b)
    np.testing.assert_array_equal(fa, fb)
    assert np.all(a[~fa] == b[~fb])
    np.testing.assert_allclose(a[fa], b[fb], rtol=rtol, atol=0.0)


def _both(omega, frf, alpha, rpm, max_lobe, teeth=3):  # type: ignore[no-untyped-def]
    kw = dict(alpha=alpha, teeth=teeth, kt=MAT.kt, rpm=rpm, max_lobe=max_lobe)
    return zoa_lobes(omega, frf, jit=False, **kw), zoa_lobes(omega, frf, jit=True, **kw)


@pytest.mark.parametrize("immersion", [1.0, 0.5, 0.1])
def test_kernel_equals_numpy_path(immersion: float) -> None:
    m = _models(40, seed=int(immersion * 10))
    cond = CuttingConditions.from_immersion(immersion, "down")
    alpha = directional_factors(cond.phi_entry, cond.phi_exit, MAT.kr)
    omega = m.frequency_grid(shared=False)
    ref, got = _both(omega, m.frf(omega), alpha, np.linspace(2000.0, 24000.0, 700), 30)
    _compare(got.a_lim, ref.a_lim, 1e-12)
    _compare(got.complete_above_rpm, ref.complete_above_rpm, 1e-12)
    # depth and phase too (the kernel rounds the complex products as numpy does,
    # so even the depths near a branch edge, where Re mu cancels, agree)
    _compare(got.depth, ref.depth, 1e-12)
    fin = np.isfinite(ref.depth)
    np.testing.assert_allclose(got.eps[fin], ref.eps[fin], rtol=0, atol=1e-12)


def test_kernel_unsorted_nonuniform_speeds_and_auto_lobes() -> None:
    m = _models(12, seed=7)
    alpha = directional_factors(0.0, math.pi / 2, MAT.kr)
    omega = m.frequency_grid(shared=False)
    rng = np.random.default_rng(3)
    rpm = rng.permutation(np.geomspace(800.0, 30000.0, 333))
    ref, got = _both(omega, m.frf(omega), alpha, rpm, None)
    assert got.max_lobe == ref.max_lobe > 30  # low speeds need more lobes
    _compare(got.a_lim, ref.a_lim, 1e-12)
    _compare(got.complete_above_rpm, ref.complete_above_rpm, 1e-12)


def test_kernel_shared_grid_batch_shapes_and_alpha_batch() -> None:
    m = ModalModel.isotropic([600.0, 900.0], [0.02, 0.03], [2e7, 3e7])
    omega = m.frequency_grid()
    frf = m.frf(omega)  # (n_freq, 2, 2), no batch
    alphas = np.stack(
        [directional_factors(0.0, p, MAT.kr) for p in np.linspace(0.3, math.pi, 6)]
    ).reshape(2, 3, 2, 2)
    ref, got = _both(omega, frf, alphas, np.linspace(3000.0, 20000.0, 50), 10, teeth=2)
    assert got.a_lim.shape == (2, 3, 50)
    _compare(got.a_lim, ref.a_lim, 1e-12)


def test_no_jit_env_takes_numpy_path() -> None:
    code = "from robolobe import _jit; import sys; sys.exit(0 if not _jit.available() else 1)"
    env = dict(os.environ, ROBOLOBE_NO_JIT="1")
    assert subprocess.run([sys.executable, "-c", code], env=env).returncode == 0


def test_no_cache_location_falls_back_to_uncached(monkeypatch: pytest.MonkeyPatch) -> None:
    import numba

    real = numba.njit

    def fake(*args, **kw):  # type: ignore[no-untyped-def]
        if kw.get("cache"):
            raise RuntimeError("cannot cache function 'f': no locator available for file")
        return real(*args, **kw)

    monkeypatch.setattr(numba, "njit", fake)
    monkeypatch.setattr(_jit, "_STATE", {"ok": True})

    def f(x: float) -> float:
        return 2.0 * x

    g = _jit.njit()(f)
    assert g(2.0) == 4.0
    assert not _jit.cache_enabled()


@pytest.mark.slow
def test_read_only_cache_dir_still_computes(tmp_path: Path) -> None:
    """A copy of the kernels in a read-only folder with no writable user cache dir."""
    src = Path(_jit.__file__).parent
    pkg = tmp_path / "ro" / "robolobe"
    import shutil

    shutil.copytree(src, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    for p in sorted(pkg.rglob("*"), reverse=True):
        p.chmod(0o555 if p.is_dir() else 0o444)
    pkg.chmod(0o555)
    (tmp_path / "ro").chmod(0o555)
    code = (
        "import numpy as np; from robolobe import _jit; from robolobe.sld import ModalModel, "
        "zoa_lobes, directional_factors\n"
        "m = ModalModel.isotropic([900.0], [0.02], [2e7]); w = m.frequency_grid()\n"
        "a = directional_factors(0.0, 3.14159, 0.3)\n"
        "r = zoa_lobes(w, m.frf(w), alpha=a, teeth=2, kt=7e8, rpm=[5000.0, 9000.0], jit=True)\n"
        "assert np.all(np.isfinite(r.a_lim)); print('cache', _jit.cache_enabled())"
    )
    home = tmp_path / "home"
    home.mkdir()
    home.chmod(0o555)
    env = dict(
        os.environ,
        PYTHONPATH=str(tmp_path / "ro"),
        HOME=str(home),
        XDG_CACHE_HOME=str(home / "cache"),
    )
    env.pop("NUMBA_CACHE_DIR", None)
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300
    )
    try:
        assert out.returncode == 0, out.stderr[-2000:]
        if os.geteuid() != 0:  # root writes through read-only modes
            assert "cache False" in out.stdout
    finally:
        for p in [tmp_path / "ro", *(tmp_path / "ro").rglob("*"), home]:
            p.chmod(0o755)


def test_envelope_rows_equals_lobe_envelope_per_row() -> None:
    """Exact queries (one speed row per entry, any order, off-grid) as the numpy reference."""
    from robolobe.sld import _kernels
    from robolobe.sld.lobes import lobe_envelope

    m = _models(30, seed=11)
    alpha = directional_factors(0.0, math.pi / 2, MAT.kr)
    omega = m.frequency_grid(shared=False)
    d = zoa_lobes(omega, m.frf(omega), alpha=alpha, teeth=3, kt=MAT.kt, rpm=[5e3, 2e4], jit=True)
    rng = np.random.default_rng(3)
    groups = rng.integers(0, 30, 50)
    rows = rng.uniform(4000.0, 24000.0, (50, 7))
    rows[:, 0] = 24000.0  # the grid's end, and a repeated speed
    rows[:, 1] = 24000.0
    got = _kernels.envelope_rows(
        d.omega, d.depth, d.eps, groups, teeth=3, rpm=rows, max_lobe=d.max_lobe
    )
    # the reference one entry at a time (its one-row path searches each row exactly)
    ref = np.stack(
        [
            lobe_envelope(d.omega[g], d.depth[g], d.eps[g], teeth=3, rpm=r, max_lobe=d.max_lobe)
            for g, r in zip(groups, rows, strict=True)
        ]
    )
    _compare(got, ref, 1e-12)
    assert np.all(got[:, 0] == got[:, 1])


def test_envelope_rows_of_one_entry_asked_together_equal_each_row_alone() -> None:
    """Rows of one entry are answered together (its lobes visited once for all their
    speeds): each row's values are bit for bit those of the row asked alone, and the
    numpy reference's to rounding, whatever the other rows ask (many rows per entry,
    speeds spread over the range so that the rows' envelopes lie far apart)."""
    from robolobe.sld import _kernels
    from robolobe.sld.lobes import lobe_envelope

    m = _models(6, seed=5)
    alpha = directional_factors(0.0, math.pi, MAT.kr)
    omega = m.frequency_grid(shared=False)
    d = zoa_lobes(omega, m.frf(omega), alpha=alpha, teeth=2, kt=MAT.kt, rpm=[4e3, 3e4], jit=True)
    rng = np.random.default_rng(8)
    groups = rng.integers(0, 6, 400)
    rows = rng.uniform(4000.0, 30000.0, (400, 5))
    rows[::7] = rng.uniform(29000.0, 30000.0, (rows[::7].shape[0], 5))  # a narrow window
    kw = dict(teeth=2, max_lobe=d.max_lobe)
    got = _kernels.envelope_rows(d.omega, d.depth, d.eps, groups, rpm=rows, **kw)
    alone = np.concatenate(
        [
            _kernels.envelope_rows(
                d.omega, d.depth, d.eps, groups[i : i + 1], rpm=rows[i : i + 1], **kw
            )
            for i in range(groups.size)
        ]
    )
    np.testing.assert_array_equal(got, alone)
    ref = np.stack(
        [
            lobe_envelope(d.omega[g], d.depth[g], d.eps[g], teeth=2, rpm=r, max_lobe=d.max_lobe)
            for g, r in zip(groups, rows, strict=True)
        ]
    )
    _compare(got, ref, 1e-12)
    assert np.isfinite(got).mean() > 0.9  # the rows cross lobes: the comparison bites


@pytest.mark.parametrize(("jit", "shuffled"), [(True, False), (True, True), (False, False)])
def test_frf_synthesis_in_chunks_equals_the_whole_array(monkeypatch, jit, shuffled) -> None:
    from robolobe.sld import zoa

    monkeypatch.setattr(zoa, "FRF_CHUNK", 7)
    m = _models(40, seed=5)
    alpha = directional_factors(0.0, math.pi / 2, MAT.kr)
    omega = m.frequency_grid(shared=False)
    calls = []

    def synth(a: int, b: int) -> np.ndarray:
        calls.append(b - a)
        return m.take(slice(a, b)).frf(omega[a:b])

    rpm = np.linspace(2e3, 24e3, 300)
    if shuffled:
        rpm = np.random.default_rng(1).permutation(rpm)
    kw = dict(alpha=alpha, teeth=3, kt=MAT.kt, rpm=rpm, max_lobe=None)
    ref = zoa_lobes(omega, m.frf(omega), jit=jit, **kw)
    got = zoa_lobes(omega, synth, jit=jit, **kw)
    assert max(calls) == (7 if jit else 40)
    assert sum(calls) == 40
    assert got.max_lobe == ref.max_lobe
    for name in ("a_lim", "depth", "eps", "complete_above_rpm"):
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name))


def test_eigenvalues_of_many_samples_equal_those_of_one_sample_each():
    """The refinement's vectorised eigenvalues (the initial samples and their middles) are
    those of the per-sample form bit for bit, so the refined samples do not depend on
    which form evaluated them; random models with light, heavy and overdamped modes."""
    from robolobe import _jit

    if not _jit.available():
        pytest.skip("numba not installed")
    from robolobe.sld import _kernels as kern

    rng = np.random.default_rng(17)
    for m in (1, 4, 10):
        om = 2 * np.pi * rng.uniform(3.0, 3000.0, m)
        ze = rng.choice([0.005, 0.05, 0.3, 1.5], m)
        th = rng.uniform(0, np.pi, m)
        u = np.stack([np.cos(th), np.sin(th)], axis=-1)
        res = (om**2 / 10 ** rng.uniform(5, 8, m))[:, None, None] * u[:, :, None] * u[:, None, :]
        res[:, 0, 1] *= rng.uniform(0.5, 1.5, m)  # cross terms that are not symmetric
        al = rng.normal(size=(2, 2))
        w = np.sort(rng.uniform(0.2, 2.0, 301) * om.mean())
        w[5] = om[0]  # on a resonance
        m1 = np.empty(w.size, np.complex128)
        m2 = np.empty(w.size, np.complex128)
        kern._eig_many(w, om, ze, res, al, m1, m2)
        for i in range(w.size):
            p1, p2 = kern._eig_pt(w[i], om, ze, res, al)
            assert (m1[i], m2[i]) == (p1, p2)
