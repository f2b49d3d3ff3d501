"""The ensemble's forward pass in numpy: prediction without torch.

:class:`ArrayMLP` holds the weights of an
:class:`~robolobe.tl.network.EnsembleMLP` as plain arrays (the layout of
:meth:`~robolobe.tl.network.EnsembleMLP.to_arrays`: ``W{i}`` of shape
``(n_models, n_in, n_out)``, ``b{i}`` of shape ``(n_models, n_out)``) and
evaluates them with numpy. Loading a model and predicting with it (planning,
``robolobe predict``) therefore never imports torch (~1.5 s of start-up);
only training and transfer do. The float32 weights are evaluated in float64,
so the result is the exact network to rounding (torch's float32 pass agrees
to ~1e-6, tested).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = ["ArrayMLP"]


class ArrayMLP:
    """``n_models`` independent ReLU perceptrons as numpy arrays (inference only).

    Parameters
    ----------
    weights : sequence of ndarray, shapes (n_models, n_in_i, n_out_i)
    biases : sequence of ndarray, shapes (n_models, n_out_i)
    """

    def __init__(
        self, weights: Sequence[NDArray[np.floating]], biases: Sequence[NDArray[np.floating]]
    ) -> None:
        self.weights = [np.asarray(w, dtype=np.float32) for w in weights]
        self.biases = [np.asarray(b, dtype=np.float32) for b in biases]
        self.n_models = int(self.weights[0].shape[0])
        self.sizes = (int(self.weights[0].shape[1]), *(int(w.shape[2]) for w in self.weights))

    @property
    def n_layers(self) -> int:
        """Number of weight layers (hidden layers + output layer)."""
        return len(self.weights)

    @classmethod
    def from_arrays(cls, arrays: dict[str, NDArray[np.floating]]) -> ArrayMLP:
        """From ``W0, b0, W1, b1, ...`` (as written by ``to_arrays``).

        Raises
        ------
        ValueError
            If layers are missing or their shapes do not chain.
        """
        n_layers = sum(1 for k in arrays if k.startswith("W") and k[1:].isdigit())
        if n_layers < 1:
            raise InputError("weights: expected arrays W0, b0, ..., found none")
        ws, bs = [], []
        for i in range(n_layers):
            if f"W{i}" not in arrays or f"b{i}" not in arrays:
                raise InputError(f"weights: layer {i}: expected W{i} and b{i}")
            ws.append(np.asarray(arrays[f"W{i}"], dtype=np.float32))
            bs.append(np.asarray(arrays[f"b{i}"], dtype=np.float32))
        if ws[0].ndim != 3:
            raise InputError(f"weights: layer 0: expected 3 axes, found shape {ws[0].shape}")
        n_models = ws[0].shape[0]
        sizes = [ws[0].shape[1]] + [w.shape[2] if w.ndim == 3 else -1 for w in ws]
        for i in range(n_layers):
            want_w = (n_models, sizes[i], sizes[i + 1])
            if ws[i].shape != want_w or bs[i].shape != (n_models, sizes[i + 1]):
                raise InputError(
                    f"weights: layer {i}: expected shapes {want_w} and "
                    f"{(n_models, sizes[i + 1])}, found {ws[i].shape} and {bs[i].shape}"
                )
        return cls(ws, bs)

    def to_arrays(self) -> dict[str, NDArray[np.float32]]:
        """Weights as plain arrays ``W0, b0, W1, b1, ...`` (float32 copies)."""
        out: dict[str, NDArray[np.float32]] = {}
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            out[f"W{i}"] = w.copy()
            out[f"b{i}"] = b.copy()
        return out

    def select(self, models: Sequence[int] | NDArray[np.integer]) -> ArrayMLP:
        """A new ensemble holding copies of the given models, in that order."""
        idx = np.asarray(models, dtype=np.int64)
        return ArrayMLP([w[idx] for w in self.weights], [b[idx] for b in self.biases])

    def predict_numpy(self, x: NDArray[np.floating]) -> NDArray[np.float64]:
        """Forward pass of all models.

        Parameters
        ----------
        x : ndarray, shape (batch, n_in) or (n_models, batch, n_in)
            One input batch shared by all models, or one per model.

        Returns
        -------
        ndarray, shape (n_models, batch, n_out)
        """
        h = np.asarray(x, dtype=np.float32).astype(np.float64)
        if h.ndim == 2:
            h = np.broadcast_to(h, (self.n_models, *h.shape))
        if h.ndim != 3 or h.shape[0] != self.n_models or h.shape[2] != self.sizes[0]:
            raise InputError(
                f"x: expected shape (batch, {self.sizes[0]}) or "
                f"({self.n_models}, batch, {self.sizes[0]}), found {np.shape(x)}"
            )
        last = self.n_layers - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = np.matmul(h, w.astype(np.float64)) + b.astype(np.float64)[:, None, :]
            if i < last:
                np.maximum(h, 0.0, out=h)
        return np.asarray(h, dtype=np.float64)
