"""The seed paper's network as a vectorized ensemble of multilayer perceptrons.

One :class:`EnsembleMLP` holds ``n_models`` independent networks of the same
shape (``in -> hidden... -> out``, ReLU) whose weights carry a leading model
axis, so that all members of a deep ensemble, all directions (x, y, z) and all
cross-validation folds train in one pass with batched matrix products
(``torch.baddbmm``). Members share no parameter.

The seed's network (section 2.3): 6 joint angles -> 5 hidden layers of 32 ReLU
units -> 15 outputs (5 modes x frequency, damping, modal stiffness), one
network per TCP direction, Glorot-uniform weights and zero biases (the Keras
defaults the paper used).

All weights live in one flat parameter ``theta``, layer after layer (``W0``,
``b0``, ``W1``, ...; each block model-major), so the first ``n`` layers are a
contiguous prefix ``theta[:frozen_size(n)]``: freezing them is training only
the rest of the vector.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import torch
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = ["EnsembleMLP"]


class EnsembleMLP(torch.nn.Module):
    """``n_models`` independent ReLU perceptrons evaluated together.

    Parameters
    ----------
    n_models : int
        Number of independent networks (members x directions x folds).
    sizes : sequence of int
        Layer widths, input first, output last, e.g. ``(6, 32, 32, 32, 32, 32, 15)``.
    generator : torch.Generator, optional
        Source of the Glorot-uniform initial weights; zeros if absent.
    """

    def __init__(
        self, n_models: int, sizes: Sequence[int], generator: torch.Generator | None = None
    ) -> None:
        super().__init__()
        if len(sizes) < 2 or min(sizes) < 1 or n_models < 1:
            raise InputError(f"sizes: expected >= 2 positive widths, found {tuple(sizes)}")
        self.n_models = int(n_models)
        self.sizes = tuple(int(s) for s in sizes)
        self._offsets: list[tuple[int, int, int]] = []  # (w_start, b_start, b_end)
        off = 0
        for n_in, n_out in zip(self.sizes[:-1], self.sizes[1:], strict=True):
            w0 = off
            off += self.n_models * n_in * n_out
            b0 = off
            off += self.n_models * n_out
            self._offsets.append((w0, b0, off))
        self.theta = torch.nn.Parameter(torch.zeros(off, dtype=torch.float32))
        if generator is not None:
            with torch.no_grad():
                for i, w in enumerate(self.weight_views(self.theta)):
                    n_in, n_out = self.sizes[i], self.sizes[i + 1]
                    limit = math.sqrt(6.0 / (n_in + n_out))
                    u = torch.rand(w.shape, generator=generator, dtype=torch.float32)
                    w.copy_((2.0 * u - 1.0) * limit)

    # ------------------------------------------------------------------ views
    @property
    def n_layers(self) -> int:
        """Number of weight layers (hidden layers + output layer)."""
        return len(self.sizes) - 1

    def frozen_size(self, n_frozen: int) -> int:
        """Length of the prefix of ``theta`` holding the first ``n_frozen`` layers."""
        if not 0 <= n_frozen <= self.n_layers:
            raise InputError(f"n_frozen: expected 0..{self.n_layers}, found {n_frozen}")
        return 0 if n_frozen == 0 else self._offsets[n_frozen - 1][2]

    def weight_views(self, flat: torch.Tensor) -> list[torch.Tensor]:
        """Views ``(n_models, n_in, n_out)`` of each layer's weights in ``flat``."""
        out = []
        for i, (w0, b0, _) in enumerate(self._offsets):
            out.append(flat[w0:b0].view(self.n_models, self.sizes[i], self.sizes[i + 1]))
        return out

    def bias_views(self, flat: torch.Tensor) -> list[torch.Tensor]:
        """Views ``(n_models, 1, n_out)`` of each layer's biases in ``flat``."""
        out = []
        for i, (_, b0, b1) in enumerate(self._offsets):
            out.append(flat[b0:b1].view(self.n_models, 1, self.sizes[i + 1]))
        return out

    # ---------------------------------------------------------------- forward
    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Evaluate all models.

        Parameters
        ----------
        x : Tensor, shape (n_models, batch, n_in) or (batch, n_in)
            Inputs per model, or one input batch shared by all models.

        Returns
        -------
        Tensor, shape (n_models, batch, n_out)
        """
        h = x
        if h.dim() == 2:
            h = h.unsqueeze(0).expand(self.n_models, -1, -1)
        ws = self.weight_views(self.theta)
        bs = self.bias_views(self.theta)
        last = self.n_layers - 1
        for i in range(self.n_layers):
            h = torch.baddbmm(bs[i], h, ws[i])
            if i < last:
                h = torch.relu(h)
        return h

    def predict_numpy(self, x: NDArray[np.floating]) -> NDArray[np.float64]:
        """Forward pass without autograd (float32, torch).

        Prediction from a trained model uses the numpy pass of the same
        weights instead (:class:`robolobe.tl.forward.ArrayMLP`, no torch).

        Parameters
        ----------
        x : ndarray, shape (batch, n_in) or (n_models, batch, n_in)

        Returns
        -------
        ndarray, shape (n_models, batch, n_out)
        """
        with torch.inference_mode():
            out = self.forward(torch.as_tensor(np.asarray(x, dtype=np.float32)))
        return out.numpy().astype(np.float64)

    # ---------------------------------------------------------------- export
    def to_arrays(self) -> dict[str, NDArray[np.float32]]:
        """Weights as plain arrays ``W0, b0, W1, b1, ...`` (float32 copies)."""
        flat = self.theta.detach()
        out: dict[str, NDArray[np.float32]] = {}
        for i, (w, b) in enumerate(
            zip(self.weight_views(flat), self.bias_views(flat), strict=True)
        ):
            out[f"W{i}"] = w.numpy().copy()
            out[f"b{i}"] = b[:, 0, :].numpy().copy()
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, NDArray[np.floating]]) -> EnsembleMLP:
        """Rebuild from :meth:`to_arrays` output.

        Raises
        ------
        ValueError
            If layers are missing or their shapes do not chain.
        """
        from robolobe.tl.forward import ArrayMLP

        plain = ArrayMLP.from_arrays(arrays)  # checks the layers chain
        ws, bs = plain.weights, plain.biases
        net = cls(plain.n_models, plain.sizes)
        with torch.no_grad():
            for w_view, b_view, w, b in zip(
                net.weight_views(net.theta), net.bias_views(net.theta), ws, bs, strict=True
            ):
                w_view.copy_(torch.from_numpy(w))
                b_view.copy_(torch.from_numpy(b)[:, None, :])
        return net

    def select(self, models: Sequence[int] | NDArray[np.integer]) -> EnsembleMLP:
        """A new ensemble holding copies of the given models, in that order."""
        idx = np.asarray(models, dtype=np.int64)
        return EnsembleMLP.from_arrays({k: v[idx] for k, v in self.to_arrays().items()})
