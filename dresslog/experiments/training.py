"""`train_dataset`: the paper's network trained on a dataset folder (`dresslog train`)."""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from dresslog.dataset import DatasetArrays, Split, load_dataset, load_manifest
from dresslog.dataset.manifest import MIN_TRAIN
from dresslog.errors import DatasetError, ModelError
from dresslog.experiments.evaluation import check_data_task, warn_no_force
from dresslog.experiments.plots import plot_training
from dresslog.folders import MANIFEST_FILE, TRAINING_PLOT
from dresslog.io.files import check_name_fits, exclusive, printable, temporary_path
from dresslog.model.evaluate import score_sequences
from dresslog.model.files import (
    DataProvenance,
    EpochRecord,
    InitialModel,
    LoadedModel,
    ModelCard,
    Normalisation,
    TrainingFolder,
    check_model_folder,
    load_model,
    save_model,
)
from dresslog.model.numpy_lstm import NumpyEstimator
from dresslog.model.options import PAPER, TrainOptions, check_options, held_out
from dresslog.spec import Task


def train_dataset(
    data: str | Path | Sequence[str | Path],
    out: str | Path,
    options: TrainOptions = PAPER,
    *,
    init: str | Path | None = None,
    overwrite: bool = False,
    workers: int | None = None,
    progress: bool = True,
    on_epoch: Callable[[EpochRecord], None] | None = None,
) -> ModelCard:
    """Train the paper's network (by default: 3 layers of 50 cells) on `data`'s training
    split; save it to `out`, scored on the test split.

    Several dataset folders of one task pool their training splits (the validation
    sequences drawn from all), and their test splits for the card's scores.
    Fine-tuning (`init`, e.g. on trials of a forearm turned aside, beside in-range ones so
    that it does not forget them) keeps the initial model's network, input
    standardisation and signal differences: `options` may only repeat them.

    Args:
        data: the dataset folder, or several of one task.
        out: the model folder to write.
        options: every setting of the run; by default the paper's.
        init: a model to start from; the card names it under `init`.
        overwrite: replace an existing model folder (an interrupted run of these
            options still resumes; one of other options is discarded).
        workers: processes decoding the trials; None: one per core.
        progress: show progress bars.
        on_epoch: called with each epoch's record as it ends.

    Returns:
        The saved model's card.

    Raises:
        DatasetError: a folder that is no dataset, is given twice, holds another task or
            too few training trials.
        ModelError: an output that may not become a model folder, `init` that is no model
            or of another task, options that would change its network, settings the
            data make meaningless, a diverged run.
    """
    out = Path(out)
    if out.name in ("", ".."):  # `-o .` or `-o ..`: name the folder, for the files beside it
        out = out.resolve()
    check_model_folder(out, overwrite)  # say so now, not after hours of training
    folders = _folders(data)
    named = " + ".join(printable(f) for f in folders)
    manifests = [load_manifest(f) for f in folders]
    task = _one_task(folders, [m.task for m in manifests])
    start = None
    if init is not None:
        if (Path(init) / MANIFEST_FILE).is_file():  # read_card's hint is for eval's order
            raise ModelError(
                "is a dataset folder, not a model: --init takes the model to start from; "
                "give the dataset folders as DATA",
                path=init,
            )
        start = load_model(init)
        check_data_task(start, task)
        options = _as_initial(start, options)
    steps = [t.steps for m in manifests for t in m.trials if t.split is Split.TRAIN]
    if len(steps) < MIN_TRAIN:
        raise DatasetError(
            f"needs at least {MIN_TRAIN} training trials, has {len(steps)}",
            path=folders[0] if len(folders) == 1 else named,
        )
    # from the manifest: a bad option fails before minutes of decoding
    check_options(steps, held_out(len(steps), options.val_fraction), options)
    checkpoint = out.with_name(f".{out.name}.checkpoint.safetensors")
    check_name_fits(out, temporary_path(checkpoint).name)  # the longest name beside it
    out.parent.mkdir(parents=True, exist_ok=True)  # the checkpoint and the lock go beside it
    # a second run on the same output would share (and garble) the checkpoint
    with exclusive(out.with_name(f".{out.name}.train.lock"), "dresslog train", out):
        pooled = [load_dataset(f, workers=workers, progress=progress) for f in folders]
        if start is not None:
            check_data_task(start, task, pooled[0].n_points)
        sequences, forces, outcomes = _split_of(pooled, Split.TRAIN)
        if not any(f.any() for f in forces):  # trials too short to touch
            warn_no_force(
                named,
                f"training sequence (outcomes: {', '.join(sorted(set(outcomes)))})",
                "the model can only learn to estimate none",
                "generate longer trials (--duration)",
            )
        # torch's OpenMP threads spinning while they wait took the cores a job beside the
        # training needs (a generation, the tests): it ran ten times slower. Waiting
        # passively costs nothing alone; read when torch loads, so set before; a user's
        # own setting wins.
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
        from dresslog.model.train import make_card, train  # torch once the data checks out

        weights, history = train(
            sequences,
            forces,
            options,
            init=None if start is None else start.weights,
            progress=progress,
            checkpoint=checkpoint,
            restart_other=overwrite,  # an interrupted run of these options still resumes
            on_epoch=on_epoch,
        )
        metrics: dict[str, float] = {}
        test, test_forces, _ = _split_of(pooled, Split.TEST)
        if test:
            scores = score_sequences(NumpyEstimator(weights), test, test_forces).scores()
            metrics = {f"test_{k}": v for k, v in scores.as_metrics().items()}
        hashes = [arrays.manifest_sha256 for arrays in pooled]
        provenance = DataProvenance(
            manifest_sha256=hashes[0] if len(hashes) == 1 else _pooled_hash(hashes),
            description=named,
            signal=_seen_signal(sequences, None if start is None else start.card.data),
            folders=[
                TrainingFolder(
                    folder=printable(folder),
                    trials=len(manifest.split(Split.TRAIN)),
                    overrides=manifest.overrides,
                    rotation_range=manifest.rotation_range,
                )
                for folder, manifest in zip(folders, manifests, strict=True)
            ],
        )
        card = make_card(
            task,
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


def _folders(data: str | Path | Sequence[str | Path]) -> list[Path]:
    """The dataset folders `data` names: one, or several, each once."""
    folders = [Path(data)] if isinstance(data, str | Path) else [Path(f) for f in data]
    if not folders:
        raise DatasetError("no dataset folder given")
    seen: set[Path] = set()
    for folder in folders:
        if (same := folder.resolve()) in seen:
            raise DatasetError("is given twice; give each dataset folder once", path=folder)
        seen.add(same)
    return folders


def _one_task(folders: Sequence[Path], tasks: Sequence[Task]) -> Task:
    """The task every folder's manifest records; a folder of another one is refused."""
    for folder, task in zip(folders[1:], tasks[1:], strict=True):
        if task != tasks[0]:
            raise DatasetError(
                f"holds {task} trials but {printable(folders[0])} holds {tasks[0]}; "
                "a model is trained for one task",
                path=folder,
            )
    return tasks[0]


def _split_of(
    pooled: Sequence[DatasetArrays], split: Split
) -> tuple[list[np.ndarray], list[np.ndarray], list[str]]:
    """Every folder's `split`: phi, force maps and outcomes, folder after folder."""
    sequences, forces, outcomes = [], [], []
    for arrays in pooled:
        rows = arrays.rows(split)
        sequences += arrays.sequences(rows)
        forces += arrays.force_maps(rows)
        outcomes += arrays.outcomes[rows].tolist()
    return sequences, forces, outcomes


def _pooled_hash(hashes: Sequence[str]) -> str:
    """Several folders' content hashes as one, in the order given (which draws the
    validation sequences): what the card names pooled data by."""
    return hashlib.sha256(" ".join(hashes).encode()).hexdigest()


def _as_initial(start: LoadedModel, options: TrainOptions) -> TrainOptions:
    """The options of a run that starts from `start`, with its network: its own, which an
    option may repeat but not change (one left out, None or False, takes the model's)."""
    card = start.card
    standardised, differences = (
        card.normalisation is not None,
        card.hyperparameters.input_differences,
    )
    kept = (card.hidden, card.layers, standardised, differences)
    names = ("--hidden", "--layers", "--normalise", "--input-differences")
    given = (options.hidden, options.layers, options.normalise, options.input_differences)
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
    fields = ("hidden", "layers", "normalise", "input_differences")
    return options.model_copy(update=dict(zip(fields, kept, strict=True)))


def _seen_signal(sequences: Sequence[np.ndarray], before: DataProvenance | None) -> Normalisation:
    """The training signal's per-channel mean and std, which `infer` calls a trial unlike
    the training data by. A fine-tuned model has learnt from its initial model's sequences
    too (`before`): the two sets' mixture, weighted by their sequence counts."""
    signal = np.concatenate(sequences)
    mean, var = signal.mean(0), signal.var(0)
    if before is not None and before.signal is not None:
        share = (before.n_train + before.n_val) / (before.n_train + before.n_val + len(sequences))
        old_mean, old_var = np.array(before.signal.mean), np.array(before.signal.std) ** 2
        mixed = share * old_mean + (1 - share) * mean
        var = share * (old_var + old_mean**2) + (1 - share) * (var + mean**2) - mixed**2
        mean = mixed
    return Normalisation(mean=mean.tolist(), std=np.sqrt(np.maximum(var, 0)).tolist())


def _initial_model(start: LoadedModel) -> InitialModel:
    card = start.card
    return InitialModel(
        description=printable(start.path),
        weights_sha256=card.weights_sha256,
        manifest_sha256=card.data.manifest_sha256,
        test_ratio=card.metrics.get("test_ratio"),
        folders=card.trained_folders(),
    )
