"""The numpy forward pass equals torch's on the same weights; loading needs no torch."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import torch

from robolobe.tl.forward import ArrayMLP
from robolobe.tl.models import SHIPPED, load_model
from robolobe.tl.network import EnsembleMLP


@pytest.mark.parametrize("sizes", [(6, 32, 32, 32, 32, 32, 15), (12, 16, 16, 4), (3, 5)])
def test_numpy_forward_equals_torch(sizes: tuple[int, ...]) -> None:
    net = EnsembleMLP(7, sizes, torch.Generator().manual_seed(len(sizes)))
    with torch.no_grad():  # non-zero biases too
        for b in net.bias_views(net.theta):
            b.copy_(torch.randn(b.shape, generator=torch.Generator().manual_seed(1)) * 0.3)
    plain = ArrayMLP.from_arrays(net.to_arrays())
    rng = np.random.default_rng(0)
    for x in (rng.uniform(-1, 1, (50, sizes[0])), rng.uniform(-1, 1, (7, 20, sizes[0]))):
        want = net.predict_numpy(x)
        got = plain.predict_numpy(x)
        assert got.shape == want.shape == (7, x.shape[-2], sizes[-1])
        scale = np.abs(want).max()
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-6 * scale)
    back = EnsembleMLP.from_arrays(plain.select([6, 0]).to_arrays())
    np.testing.assert_array_equal(back.to_arrays()["W0"], net.to_arrays()["W0"][[6, 0]])


@pytest.mark.parametrize("key", SHIPPED)
def test_shipped_model_numpy_equals_torch(key: str) -> None:
    model = load_model(key)
    assert isinstance(model.net_, ArrayMLP)
    net = EnsembleMLP.from_arrays(model.net_.to_arrays())
    x = np.random.default_rng(1).uniform(0, 1, (64, model.net_.sizes[0]))
    want = net.predict_numpy(x)
    np.testing.assert_allclose(
        model.net_.predict_numpy(x), want, rtol=0, atol=1e-6 * np.abs(want).max()
    )


def test_bad_layers_refused() -> None:
    arrays = ArrayMLP.from_arrays(EnsembleMLP(2, (6, 8, 3)).to_arrays()).to_arrays()
    with pytest.raises(ValueError, match="layer 1"):
        ArrayMLP.from_arrays({**arrays, "W1": np.zeros((2, 7, 3), np.float32)})
    with pytest.raises(ValueError, match="expected shape"):
        ArrayMLP.from_arrays(arrays).predict_numpy(np.zeros((4, 5)))


@pytest.mark.slow
def test_loading_and_predicting_do_not_import_torch() -> None:
    code = (
        "import sys, numpy as np\n"
        "from robolobe.tl.models import load_model\n"
        "m = load_model('A')\n"
        "m.predict(np.zeros((3, 6)))\n"
        "assert 'torch' not in sys.modules, 'torch imported'\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]
