"""`train_dataset`: the paper's network trained on a dataset folder (`dresslog train`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from dresslog.dataset import Split, load_dataset, load_manifest
from dresslog.dataset.manifest import MIN_TRAIN
from dresslog.errors import DatasetError
from dresslog.experiments.evaluation import warn_no_force
from dresslog.io.files import check_name_fits, exclusive, printable, temporary_path
from dresslog.model.evaluate import evaluate
from dresslog.model.files import (
    TRAINING_PLOT,
    DataProvenance,
    EpochRecord,
    ModelCard,
    Normalisation,
    check_model_folder,
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
    hidden: int = 50,
    layers: int = 3,
    lr: float = 1e-3,
    normalise: bool = False,
    balance_loss: bool = False,
    keep_best: bool = False,
    lr_schedule: LrSchedule = "constant",
    input_differences: bool = False,
    window: int | None = None,
    seed: int = 0,
    overwrite: bool = False,
    workers: int | None = None,
    progress: bool = True,
    on_epoch: Callable[[EpochRecord], None] | None = None,
) -> ModelCard:
    """Train the paper's network (by default) on `data`'s training split; save to `out`."""
    out = Path(out)
    if out.name in ("", ".."):  # `-o .` or `-o ..`: name the folder, for the files beside it
        out = out.resolve()
    check_model_folder(out, overwrite)  # say so now, not after hours of training
    steps = [t.steps for t in load_manifest(data).trials if t.split is Split.TRAIN]
    if len(steps) < MIN_TRAIN:
        raise DatasetError(
            f"needs at least {MIN_TRAIN} training trials, has {len(steps)}", path=data
        )
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
        card = make_card(arrays.task, weights, history, data=provenance, metrics=metrics)
        card = save_model(
            out,
            weights,
            card,
            overwrite=overwrite,
            also=lambda folder, saved: plot_training(folder / TRAINING_PLOT, saved),
        )
        checkpoint.unlink(missing_ok=True)
    return card
