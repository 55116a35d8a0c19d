"""`dresslog info MODEL`: what a model folder holds, read from its verified card.

Public API
----------
``format_card(path, card, verified) -> str``
    Task and sizes, input normalisation, how it was trained (hyperparameters, data, the
    model it was fine-tuned from, the speeds and rotations of all its training trials as
    `eval` and `sweep` read them, the epochs run and the one kept), its recorded test
    metrics, the `dresslog train` line that trains it again, and the weights hash, and
    whether the model loads, as `dresslog info` prints
    it (``--json`` prints the card itself).
"""

from __future__ import annotations

from pathlib import Path

from dresslog.model.conditions import trained_conditions
from dresslog.model.files import ModelCard, TrainingFolder
from dresslog.model.recipe import train_command
from dresslog.spec import LimbRotation

#: How `info` names the spec fields `generate` can fix for every trial.
_FIXED = {"speed": "speed {:g} m/s", "duration": "{:g} s long"}


def _count(n: int, noun: str) -> str:
    """`1 epoch`, `2 epochs`: a one-epoch test model's card read `1 epochs`."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _conditions(folder: TrainingFolder) -> str:
    """A training folder's trials and what they had in common, on one line."""
    trials = f"{folder.trials} trials; " if folder.trials is not None else ""
    if folder.overrides is None:
        return f"{folder.folder}: {trials}conditions not recorded"
    said = []
    for field, value in folder.overrides.items():
        if field == "limb_rotation":
            rotation = LimbRotation.model_validate(value)
            said.append(f"rotation {rotation.axis} {rotation.degrees:+g} deg")
        else:
            said.append(_FIXED.get(field, f"{field} {{}}").format(value))
    if folder.rotation_range is not None:
        said.append(f"rotation {folder.rotation_range} drawn per trial")
    held = ", ".join(said) or "generate's defaults"
    return f"{folder.folder}: {trials}{held}"


def format_card(path: Path, card: ModelCard, verified: bool) -> str:
    """The human-readable form printed by `dresslog info` for a model folder."""
    hp, data = card.hyperparameters, card.data
    extras = [
        name
        for name, on in (
            ("phi and its change per step", hp.input_differences),
            ("normalised inputs", card.normalisation is not None),
            (f"force loss x{hp.force_scale:.3g}", hp.force_scale != 1.0),
            (f"{hp.window}-step crops", hp.window is not None),
            ("kept best epoch", hp.keep_best),
        )
        if on
    ]
    lines = [
        f"{path}  (dresslog model, format {card.format_version})",
        f"  task      {card.task.value}, {card.n_points} limb points",
        f"  network   {card.layers}x{card.hidden} LSTM on {card.input_dim}-D input"
        + (f"; {', '.join(extras)}" if extras else ""),
        f"  training  {_count(hp.epochs, 'epoch')}, batch {hp.batch_size}, {hp.optimizer} "
        f"lr {hp.lr:g} ({hp.lr_schedule}), seed {hp.seed}",
        f"  data      {data.n_train} training + {data.n_val} validation sequences"
        + (f" from {data.description}" if data.description else "")
        + (f", manifest {data.manifest_sha256[:12]}" if data.manifest_sha256 else ""),
    ]
    lines += [f"{'':12}{_conditions(folder)}" for folder in data.folders]
    if (init := card.init) is not None:
        scored = f", test ratio {init.test_ratio:.3f}" if init.test_ratio is not None else ""
        lines.append(
            f"  init      fine-tuned from {init.description or 'a model'} "
            f"(weights {init.weights_sha256[:12]}{scored})"
        )
        lines += [f"{'':12}{_conditions(folder)}" for folder in init.folders]
    assumed = any(folder.overrides is None for folder in card.trained_folders())
    lines.append(
        f"  trained   {trained_conditions(card).describe()}"
        + (" (generate's defaults taken where the card does not record them)" if assumed else "")
    )
    if card.history:
        last = card.history[-1]
        kept = card.metrics.get("kept_epoch", last.epoch)
        val = "" if last.val_loss is None else f", validation {last.val_loss:.4g}"
        seconds = sum(e.seconds for e in card.history)
        lines.append(
            f"  history   {_count(len(card.history), 'epoch')} in {seconds:.0f} s; last: "
            f"training loss {last.train_loss:.4g}{val}; kept epoch {kept:g}"
        )
    test = {k.removeprefix("test_"): v for k, v in card.metrics.items() if k.startswith("test_")}
    other = {k: v for k, v in card.metrics.items() if not k.startswith("test_")}
    for label, metrics in (("metrics", other), ("test", test)):  # one line each, readable
        if metrics:
            shown = ", ".join(f"{k} {v:.4g}" for k, v in metrics.items())
            lines.append(f"  {label:<8}  {shown}")
    lines.append(f"  again     {train_command(card, str(path))}")
    checked = "verified" if verified else "but the model does not load (the error says why)"
    lines.append(f"  weights   sha256 {card.weights_sha256[:16]}, {checked}")
    lines.append(f"  software  dresslog {card.dresslog_version}, created {card.created}")
    return "\n".join(lines)
