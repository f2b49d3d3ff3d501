"""EnsembleMLP and the hand-written backpropagation (checked against autograd)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from robolobe.tl.network import EnsembleMLP
from robolobe.tl.training import masked_mse, masked_mse_grad, train_ensemble


def test_paper_shapes_and_independent_members():
    net = EnsembleMLP(4, (6, 32, 32, 32, 32, 32, 15), torch.Generator().manual_seed(0))
    x = torch.rand(4, 7, 6)
    out = net(x)
    assert out.shape == (4, 7, 15)
    # a member's output depends only on its own weights and inputs
    x2 = x.clone()
    x2[1] += 1.0
    out2 = net(x2)
    assert torch.equal(out[0], out2[0])
    assert torch.equal(out[2:], out2[2:])
    assert not torch.equal(out[1], out2[1])


@pytest.mark.slow
@pytest.mark.parametrize("n_frozen", [0, 2])
def test_manual_gradient_equals_autograd(n_frozen):
    g = torch.Generator().manual_seed(1)
    net = EnsembleMLP(3, (12, 16, 16, 16, 10), g)
    x = torch.rand(3, 9, 12, generator=g)
    y = torch.rand(3, 9, 10, generator=g)
    mask = (torch.rand(3, 9, 10, generator=g) > 0.3).float()
    masked_mse(net(x), y, mask).sum().backward()
    grad = torch.zeros_like(net.theta.detach())
    loss = masked_mse_grad(net, x, y, mask, grad, n_frozen)
    start = net.frozen_size(n_frozen)
    torch.testing.assert_close(grad[start:], net.theta.grad[start:], rtol=1e-5, atol=1e-7)
    assert torch.count_nonzero(grad[:start]) == 0
    torch.testing.assert_close(loss, masked_mse(net(x), y, mask).detach())


@pytest.mark.slow
def test_arrays_round_trip_and_select():
    net = EnsembleMLP(5, (6, 8, 3), torch.Generator().manual_seed(2))
    arrays = net.to_arrays()
    assert set(arrays) == {"W0", "b0", "W1", "b1"}
    assert arrays["W0"].shape == (5, 6, 8)
    assert arrays["b1"].shape == (5, 3)
    back = EnsembleMLP.from_arrays(arrays)
    assert torch.equal(back.theta, net.theta)
    sub = net.select([3, 1])
    x = torch.rand(4, 6)
    torch.testing.assert_close(sub(x), net(x)[[3, 1]])
    with pytest.raises(ValueError, match="layer 1"):
        EnsembleMLP.from_arrays({**arrays, "W1": np.zeros((5, 7, 3), np.float32)})


def test_training_fits_and_frozen_prefix_is_bitwise_unchanged():
    g = torch.Generator().manual_seed(3)
    net = EnsembleMLP(2, (2, 16, 16, 16, 1), g)
    x = torch.rand(2, 64, 2, generator=g)
    y = (torch.sin(3 * x[..., :1]) + x[..., 1:] ** 2).contiguous()
    mask = torch.ones_like(y)
    frozen = net.theta.detach()[: net.frozen_size(2)].clone()
    before = masked_mse(net(x), y, mask).detach()
    hist = train_ensemble(net, x, y, mask, n_frozen=2, epochs=60, generator=g)
    after = masked_mse(net(x), y, mask).detach()
    assert torch.all(after < 0.2 * before)
    assert hist.train_loss.shape == (60, 2)
    assert torch.equal(net.theta.detach()[: net.frozen_size(2)], frozen)


def test_rows_restrict_each_model_to_its_fold():
    g = torch.Generator().manual_seed(4)
    net = EnsembleMLP(2, (1, 8, 1), g)
    x = torch.linspace(0, 1, 20).reshape(1, 20, 1).repeat(2, 1, 1)
    y = torch.zeros(2, 20, 1)
    y[:, 10:] = 10.0  # only model 1 may see these rows
    rows = torch.ones(2, 20, dtype=torch.bool)
    rows[0, 10:] = False
    train_ensemble(
        net, x, y, torch.ones_like(y), rows=rows, epochs=80, learning_rate=0.02, generator=g
    )
    pred = net(x).detach()
    assert pred[0, :10].abs().max() < 1.0  # model 0 never learnt the 10s
    assert pred[1, 10:].mean() > 8.0
