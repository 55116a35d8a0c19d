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
#: phi's channels and their units, as a warning names them.
PHI_NAMES = ("fx", "fy", "fz", "tx", "ty", "tz", "vx", "vy", "vz")
PHI_UNITS = ("N", "N", "N", "N m", "N m", "N m", "m/s", "m/s", "m/s")
#: A channel is unfamiliar when more than FAR_SHARE of a trial's steps lie beyond FAR_SD
#: of the training data's standard deviations: 32 simulated trials the bundled models
#: never saw have at most 1.7% of steps beyond 10, an untared sensor (the gripper's own
#: weight in fz) every step.
FAR_SD = 10.0
FAR_SHARE = 0.1


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


def unfamiliar(phi: np.ndarray, mean: np.ndarray, std: np.ndarray) -> str | None:
    """Why a trial's signal (T, 9) is far from the training data's, or None if it is not.

    `mean` and `std` are the model's input standardisation (the first 9 are phi's).
    A network extrapolates there without a sign of it, and the usual causes are the
    recording's (a sensor not tared, in its own axes, in other units), not the model's.
    """
    mean, std = np.asarray(mean[:PHI_DIM]), np.asarray(std[:PHI_DIM])
    share = (np.abs((phi - mean) / std) > FAR_SD).mean(axis=0)
    k = int(share.argmax())
    if not share[k] > FAR_SHARE:
        return None
    unit = PHI_UNITS[k]
    return (
        f"{PHI_NAMES[k]} lies beyond {FAR_SD:g} standard deviations of the model's training "
        f"data on {share[k]:.0%} of steps (median {np.median(phi[:, k]):.3g} {unit}, trained on "
        f"{mean[k]:.3g} +- {std[k]:.3g} {unit}), so the estimate there is a guess; is the "
        "sensor tared (`convert --tare`), in world axes and SI units?"
    )
