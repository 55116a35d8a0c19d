"""Training options: one typed object, validated once, checked against the data before any
work (torch-free, so `train` can refuse at once).

Public API
----------
``TrainOptions`` (pydantic, frozen): every setting of a training run, one field each, with
    the paper's defaults; what `dresslog train`'s options build and what
    `dresslog.experiments.train_dataset` and `dresslog.model.train.train` take whole. A
    setting out of range raises pydantic's ``ValidationError`` when the object is built,
    in the words of the option it came from.
``check_options(lengths, n_val, options)``: ``ModelError`` for settings the data make
    meaningless (a crop window no shorter than any sequence; keeping the best epoch with
    nothing to validate on).
``held_out(n_sequences, val_fraction) -> int``: how many sequences validate.
``PAPER``: ``TrainOptions()``, the paper's settings, every run's default.
``BUNDLED``: the bundled models' recipe; ``RECIPES`` names both for `train --recipe`.
``Device``, ``DEVICES``: where a run trains (`train --device`).
``VAL_FRACTION``, ``LrSchedule``, ``LR_SCHEDULES``, ``PAPER_HIDDEN``, ``PAPER_LAYERS``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Final, Literal, get_args

from pydantic import BaseModel, ConfigDict, model_validator

from dresslog.errors import ModelError

#: The share of training sequences held out for the per-epoch validation loss.
VAL_FRACTION = 0.1
#: How the learning rate changes over the epochs: "cosine" anneals it towards 0.
LrSchedule = Literal["constant", "cosine"]
LR_SCHEDULES: Final[tuple[str, ...]] = get_args(LrSchedule)
#: The paper's network: 3 layers of 50 LSTM cells.
PAPER_HIDDEN, PAPER_LAYERS = 50, 3
#: Where the network trains: "auto" takes CUDA when torch sees a device, else the CPU.
Device = Literal["auto", "cpu", "cuda"]
DEVICES: Final[tuple[str, ...]] = get_args(Device)


class TrainOptions(BaseModel):
    """Every setting of a training run, the paper's by default (3x50 LSTM, RMSprop at
    0.001, 10 epochs of 16-sequence batches over whole sequences).

    One field per setting and its default here alone: `dresslog train` shows these
    defaults, builds the object from its options and hands it on whole, so a new
    setting is one field here and one option there. `hidden` and `layers` left as None
    take the paper's sizes, or, when fine-tuning (`train --init`), the initial model's;
    `normalise` and `input_differences` left False take the initial model's too.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=True)

    #: passes over the training split
    epochs: int = 10
    #: sequences per batch
    batch_size: int = 16
    #: LSTM cells per layer; None: `PAPER_HIDDEN`, or the initial model's
    hidden: int | None = None
    #: LSTM layers; None: `PAPER_LAYERS`, or the initial model's
    layers: int | None = None
    #: RMSprop's learning rate
    lr: float = 1e-3
    #: "cosine": anneal the learning rate towards 0 over the epochs (the paper: constant)
    lr_schedule: LrSchedule = "constant"
    #: standardise the network's inputs by the training signal's mean and std
    normalise: bool = False
    #: scale force targets to the contact map's 0.1 in the loss (`balanced_force_scale`)
    balance_loss: bool = False
    #: keep the weights of the epoch of lowest validation loss, not the last
    keep_best: bool = False
    #: the network also reads phi's change per step (9 more inputs)
    input_differences: bool = False
    #: train on random crops of this many steps; None: whole sequences
    window: int | None = None
    #: draws the validation split, the batches and the initial weights
    seed: int = 0
    #: the share of training sequences held out to validate on
    val_fraction: float = VAL_FRACTION
    #: torch CPU threads; None: min(2, cores). The same data, seed and threads give the
    #: same weights.
    threads: int | None = None
    #: where to train; not a hyperparameter: a CUDA run matches a CPU one within float
    #: tolerance, and a run resumes on either
    device: Device = "auto"

    @model_validator(mode="after")
    def _trainable(self) -> TrainOptions:
        """Refuse settings that cannot train, in the words of the option they came from."""
        given = (self.hidden, self.layers, self.threads)  # None: the default, not 0
        if min(self.epochs, self.batch_size, *(n for n in given if n is not None)) < 1:
            raise ValueError(
                "epochs, batch size, hidden size, layers and threads must all be 1 or more"
            )
        if not (math.isfinite(self.lr) and self.lr > 0):
            raise ValueError(f"the learning rate must be a positive number, not {self.lr}")
        if self.window is not None and self.window < 2:  # as `train --window` says
            raise ValueError(f"a crop window must be 2 steps or more, not {self.window}")
        if not 0 <= self.val_fraction < 1:  # NaN too
            raise ValueError(_share_problem(self.val_fraction))
        if not 0 <= self.seed < 2**32:
            raise ValueError(f"the seed must be in [0, 2**32), not {self.seed}")
        return self

    def network(self) -> tuple[int, int]:
        """(hidden, layers): the sizes asked for, the paper's where left out."""
        hidden = PAPER_HIDDEN if self.hidden is None else self.hidden
        return hidden, PAPER_LAYERS if self.layers is None else self.layers


#: The paper's settings: what `train` and `dresslog train` use where not told otherwise.
PAPER: Final = TrainOptions()
#: The bundled models' recipe (docs/results.md): 3x100 cells reading phi and its change
#: per step, standardised inputs, a balanced loss, 60 epochs annealed, the best one kept.
BUNDLED: Final = TrainOptions(
    epochs=60,
    hidden=100,
    lr_schedule="cosine",
    normalise=True,
    balance_loss=True,
    keep_best=True,
    input_differences=True,
)
#: The recipes `dresslog train --recipe` names; its other options change one setting each.
RECIPES: Final[dict[str, TrainOptions]] = {"paper": PAPER, "bundled": BUNDLED}


def _share_problem(val_fraction: float) -> str:
    return f"val_fraction must be a share of the training sequences in [0, 1), not {val_fraction!r}"


def held_out(n_sequences: int, val_fraction: float) -> int:
    """How many of `n_sequences` are held out to validate on (at least one is trained on).

    Raises:
        ModelError: `val_fraction` is not a share in [0, 1).
    """
    if not 0 <= val_fraction < 1:  # NaN too
        raise ModelError(_share_problem(val_fraction))
    return max(0, min(round(val_fraction * n_sequences), n_sequences - 1))


def check_options(lengths: Sequence[int], n_val: int, options: TrainOptions) -> None:
    """Refuse settings the data make meaningless; cheap, so `train_dataset` runs it from
    the manifest before loading any trial, and `train` again on the sequences themselves.

    Args:
        lengths: the training sequences' step counts.
        n_val: how many sequences validate.
        options: the run's settings (already valid in themselves).

    Raises:
        ModelError: keeping the best epoch with nothing to validate on, or a crop window
            no shorter than the longest sequence.
    """
    if options.keep_best and not n_val:
        raise ModelError(
            "keeping the epoch of lowest validation loss needs validation sequences, "
            f"and none of the {len(lengths)} training sequences is held out: train on "
            "more trials, or keep the last epoch"
        )
    longest = max(lengths, default=0)
    window = options.window
    if window is not None and window >= longest:
        raise ModelError(
            f"a crop window of {window} steps is not shorter than any training sequence "
            f"(the longest has {longest}): every crop would be a whole sequence; "
            f"give a window below {longest} or none"
        )
