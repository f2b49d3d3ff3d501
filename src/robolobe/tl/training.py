"""Mini-batch training of an :class:`~robolobe.tl.network.EnsembleMLP`.

All models of the ensemble train together: at every step each model gets its
own mini-batch (its own shuffle of its own rows), and one Adam step updates
every trainable weight. Models are independent (disjoint parameters,
element-wise Adam), so each model ends exactly where it would trained alone
with the same shuffles.

Defaults follow the seed paper (section 2.3): Adam with the Keras defaults
(learning rate 1e-3, beta 0.9/0.999, eps 1e-7), MSE loss, batch 8, 500
epochs, the last partial batch of an epoch kept.

The gradient of the masked MSE is written out by hand (batched matrix
products, no autograd) and Adam works on the flat trainable slice of the
parameter vector: for these tiny layers that is ~5x faster than autograd plus
``torch.optim.Adam``. ``tests/tl`` checks the gradient against autograd. The
first ``n_frozen`` layers are never written: their slice of the parameter
vector is left out of the update.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError

if TYPE_CHECKING:  # torch is imported by the functions that train (not on load)
    import torch

    from robolobe.tl.network import EnsembleMLP

__all__ = ["TrainHistory", "masked_mse", "masked_mse_grad", "train_ensemble"]

_BETA1 = 0.9
_BETA2 = 0.999
_EPS = 1e-7
# sqrt(0) is ~20x slower than sqrt(x > 0) in the MKL vector math torch uses on
# CPU; a second-moment floor far below eps**2 removes the zeros harmlessly.
_V_FLOOR = 1e-30


@dataclass(frozen=True)
class TrainHistory:
    """Loss per epoch and model.

    Attributes
    ----------
    train_loss : ndarray, shape (epochs, n_models)
        Mean masked MSE over each model's mini-batches of the epoch (scaled targets).
    val_loss : ndarray, shape (epochs, n_models) or None
        Masked MSE on the validation rows after each epoch, if given.
    """

    train_loss: NDArray[np.float64]
    val_loss: NDArray[np.float64] | None


def masked_mse(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean squared error per model over the known entries.

    Parameters
    ----------
    pred, target, mask : Tensor, shape (n_models, batch, n_out)
        ``mask`` is 1 where the target is known, 0 where it is missing.

    Returns
    -------
    Tensor, shape (n_models,)
    """
    se = (pred - target).square() * mask
    return se.sum(dim=(1, 2)) / mask.sum(dim=(1, 2)).clamp_min(1.0)


def masked_mse_grad(
    net: EnsembleMLP,
    x: torch.Tensor,
    target: torch.Tensor,
    mask: torch.Tensor,
    grad: torch.Tensor,
    n_frozen: int = 0,
) -> torch.Tensor:
    """Loss per model and its gradient (written into ``grad``) by backpropagation.

    Parameters
    ----------
    net : EnsembleMLP
    x : Tensor, shape (n_models, batch, n_in)
    target, mask : Tensor, shape (n_models, batch, n_out)
    grad : Tensor, shape like ``net.theta``
        Receives d(sum of per-model losses)/d theta for the layers from
        ``n_frozen`` on; the frozen prefix is not touched.
    n_frozen : int
        Number of leading layers whose gradient is not needed.

    Returns
    -------
    Tensor, shape (n_models,)
        The masked MSE of each model.
    """
    return _Backprop(net, grad, n_frozen)(x, target, mask)


