"""The force-map LSTM in torch: used for training only; inference runs in numpy.

Public API
----------
``ForceMapLSTM(n_points, hidden=50, layers=3, input_dim=9)``
    3 stacked LSTMs of 50 tanh cells (Glorot-uniform weights, forget-gate bias 1 as
    Keras had it), all returning sequences, then a per-step linear head to ``2 * n_points``
    outputs ``[force map, contact map]``. Input normalisation ``(phi - mean) / std`` is
    held in buffers ``input_mean``/``input_std`` (identity by default; the paper used none).

    ``forward(phi (B, T, input_dim), state=None) -> (out (B, T, 2N), state)``: ``phi`` is
    ``dresslog.model.inputs.network_inputs(phi, ...)``, phi itself for 9 inputs. Causal, so padding
    at the end of a sequence never changes its valid outputs; pass ``state`` back in to
    continue a sequence (the stateful one-step use). ``set_normalisation(mean, std)``
    fills the normalisation buffers.

``ForceMapLSTM.from_weights(weights)`` / ``.weights() -> dict[str, np.ndarray]``
    To and from the flat float32 dict that ``dresslog.model.files`` saves and
    ``dresslog.model.numpy_lstm.NumpyEstimator`` runs. Key names are this module's
    ``state_dict`` names (``lstm.weight_ih_l0`` ..., ``head.weight``, ``input_mean`` ...).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import torch
from torch import nn

from dresslog.model.inputs import PHI_DIM
from dresslog.model.numpy_lstm import infer_sizes

LSTMState = tuple[torch.Tensor, torch.Tensor]


class ForceMapLSTM(nn.Module):
    """phi_{1:T} (9-D per step) -> [unprocessed force map, contact map] per step."""

    input_mean: torch.Tensor  # buffers: saved with the weights, not trained
    input_std: torch.Tensor

    def __init__(
        self, n_points: int, hidden: int = 50, layers: int = 3, input_dim: int = PHI_DIM
    ) -> None:
        super().__init__()
        self.n_points = n_points
        self.hidden = hidden
        self.layers = layers
        self.input_dim = input_dim
        self.lstm = nn.LSTM(input_dim, hidden, num_layers=layers, batch_first=True)
        self.head = nn.Linear(hidden, 2 * n_points)
        self.register_buffer("input_mean", torch.zeros(input_dim))
        self.register_buffer("input_std", torch.ones(input_dim))
        self.reset_parameters()

    def reset_parameters(self) -> None:
        """Glorot-uniform weights (the paper's words), zero biases, forget-gate bias 1.

        Keras's own LSTM default is orthogonal for the recurrent weights; the paper
        names Glorot's uniform distribution, so every weight gets it here.
        """
        for name, param in self.named_parameters():
            if "weight" in name:
                nn.init.xavier_uniform_(param)
            else:
                nn.init.zeros_(param)
        for layer in range(self.layers):
            # torch's gate order is (input, forget, cell, output); two biases are summed.
            getattr(self.lstm, f"bias_ih_l{layer}").data[self.hidden : 2 * self.hidden] = 1.0

    def set_normalisation(self, mean: np.ndarray, std: np.ndarray) -> None:
        """Standardise inputs with these per-channel statistics (std floored at 1e-8)."""
        self.input_mean.copy_(torch.as_tensor(np.asarray(mean, dtype=np.float32)))
        self.input_std.copy_(torch.as_tensor(np.maximum(np.asarray(std, np.float32), 1e-8)))

    def forward(
        self, phi: torch.Tensor, state: LSTMState | None = None
    ) -> tuple[torch.Tensor, LSTMState]:
        """The network's outputs (..., T, 2N), force map then contact map, and the LSTM state
        after the last step: pass it back to continue a sequence."""
        x = (phi - self.input_mean) / self.input_std
        h, state = self.lstm(x, state)
        return self.head(h), state

    def weights(self) -> dict[str, np.ndarray]:
        """Every parameter and buffer as a contiguous float32 numpy array."""
        return {
            k: np.ascontiguousarray(v.detach().cpu().numpy(), dtype=np.float32)
            for k, v in self.state_dict().items()
        }

    @classmethod
    def from_weights(cls, weights: Mapping[str, np.ndarray]) -> ForceMapLSTM:
        """Rebuild a network from `weights()` output; sizes are read from the shapes."""
        n_points, hidden, layers, input_dim = infer_sizes(weights)
        net = cls(n_points, hidden=hidden, layers=layers, input_dim=input_dim)
        net.load_state_dict({k: torch.from_numpy(np.array(v)) for k, v in weights.items()})
        return net
