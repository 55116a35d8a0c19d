"""`dresslog train DATA... -o MODEL`: the paper's network by default; options for the rest."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from dresslog.model.options import (
    DEVICES,
    LR_SCHEDULES,
    PAPER,
    PAPER_HIDDEN,
    PAPER_LAYERS,
    RECIPES,
    TrainOptions,
)

from .common import reports_errors
from .options import FiniteRange

#: Ceilings no run on this problem needs to pass (the paper's network is 3x50 at lr 0.001,
#: the bundled models 3x100), so that a slip (--hidden 5000, --lr 10) is refused at once,
#: not after the trials are loaded and the run diverges or runs out of memory. At 1024
#: cells in 3 layers one inference step already takes some 5 ms of a 100 Hz step's 10.
MAX_HIDDEN, MAX_LAYERS, MAX_LR = 1024, 8, 1

# Every default below is the paper's `TrainOptions` field's (`PAPER`), never a second copy;
# `--recipe` swaps in another recipe's, and an option given on the line overrides either.


@click.command("train")
@click.argument("data", nargs=-1, required=True, type=click.Path(file_okay=False))
@click.option("-o", "--output", "--out", "out", type=click.Path(file_okay=False), required=True,
              help="Model folder to write.")  # fmt: skip
@click.option("--recipe", type=click.Choice(list(RECIPES)), default="paper", show_default=True,
              help="The settings every other option starts from: the paper's, or the bundled "
              "models' (3x100 cells, phi and its change, normalised, balanced loss, 60 epochs "
              "annealed, best kept).")  # fmt: skip
@click.option("--epochs", type=click.IntRange(min=1), default=PAPER.epochs, show_default=True,
              help="Passes over the training split.")  # fmt: skip
@click.option("--batch-size", type=click.IntRange(min=1), default=PAPER.batch_size,
              show_default=True, help="Sequences per batch.")  # fmt: skip
@click.option("--hidden", type=click.IntRange(1, MAX_HIDDEN), help="LSTM cells per layer.",
              show_default=f"{PAPER_HIDDEN}, or --init's")  # fmt: skip
@click.option("--layers", type=click.IntRange(1, MAX_LAYERS), help="LSTM layers.",
              show_default=f"{PAPER_LAYERS}, or --init's")  # fmt: skip
@click.option("--lr", type=FiniteRange(0, MAX_LR, min_open=True), default=PAPER.lr,
              show_default=True, help="RMSprop learning rate.")  # fmt: skip
@click.option("--normalise/--no-normalise", default=PAPER.normalise,
              help="Standardise inputs (not in the paper).")  # fmt: skip
@click.option("--balance-loss/--no-balance-loss", default=PAPER.balance_loss,
              help="Scale force targets to the contact map's 0.1 in the loss.")  # fmt: skip
@click.option("--keep-best/--no-keep-best", default=PAPER.keep_best,
              help="Keep the epoch of lowest validation loss, not the last.")  # fmt: skip
@click.option(
    "--lr-schedule",
    type=click.Choice(LR_SCHEDULES),
    default=PAPER.lr_schedule,
    show_default=True,
    help="cosine: anneal the learning rate to 0 over the epochs (the paper: constant).",
)
@click.option("--input-differences/--no-input-differences", default=PAPER.input_differences,
              help="The network also reads the signal's change per step (9 more inputs; not "
              "in the paper).")  # fmt: skip
@click.option("--window", type=click.IntRange(min=2), metavar="W",
              help="Train on random crops of W steps (10 ms each; below the longest training "
              "sequence).", show_default="whole sequences")  # fmt: skip
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=PAPER.seed, show_default=True,
              help="Draws the validation split, the batches and the initial weights.")  # fmt: skip
@click.option("--device", type=click.Choice(DEVICES), default=PAPER.device, show_default=True,
              help="Where to train: auto takes CUDA when torch sees a GPU, else the CPU "
              "(the same model within float tolerance).")  # fmt: skip
@click.option("--init", type=click.Path(), metavar="MODEL",
              help="Start from this model's weights (fine-tuning: its network and input "
              "standardisation are kept).", show_default="random weights")  # fmt: skip
@click.option(
    "--overwrite",
    is_flag=True,
    help="Replace an existing model folder (an interrupted run of these options resumes; "
    "one of other options is discarded).",
)
@click.option("--quiet", "-q", is_flag=True, help="No progress bars.")
@reports_errors
def train(
    data: tuple[str, ...],
    out: str,
    recipe: str,
    init: str | None,
    overwrite: bool,
    quiet: bool,
    **settings: Any,
) -> None:
    """Train a force-map LSTM on DATA's training split; score it on the test split.

    Several DATA folders of one task are pooled (a condition's trials beside in-range ones).
    """
    from dresslog.experiments import TRAINING_PLOT, train_dataset
    from dresslog.model.files import EpochRecord

    def report(epoch: EpochRecord) -> None:
        val = "n/a" if epoch.val_loss is None else f"{epoch.val_loss:.4g}"
        click.echo(f"epoch {epoch.epoch}: train loss {epoch.train_loss:.4g}, val {val}", err=True)

    card = train_dataset(
        data,
        out,
        _options(recipe, settings),
        init=init,
        overwrite=overwrite,
        progress=not quiet,
        on_epoch=report,
    )
    shown = ", ".join(f"{k} {v:.4g}" for k, v in card.metrics.items())
    click.echo(f"{out}: {card.task} model, {card.data.n_train} training sequences; {shown}")
    click.echo(f"learning curve: {Path(out) / TRAINING_PLOT}")


def _options(recipe: str, settings: dict[str, Any]) -> TrainOptions:
    """The recipe's settings, with each option given on the command line in its place."""
    ctx = click.get_current_context()
    given = {
        name: value
        for name, value in settings.items()
        if ctx.get_parameter_source(name) is not click.core.ParameterSource.DEFAULT
    }
    return TrainOptions.model_validate({**RECIPES[recipe].model_dump(), **given})
