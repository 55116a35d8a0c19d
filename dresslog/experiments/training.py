"""`train_dataset`: the paper's network trained on a dataset folder (`dresslog train`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from dresslog.dataset import Split, load_dataset, load_manifest
from dresslog.dataset.manifest import MIN_TRAIN
from dresslog.errors import DatasetError, ModelError
from dresslog.experiments.evaluation import check_data_task, warn_no_force
from dresslog.io.files import check_name_fits, exclusive, printable, temporary_path
from dresslog.model.evaluate import evaluate
from dresslog.model.files import (
    TRAINING_PLOT,
    DataProvenance,
    EpochRecord,
    InitialModel,
    LoadedModel,
    ModelCard,
    Normalisation,
    check_model_folder,
    load_model,
    save_model,
)
from dresslog.model.numpy_lstm import NumpyEstimator
from dresslog.model.options import VAL_FRACTION, LrSchedule, check_options, held_out
from dresslog.plots import plot_training


def train_dataset(
    data: str | Path,
    out: str | Path,
    *,
    epochs: int = 10,
    batch_size: int = 16,
    hidden: int | None = None,
    layers: int | None = None,
    lr: float = 1e-3,
    normalise: bool = False,
    balance_loss: bool = False,
    keep_best: bool = False,
    lr_schedule: LrSchedule = "constant",
    input_differences: bool = False,
    window: int | None = None,
    seed: int = 0,
    init: str | Path | None = None,
    overwrite: bool = False,
    workers: int | None = None,
    progress: bool = True,
    on_epoch: Callable[[EpochRecord], None] | None = None,
) -> ModelCard:
    """Train the paper's network (by default: 3 layers of 50 cells) on `data`'s training
    split; save to `out`.

    `init` names a model to start from (fine-tuning, e.g. on trials of a raised forearm):
    its network, input standardisation and signal differences are kept, so `hidden`,
    `layers`, `normalise` and `input_differences` may only repeat its own; the card
    names it under `init`.
    """
    out = Path(out)
    if out.name in ("", ".."):  # `-o .` or `-o ..`: name the folder, for the files beside it
        out = out.resolve()
    check_model_folder(out, overwrite)  # say so now, not after hours of training
    manifest = load_manifest(data)
    start = None
    if init is not None:
        start = load_model(init)
        check_data_task(start, manifest.task)
        hidden, layers, normalise, input_differences = _as_initial(
            start, hidden, layers, normalise, input_differences
        )
    steps = [t.steps for t in manifest.trials if t.split is Split.TRAIN]
    if len(steps) < MIN_TRAIN:
        raise DatasetError(
            f"needs at least {MIN_TRAIN} training trials, has {len(steps)}", path=data
        )
    hidden, layers = hidden or 50, layers or 3
    check_options(  # from the manifest: a bad option fails before minutes of decoding
        steps, held_out(len(steps), VAL_FRACTION), epochs=epochs, batch_size=batch_size,
        hidden=hidden, layers=layers, lr=lr, window=window, keep_best=keep_best,
        lr_schedule=lr_schedule,
    )  # fmt: skip
    checkpoint = out.with_name(f".{out.name}.checkpoint.safetensors")
    check_name_fits(out, temporary_path(checkpoint).name)  # the longest name beside it
    out.parent.mkdir(parents=True, exist_ok=True)  # the checkpoint and the lock go beside it
    # a second run on the same output would share (and garble) the checkpoint
    with exclusive(out.with_name(f".{out.name}.train.lock"), "dresslog train", out):
        arrays = load_dataset(data, workers=workers, progress=progress)
        if start is not None:
            check_data_task(start, arrays.task, arrays.forces[0].shape[-1])
        rows = arrays.rows(Split.TRAIN)
        if not any(arrays.forces[row].any() for row in rows):  # trials too short to touch
            warn_no_force(
                data,
                f"training sequence (outcomes: "
                f"{', '.join(sorted(set(arrays.outcomes[rows].tolist())))})",
                "the model can only learn to estimate none",
                "generate longer trials (--duration)",
            )
        from dresslog.model.train import make_card, train  # torch once the data checks out

        weights, history = train(
            arrays.sequences(rows),
            arrays.force_maps(rows),
            epochs=epochs,
            batch_size=batch_size,
            lr=lr,
            hidden=hidden,
            layers=layers,
            seed=seed,
            window=window,
            normalise=normalise,
            balance_loss=balance_loss,
            keep_best=keep_best,
            lr_schedule=lr_schedule,
            input_differences=input_differences,
            init=None if start is None else start.weights,
            progress=progress,
            checkpoint=checkpoint,
            restart_other=overwrite,  # an interrupted run of these options still resumes
            on_epoch=on_epoch,
        )
        metrics: dict[str, float] = {}
        test = arrays.rows(Split.TEST)
        if len(test):
            scores = evaluate(
                NumpyEstimator(weights), arrays.sequences(test), arrays.force_maps(test)
            )
            metrics = {f"test_{k}": v for k, v in scores.as_metrics().items()}
        signal = np.concatenate(arrays.sequences(rows))
        provenance = DataProvenance(
            manifest_sha256=arrays.manifest_sha256,
            description=printable(data),
            signal=Normalisation(mean=signal.mean(0).tolist(), std=signal.std(0).tolist()),
        )
        card = make_card(
            arrays.task,
            weights,
            history,
            data=provenance,
            init=None if start is None else _initial_model(start),
            metrics=metrics,
        )
        card = save_model(
            out,
            weights,
            card,
            overwrite=overwrite,
            also=lambda folder, saved: plot_training(folder / TRAINING_PLOT, saved),
        )
        checkpoint.unlink(missing_ok=True)
    return card


def _as_initial(
    start: LoadedModel,
    hidden: int | None,
    layers: int | None,
    normalise: bool,
    input_differences: bool,
) -> tuple[int, int, bool, bool]:
    """The network options of a run that starts from `start`: its own, which an option
    may repeat but not change (an option left out, None or False, takes the model's)."""
    card = start.card
    standardised, differences = (
        card.normalisation is not None,
        card.hyperparameters.input_differences,
    )
    kept = (card.hidden, card.layers, standardised, differences)
    names = ("--hidden", "--layers", "--normalise", "--input-differences")
    given = (hidden, layers, normalise, input_differences)
    for name, asked, have in zip(names, given, kept, strict=True):
        if asked not in (None, False, have):
            network = f"{card.layers}x{card.hidden} LSTM" + "".join(
                f", {what}"
                for what, on in (
                    ("standardised inputs", standardised),
                    ("the signal's change", differences),
                )
                if on
            )
            shown = name if asked is True else f"{name} {asked}"
            raise ModelError(
                f"{shown} would change the initial model's network ({network}), which "
                f"fine-tuning keeps; leave {name} out",
                path=start.path,
            )
    return card.hidden, card.layers, standardised, differences


def _initial_model(start: LoadedModel) -> InitialModel:
    card = start.card
    return InitialModel(
        description=printable(start.path),
        weights_sha256=card.weights_sha256,
        manifest_sha256=card.data.manifest_sha256,
        test_ratio=card.metrics.get("test_ratio"),
    )