class _Backprop:
    """Forward + backward of the masked MSE with the layer views made once."""

    def __init__(self, net: EnsembleMLP, grad: torch.Tensor, n_frozen: int) -> None:
        theta = net.theta.detach()
        self.ws = net.weight_views(theta)
        self.bs = net.bias_views(theta)
        self.wts = [w.transpose(1, 2) for w in self.ws]
        self.gws = net.weight_views(grad)
        self.gbs = net.bias_views(grad)
        self.n_frozen = n_frozen
        self.last = net.n_layers - 1

    def __call__(self, x: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        import torch

        last = self.last
        hs = [x]
        h = x
        for i in range(last + 1):
            h = torch.baddbmm(self.bs[i], h, self.ws[i])
            if i < last:
                h = torch.relu(h)
            hs.append(h)
        count = mask.sum(dim=(1, 2), keepdim=True).clamp_min(1.0)
        err = (h - target) * mask
        loss = (err.square().sum(dim=(1, 2), keepdim=True) / count).reshape(-1)
        d = err * (2.0 / count)
        for i in range(last, self.n_frozen - 1, -1):
            torch.bmm(hs[i].transpose(1, 2), d, out=self.gws[i])
            torch.sum(d, dim=1, keepdim=True, out=self.gbs[i])
            if i > self.n_frozen:
                d = torch.bmm(d, self.wts[i]) * (hs[i] > 0)
        return loss


def _epoch_indices(
    rows: torch.Tensor, counts: torch.Tensor, length: int, generator: torch.Generator
) -> torch.Tensor:
    """A random order of each model's own rows, cycled to ``length``.

    rows: (n_models, n) bool; counts: (n_models,) rows per model.
    Returns (n_models, length) int64 indices into the n rows.
    """
    import torch

    n_models, n = rows.shape
    keys = torch.rand((n_models, n), generator=generator) + (~rows).to(torch.float32) * 2.0
    perm = torch.argsort(keys, dim=1)  # the model's own rows first, shuffled
    pos = torch.arange(length).unsqueeze(0) % counts.unsqueeze(1)
    return torch.gather(perm, 1, pos)


def train_ensemble(
    net: EnsembleMLP,
    x: torch.Tensor,
    y: torch.Tensor,
    mask: torch.Tensor,
    *,
    rows: torch.Tensor | None = None,
    n_frozen: int = 0,
    epochs: int = 500,
    batch_size: int = 8,
    learning_rate: float = 1e-3,
    generator: torch.Generator,
    x_val: torch.Tensor | None = None,
    y_val: torch.Tensor | None = None,
    mask_val: torch.Tensor | None = None,
) -> TrainHistory:
    """Train every model of ``net`` in place with Adam on the masked MSE.

    Parameters
    ----------
    net : EnsembleMLP
        The ensemble; its first ``n_frozen`` layers are never written.
    x : Tensor, shape (n_models, n, n_in)
        Scaled (and augmented) inputs per model.
    y, mask : Tensor, shape (n_models, n, n_out)
        Scaled targets per model and their validity (1 known, 0 missing).
    rows : Tensor of bool, shape (n_models, n), optional
        Rows each model trains on (cross-validation folds); all if absent.
        An epoch of a model is one pass over its own rows; models with fewer
        rows than the largest set cycle through theirs again.
    n_frozen : int
        Leading layers kept fixed (the paper's transfer: 3).
    epochs, batch_size, learning_rate : int, int, float
        Training schedule (paper: 500, 8, 1e-3).
    generator : torch.Generator
        Source of the shuffles.
    x_val, y_val, mask_val : Tensor, shape (n_models, n_val, ...), optional
        Validation rows, evaluated after each epoch.

    Returns
    -------
    TrainHistory
    """
    import torch

    n_models, n, _ = x.shape
    if x_val is not None and (y_val is None or mask_val is None):
        raise InputError("x_val: expected y_val and mask_val with it")
    if n_models != net.n_models:
        raise InputError(f"x: expected {net.n_models} models, found {n_models}")
    if epochs < 1 or batch_size < 1 or not learning_rate > 0:
        raise InputError("epochs, batch_size and learning_rate must be positive")
    if rows is None:
        rows = torch.ones((n_models, n), dtype=torch.bool)
    counts = rows.sum(dim=1)
    if int(counts.min()) < 1:
        raise InputError("rows: every model needs at least one training row")
    length = int(counts.max())
    start = net.frozen_size(n_frozen)
    if start >= net.theta.numel():
        raise InputError(f"n_frozen: {n_frozen} leaves nothing to train")
    x = x.to(torch.float32)
    y = y.to(torch.float32)
    mask = mask.to(torch.float32)
    # Adam's moments of weights with zero gradient (dead ReLU units) decay into
    # denormal floats, which make every vector op ~100x slower: flush them.
    # One thread: these matrices are tiny, and on a loaded 2-core machine two
    # OpenMP threads were measured 30x slower than one (spin-waiting).
    torch.set_flush_denormal(True)
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return _train_loop(
            net, x, y, mask, rows, counts, length, start, n_frozen, epochs, batch_size,
            learning_rate, generator, x_val, y_val, mask_val,
        )  # fmt: skip
    finally:
        torch.set_flush_denormal(False)
        torch.set_num_threads(threads)


def _train_loop(
    net: EnsembleMLP,
    x: torch.Tensor,
    y: torch.Tensor,
    mask: torch.Tensor,
    rows: torch.Tensor,
    counts: torch.Tensor,
    length: int,
    start: int,
    n_frozen: int,
    epochs: int,
    batch_size: int,
    learning_rate: float,
    generator: torch.Generator,
    x_val: torch.Tensor | None,
    y_val: torch.Tensor | None,
    mask_val: torch.Tensor | None,
) -> TrainHistory:
    import torch

    n_models = x.shape[0]
    grad = torch.zeros_like(net.theta.detach())
    model_idx = torch.arange(n_models).unsqueeze(1)
    n_steps = -(-length // batch_size)
    train_loss = np.empty((epochs, n_models))
    val_loss = np.empty((epochs, n_models)) if x_val is not None else None
    with torch.inference_mode():
        theta = net.theta.detach()
        backprop = _Backprop(net, grad, n_frozen)
        param = theta[start:]
        g = grad[start:]
        m1 = torch.zeros_like(param)
        m2 = torch.zeros_like(param)
        t = 0
        for epoch in range(epochs):
            idx = _epoch_indices(rows, counts, length, generator)
            xe = x[model_idx, idx]
            ye = y[model_idx, idx]
            me = mask[model_idx, idx]
            acc = torch.zeros(n_models)
            for s in range(n_steps):
                sl = slice(s * batch_size, (s + 1) * batch_size)
                acc += backprop(xe[:, sl], ye[:, sl], me[:, sl])
                t += 1
                m1.mul_(_BETA1).add_(g, alpha=1.0 - _BETA1)
                m2.mul_(_BETA2).addcmul_(g, g, value=1.0 - _BETA2)
                bc1 = 1.0 - _BETA1**t
                bc2 = 1.0 - _BETA2**t
                denom = m2.add(_V_FLOOR).sqrt_().div_(bc2**0.5).add_(_EPS)
                param.addcdiv_(m1, denom, value=-learning_rate / bc1)
            train_loss[epoch] = (acc / n_steps).numpy()
            if val_loss is not None and x_val is not None and y_val is not None:
                assert mask_val is not None
                val_loss[epoch] = masked_mse(net(x_val), y_val, mask_val).numpy()
    return TrainHistory(train_loss=train_loss, val_loss=val_loss)
