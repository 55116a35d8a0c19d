"""What the network reads at each step: the 9-D signal phi, and optionally its change.

A model trained with `input_differences` reads [phi_t, phi_t - phi_{t-1}] (18-D; the
change is 0 at the first step). The LSTM could form that difference itself, but its
tanh units, fed standardised inputs, pick up a step's change poorly: on the gown the
change as 9 more inputs took the test ratio from 0.680 to 0.663, and the bundled models
from 0.650 to 0.623 (gown) and 0.456 to 0.411 (shorts; docs/experiments.md).
The weights alone say which a model reads: their input width is 9 or 18.
"""

from __future__ import annotations

import numpy as np

#: The end effector's measurement per step: force (3), torque (3), velocity (3).
PHI_DIM = 9


def network_inputs(phi: np.ndarray, differences: bool) -> np.ndarray:
    """(..., T, 9) -> the network's (..., T, 9) or, with `differences`, (..., T, 18)."""
    if not differences:
        return phi
    change = np.diff(phi, axis=-2, prepend=phi[..., :1, :])
    return np.concatenate([phi, change], axis=-1)


def reads_differences(input_dim: int) -> bool:
    """Whether a network of this input width reads phi's change too; ValueError if neither."""
    if input_dim not in (PHI_DIM, 2 * PHI_DIM):
        raise ValueError(f"input width {input_dim}: expected {PHI_DIM} or {2 * PHI_DIM}")
    return input_dim == 2 * PHI_DIM
