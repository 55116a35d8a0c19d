"""The `dresslog train` line that trains a model again, read from its card.

`dresslog info MODEL` prints it, so a researcher who has only a model folder can make the
same model: the same folders, seed and threads give the same weights (on another device,
within float tolerance). The line starts from the named recipe nearest the card and
names only the settings that differ from it.

Public API
----------
``options_of(card) -> TrainOptions``: the settings a card records.
``train_command(card, out="MODEL") -> str``: them as a `dresslog train` line.
"""

from __future__ import annotations

import shlex

from dresslog.model.files import ModelCard
from dresslog.model.options import RECIPES, VAL_FRACTION, TrainOptions

#: Settings the card does not keep, or that are no training option: never on the line.
_UNSAID = {"threads", "device", "val_fraction"}
#: A setting's yes/no flag pair on `dresslog train`.
_FLAGS = {"normalise", "balance_loss", "keep_best", "input_differences"}


def options_of(card: ModelCard) -> TrainOptions:
    """The settings `card` records, as `dresslog train` would be given them."""
    hp = card.hyperparameters
    return TrainOptions(
        epochs=hp.epochs,
        batch_size=hp.batch_size,
        hidden=card.hidden,
        layers=card.layers,
        lr=hp.lr,
        lr_schedule=hp.lr_schedule,
        normalise=card.normalisation is not None and card.init is None,
        balance_loss=hp.force_scale != 1.0,
        keep_best=hp.keep_best,
        input_differences=hp.input_differences,
        window=hp.window,
        seed=hp.seed,
        val_fraction=hp.val_fraction,
    )


def train_command(card: ModelCard, out: str = "MODEL") -> str:
    """The `dresslog train` line that trains `card`'s model again into `out`.

    Args:
        card: a model's card.
        out: the model folder the line writes.

    Returns:
        One shell line: the card's training folders (DATA where an old card does not
        name them), `--init` for a fine-tuned model, the nearest recipe and each setting
        that differs from it; a trailing comment where a setting cannot be given on the
        command line (a validation share other than 0.1, set from Python).
    """
    wanted = options_of(card)
    name, recipe = min(RECIPES.items(), key=lambda item: len(_differences(item[1], wanted)))
    folders = [folder.folder for folder in card.data.folders] or ["DATA"]
    words = ["dresslog", "train", *folders, "-o", out]
    if card.init is not None:
        words += ["--init", card.init.description or "INIT"]
    if name != "paper":
        words += ["--recipe", name]
    for field in _differences(recipe, wanted):
        value = getattr(wanted, field)
        option = "--" + field.replace("_", "-")
        if field in _FLAGS:
            words.append(option if value else f"--no-{option[2:]}")
        elif value is not None:
            words += [option, f"{value:g}" if isinstance(value, float) else str(value)]
    line = shlex.join(words)
    if wanted.val_fraction != VAL_FRACTION:
        line += f"  # validated on a share of {wanted.val_fraction:g}, set from Python"
    return line


def _differences(recipe: TrainOptions, wanted: TrainOptions) -> list[str]:
    """The settings of `wanted` that differ from `recipe`, in the options' order."""
    sizes = dict(zip(("hidden", "layers"), recipe.network(), strict=True))
    differ = []
    for field in TrainOptions.model_fields:
        if field in _UNSAID:
            continue
        had = sizes.get(field, getattr(recipe, field))
        if had != getattr(wanted, field):
            differ.append(field)
    return differ
