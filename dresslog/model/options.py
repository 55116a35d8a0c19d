"""Training options checked before any work: torch-free, so `train` can refuse at once."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Final, Literal, get_args

from dresslog.errors import ModelError

#: The share of training sequences held out for the per-epoch validation loss.
VAL_FRACTION = 0.1
#: How the learning rate changes over the epochs: "cosine" anneals it towards 0.
LrSchedule = Literal["constant", "cosine"]
LR_SCHEDULES: Final[tuple[str, ...]] = get_args(LrSchedule)


def held_out(n_sequences: int, val_fraction: float) -> int:
    """How many of `n_sequences` are held out to validate on (at least one is trained on);
    `val_fraction` is a share in [0, 1), anything else a `ModelError`."""
    if not 0 <= val_fraction < 1:  # NaN too
        raise ModelError(
            f"val_fraction must be a share of the training sequences in [0, 1), "
            f"not {val_fraction!r}"
        )
    return max(0, min(round(val_fraction * n_sequences), n_sequences - 1))


def check_options(
    lengths: Sequence[int],
    n_val: int,
    *,
    epochs: int,
    batch_size: int,
    hidden: int,
    layers: int,
    lr: float,
    window: int | None,
    keep_best: bool,
    lr_schedule: str = "constant",
) -> None:
    """Refuse settings that cannot train, or that the data make meaningless.

    `lengths`: the training sequences' step counts; `n_val`: how many validate. Cheap,
    so `train_dataset` runs it from the manifest before loading any trial.
    """
    if epochs < 1 or batch_size < 1 or hidden < 1 or layers < 1:
        raise ModelError("epochs, batch size, hidden size and layers must all be 1 or more")
    if not (math.isfinite(lr) and lr > 0):
        raise ModelError(f"the learning rate must be a positive number, not {lr}")
    if lr_schedule not in LR_SCHEDULES:
        raise ModelError(f"lr_schedule {lr_schedule!r} is not one of {', '.join(LR_SCHEDULES)}")
    if keep_best and not n_val:
        raise ModelError(
            "keeping the epoch of lowest validation loss needs validation sequences, "
            f"and none of the {len(lengths)} training sequences is held out: train on "
            "more trials, or keep the last epoch"
        )
    longest = max(lengths, default=0)
    if window is not None and window < 2:  # as `train --window` says
        raise ModelError(f"a crop window must be 2 steps or more, not {window}")
    if window is not None and window >= longest:
        raise ModelError(
            f"a crop window of {window} steps is not shorter than any training sequence "
            f"(the longest has {longest}): every crop would be a whole sequence; "
            f"give a window below {longest} or none"
        )
