"""Model folders: `model.safetensors` (weights) + `card.json` (what they are); safe to load.

A model is a folder, conventionally ``models/<task>/``. Loading never unpickles
(safetensors holds raw arrays only), checks the weights file against the sha256 in the
card and every array against the shapes the card promises, and imports no torch.

Public API
----------
``ModelCard`` (pydantic): ``format`` ("dresslog-model"), ``format_version``, ``task``,
    ``n_points``, ``hidden``, ``layers``, ``input_dim``, ``normalisation``
    (``Normalisation(mean, std)`` or None for identity), ``hyperparameters``
    (``Hyperparameters``), ``data`` (``DataProvenance``: manifest sha256, sequence counts),
    ``init`` (``InitialModel``: the model a fine-tuned one started from, or None),
    ``metrics`` (name -> float: "train_loss", "val_loss", "test_rmse", "test_ratio", ...),
    ``history`` (one ``EpochRecord(epoch, train_loss, val_loss, seconds)`` per epoch
    trained; empty in cards written before dresslog kept it), ``weights_sha256``,
    ``dresslog_version``, ``created``.
``save_model(path, weights, card, *, overwrite=False, also=None) -> ModelCard``
    Writes both files into a temporary sibling folder, then renames it into place, so an
    interrupted save never leaves a half model (where the folder cannot be swapped, a
    symbolic link, a mount point, the working folder: file by file from a temporary
    inside it, the card last). Fills ``weights_sha256``; returns that card. ``also(folder,
    card)`` writes more into the folder before it is put in place (``training.png``).
``check_model_folder(path, overwrite)``: ``ModelError`` unless ``path`` may become a model
    folder (new, empty, or a model to replace with ``overwrite``; not named as a recording,
    ``.mcap``, ``.rrd``, ``.bag`` or ``.db3``).
``read_card(path) -> ModelCard``: the card alone, unverified (what ``info`` shows of a
    model that does not load).
``load_model(path) -> LoadedModel``: ``.path``, ``.card``, ``.weights`` (dict of float32
    numpy arrays), ``.estimator() -> NumpyEstimator``, ``.describe()`` (the model in a
    line: where, its network, its test ratio). Raises ``ModelError`` (one line,
    ``.path`` set) for a missing folder or file, a foreign or unreadable card, weights whose
    hash differs from the card (tampered or replaced), and missing or mis-shaped arrays.
``check_task(model, task, n_points=None, *, subject="trial", hint=...)``: ``ModelError``
    when the model was trained for another task (or, given ``n_points``, for another
    number of limb points), worded for the trial or data it was to run on.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Final, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from dresslog import __version__
from dresslog.errors import ModelError, first_problem
from dresslog.folders import CARD_FILE, MANIFEST_FILE, MODEL_FILES, WEIGHTS_FILE
from dresslog.io import jsontext
from dresslog.io.files import (
    check_writable,
    discard_stale_temporaries,
    is_temporary,
    named_as_recording,
    no_such,
    printable,
    sha256_file,
    temporary_path,
)
from dresslog.model.inputs import PHI_DIM, unfamiliar
from dresslog.model.numpy_lstm import NumpyEstimator, expected_shapes
from dresslog.model.options import LrSchedule
from dresslog.spec import RotationRange, Task, TrialSpec, task_of

FORMAT: Final = "dresslog-model"
#: 2 added `data.signal`, 3 `init`, 4 `data.folders` and `init.folders`; a card of a
#: newer version than this is refused as such, before the fields this dresslog does not
#: know would be.
FORMAT_VERSION = 4


class Normalisation(BaseModel):
    """Per-channel input standardisation, (phi - mean) / std; the paper used none."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    mean: list[float] = Field(min_length=9, max_length=18)
    std: list[float] = Field(min_length=9, max_length=18)


class Hyperparameters(BaseModel):
    """How the weights were trained (defaults: the paper's)."""

    model_config = ConfigDict(extra="forbid")
    epochs: int = 10
    batch_size: int = 16
    lr: float = 1e-3
    optimizer: str = "rmsprop"
    loss: str = "mse[force, contact]"
    seed: int = 0
    window: int | None = None
    val_fraction: float = 0.1
    #: force targets were multiplied by this in the loss (1 = the paper), folded back
    #: into the head afterwards, so outputs are in newtons either way
    force_scale: float = 1.0
    #: the weights are those of the epoch with the lowest validation loss, not the last
    keep_best: bool = False
    #: "cosine": the learning rate of epoch e is lr (1 + cos(pi e / epochs)) / 2
    lr_schedule: LrSchedule = "constant"
    #: the network reads phi's change since the last step too (`dresslog.model.inputs`)
    input_differences: bool = False


class TrainingFolder(BaseModel):
    """One dataset folder a model was trained on, with what its manifest gave every trial:
    the conditions the model has seen, which `sweep` marks on its plot and `info` prints."""

    model_config = ConfigDict(extra="forbid")
    folder: str
    #: the folder's training trials (validation ones among them)
    trials: int | None = Field(None, ge=0)
    #: spec fields fixed for every trial (`generate --speed`, `--rotation`, `--duration`);
    #: None: not known (a model whose card, older than format 4, does not say)
    overrides: dict[str, Any] | None = None
    #: limb rotation drawn per trial (`generate --rotation-range`)
    rotation_range: RotationRange | None = None


class DataProvenance(BaseModel):
    """Which data trained the model: enough to tell two models' training sets apart."""

    model_config = ConfigDict(extra="forbid")
    #: the manifest's content hash (`info DATA` prints it as content sha256): what the
    #: trials are, not the bytes of manifest.json
    manifest_sha256: str | None = None
    n_train: int = 0
    n_val: int = 0
    description: str = ""
    #: the training sequences' 9-D signal, per channel: what `infer` tells a trial far
    #: from the training data by (a model without input standardisation has no other);
    #: a fine-tuned model's covers its initial model's training sequences too
    signal: Normalisation | None = None
    #: each folder and its conditions (none on cards before format 4)
    folders: list[TrainingFolder] = Field(default_factory=list)


class InitialModel(BaseModel):
    """The model a fine-tuned one started from (`train --init`): which weights, trained on
    which data, and how it scored, so a card tells what the fine-tuning added."""

    model_config = ConfigDict(extra="forbid")
    description: str = ""
    weights_sha256: str
    manifest_sha256: str | None = None
    test_ratio: float | None = None
    #: its `ModelCard.trained_folders` (none on cards before format 4)
    folders: list[TrainingFolder] = Field(default_factory=list)


class EpochRecord(BaseModel):
    """One training epoch: mean training loss, validation loss (None without a held-out set)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    epoch: int = Field(ge=1)
    train_loss: float
    val_loss: float | None = None
    seconds: float = Field(ge=0)


class ModelCard(BaseModel):
    """What a weights file is: task, sizes, normalisation, training, data, metrics, hash."""

    model_config = ConfigDict(extra="forbid")
    format: Literal["dresslog-model"] = FORMAT
    format_version: int = FORMAT_VERSION
    task: Task
    n_points: int = Field(gt=0)
    hidden: int = Field(50, gt=0)
    layers: int = Field(3, gt=0)
    input_dim: int = 9
    normalisation: Normalisation | None = None
    hyperparameters: Hyperparameters = Field(default_factory=Hyperparameters)
    data: DataProvenance = Field(default_factory=DataProvenance)
    #: the model whose weights training started from, or None: from random weights
    init: InitialModel | None = None
    metrics: dict[str, float] = Field(default_factory=dict)
    #: the learning curve of the run that made the weights, so it travels with them
    history: list[EpochRecord] = Field(default_factory=list)
    weights_sha256: str = ""
    dresslog_version: str = __version__
    created: str = Field(default_factory=lambda: datetime.now(UTC).isoformat(timespec="seconds"))

    @model_validator(mode="before")
    @classmethod
    def _not_newer(cls, data: Any) -> Any:
        """A newer dresslog's card may hold fields this one lacks: name the version first."""
        version = data.get("format_version") if isinstance(data, dict) else None
        if isinstance(version, int) and version > FORMAT_VERSION:
            raise ValueError(
                f"format version {version} is newer than this dresslog reads "
                f"({FORMAT_VERSION}); upgrade dresslog"
            )
        return data

    @model_validator(mode="after")
    def _supported(self) -> ModelCard:
        width = 2 * PHI_DIM if self.hyperparameters.input_differences else PHI_DIM
        if self.input_dim != width:
            raise ValueError(f"input_dim {self.input_dim} for a network that reads {width}")
        norm = self.normalisation
        if norm is not None and not len(norm.mean) == len(norm.std) == width:
            raise ValueError(f"normalisation is not {width}-D")
        for folder in self.trained_folders():  # what `sweep` and `info` read them as
            if folder.overrides is not None:
                try:
                    TrialSpec.model_validate({"task": self.task, **folder.overrides})
                except ValidationError as err:
                    raise ValueError(
                        f"{folder.folder}'s fixed spec fields: {first_problem(err)}"
                    ) from None
        return self

    def trained_folders(self) -> list[TrainingFolder]:
        """Every folder the weights have seen, the initial model's after this run's; a
        card before format 4 gives its data as one folder of conditions not known."""
        folders = self.data.folders or [
            TrainingFolder(folder=self.data.description, trials=self.data.n_train + self.data.n_val)
        ]
        if (init := self.init) is not None:
            unknown = TrainingFolder(folder=f"the data of {init.description or 'a model'}")
            folders = folders + (init.folders or [unknown])
        return folders


@dataclass(frozen=True)
class LoadedModel:
    """A verified model: its card and float32 weights, ready for numpy inference."""

    path: Path
    card: ModelCard
    weights: dict[str, np.ndarray]

    def estimator(self) -> NumpyEstimator:
        """A fresh stateful estimator (each caller gets its own recurrent state)."""
        return NumpyEstimator(self.weights)

    def unfamiliar(self, phi: np.ndarray, *, simulated: bool = False) -> str | None:
        """Why the signal (T, 9) is far from this model's training data; None if it is not
        (or if the card records neither the training signal nor a standardisation of it).
        A `simulated` trial's cause is named as the model's training, not the recording."""
        stats = self.card.data.signal or self.card.normalisation
        if stats is None:
            return None
        return unfamiliar(phi, np.array(stats.mean), np.array(stats.std), simulated=simulated)

    def describe(self) -> str:
        """Which model, in a line: where it is, its network and its recorded test ratio."""
        card = self.card
        ratio = card.metrics.get("test_ratio")
        scored = f", test ratio {ratio:.3f}" if ratio is not None else ""
        return f"{printable(str(self.path))} ({card.layers}x{card.hidden} LSTM{scored})"


def _check_shapes(path: Path, weights: Mapping[str, np.ndarray], card: ModelCard) -> None:
    expected = expected_shapes(card.n_points, card.hidden, card.layers, card.input_dim)
    for name, shape in expected.items():
        if name not in weights:
            raise ModelError(f"weights lack {name}; not a force-map LSTM", path=path)
        got = tuple(weights[name].shape)
        if got != shape:
            raise ModelError(
                f"{name} has shape {got} but the card ({card.n_points} limb points, "
                f"hidden {card.hidden}, {card.layers} layers) needs {shape}",
                path=path,
            )
    extra = sorted(set(weights) - set(expected))
    if extra:
        raise ModelError(f"unexpected arrays in weights: {', '.join(extra)}", path=path)


def _check_finite(path: Path, weights: Mapping[str, np.ndarray]) -> None:
    """Refuse weights holding NaN or infinity (a training run that diverged, a damaged
    file whose card was re-hashed): every estimate would be NaN, scored as `RMSE nan`."""
    for name in sorted(weights):
        if (bad := int(np.count_nonzero(~np.isfinite(weights[name])))) > 0:
            raise ModelError(
                f"{WEIGHTS_FILE}: {name} holds {bad} NaN or infinite value"
                f"{'s' if bad > 1 else ''} (of {weights[name].size}); the weights are corrupt, "
                "retrain the model or restore its folder",
                path=path,
            )


def check_model_folder(path: str | Path, overwrite: bool) -> None:
    """Fail before any work unless `path` may become a model folder (its missing parent
    folders are made when it is saved).

    --overwrite replaces a model, never anything else: a dataset or any other folder
    given as the output by mistake is refused, with or without it.

    Raises:
        ModelError: `path` is named as a recording, is a file or a dangling link, lies
            under a file, or is a folder that is neither empty nor a model; a model
            without `overwrite`, or one holding other files too.
    """
    path = Path(path)
    if (misnamed := named_as_recording(path, "a model")) is not None:  # before anything is made
        raise ModelError(misnamed, path=path)
    made = next(p for p in (path.parent, *path.parent.parents) if p.exists())  # the rest is made
    if not made.is_dir():
        raise ModelError(f"{made} is a file, not a folder", path=path)
    check_writable(made)
    if path.exists() and not path.is_dir():
        raise ModelError("is a file; give a folder for the model", path=path)
    if path.is_symlink() and not path.exists():  # else found out after the training
        raise ModelError(
            "is a symbolic link to nothing; create its folder or give another", path=path
        )
    if not path.exists() or not any(path.iterdir()):
        return
    if not (path / CARD_FILE).is_file():
        raise ModelError(
            "folder is not empty and holds no model; give a new or empty folder", path=path
        )
    if not overwrite:
        raise ModelError("model folder exists; pass --overwrite to replace it", path=path)
    if others := sorted(  # a killed save's temporary is no foreign file
        p.name for p in path.iterdir() if p.name not in MODEL_FILES and not is_temporary(p.name)
    ):
        raise ModelError(
            f"model folder also holds {', '.join(others[:3])}, which replacing the model "
            "would delete; move that out or give another folder",
            path=path,
        )


def save_model(
    path: str | Path,
    weights: Mapping[str, np.ndarray],
    card: ModelCard,
    *,
    overwrite: bool = False,
    also: Callable[[Path, ModelCard], None] | None = None,
) -> ModelCard:
    """Write a model folder atomically.

    A run stopped at any moment leaves the old folder or the whole new one; where the
    folder is replaced file by file (`_replaced_in_place`), the card goes last, so a
    stop between the files leaves weights that its hash check refuses.

    Args:
        path: the model folder.
        weights: the float32 arrays, as `train` returns them.
        card: what the weights are; its ``weights_sha256`` is filled in here.
        overwrite: replace an existing model folder.
        also: ``also(folder, card)`` writes more into the folder (the learning curve)
            before it is put in place.

    Returns:
        The card as written, with the weights' hash.

    Raises:
        ModelError: `path` may not become a model folder (`check_model_folder`).
    """
    from safetensors.numpy import save

    path = Path(path)
    check_model_folder(path, overwrite)
    arrays = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in weights.items()}
    _check_shapes(path, arrays, card)
    path.parent.mkdir(parents=True, exist_ok=True)  # `-o models/gown` on a fresh checkout
    in_place = path.exists() and _replaced_in_place(path)
    # a folder behind a link or on a mount point may be another file system: beside its
    # files, not beside it, for each rename to stay on it
    beside = path / "model" if in_place else path
    discard_stale_temporaries(beside)  # a killed save's
    tmp = temporary_path(beside)
    tmp.mkdir()
    try:
        # written by Python, so the file gets the usual permissions (safetensors' own is 0600)
        (tmp / WEIGHTS_FILE).write_bytes(save(arrays, metadata={"format": FORMAT}))
        card = card.model_copy(update={"weights_sha256": sha256_file(tmp / WEIGHTS_FILE)})
        (tmp / CARD_FILE).write_text(card.model_dump_json(indent=2) + "\n")
        if also is not None:
            also(tmp, card)
        if not path.exists():
            tmp.rename(path)
        elif in_place:
            for name in sorted(MODEL_FILES, key=lambda n: n == CARD_FILE):
                if (tmp / name).exists():  # the card last: until then, the old one stands
                    (tmp / name).replace(path / name)  # and names the old weights' hash
                else:
                    (path / name).unlink(missing_ok=True)
        else:
            old = path.with_name(f".{path.name}.{os.getpid()}.old")
            path.rename(old)
            tmp.rename(path)
            shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return card


def _replaced_in_place(path: Path) -> bool:
    """Whether a model folder's files are replaced one by one, not the folder swapped:
    `-o .` (a swap would leave the shell in a deleted folder), a mount point (which
    cannot be renamed: a Docker volume) and a symbolic link (a swap replaced the link
    with a folder and left the old one as a hidden link)."""
    if path.is_symlink() or os.path.ismount(path):
        return True
    try:
        return Path.cwd().resolve().is_relative_to(path.resolve())
    except OSError:  # the working folder is gone already
        return False


def read_card(path: str | Path) -> ModelCard:
    """The folder's card, checked to be ours and valid; the weights are not looked at.

    Raises:
        ModelError: no card (with a hint when `path` is a dataset), or one that is
            unreadable, foreign, newer than this dresslog or invalid.
    """
    path = Path(path)
    card_path = path / CARD_FILE
    if not card_path.is_file():
        what = "not a dresslog model folder"
        if (path / MANIFEST_FILE).is_file():  # `eval DATA MODEL`, the two swapped
            what = "a dataset folder, not a model (`eval` and `sweep` take the model first)"
        raise ModelError(f"no {CARD_FILE}; {what}", path=path)
    try:
        raw = jsontext.loads(card_path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:  # unreadable, not UTF-8, not JSON, nested past reading
        raise ModelError(f"{CARD_FILE} is not readable JSON: {err}", path=path) from None
    if not isinstance(raw, dict) or raw.get("format") != FORMAT:
        raise ModelError(f"{CARD_FILE} is not a dresslog model card", path=path)
    try:
        return ModelCard.model_validate(raw)
    except ValidationError as err:
        raise ModelError(f"{CARD_FILE}: {first_problem(err, 'card')}", path=path) from None


def load_model(path: str | Path) -> LoadedModel:
    """Load and verify a model folder.

    Args:
        path: the model folder.

    Returns:
        Its card and weights, checked against each other.

    Raises:
        ModelError: one line, ``.path`` set, for a missing folder or file, a foreign or
            unreadable card, weights whose hash differs from the card's, and missing,
            mis-shaped or non-finite arrays.
    """
    from safetensors import SafetensorError
    from safetensors.numpy import load_file

    path = Path(path)
    if not path.exists():
        raise ModelError(no_such(path, "model folder"), path=path)
    if not path.is_dir():
        hint = f": give {path.parent}" if path.name in (CARD_FILE, WEIGHTS_FILE) else ""
        raise ModelError(
            f"a model is a folder with {WEIGHTS_FILE} and {CARD_FILE}{hint}", path=path
        )
    card = read_card(path)
    weights_path = path / WEIGHTS_FILE
    if not weights_path.is_file():
        raise ModelError(f"no {WEIGHTS_FILE}", path=path)
    if sha256_file(weights_path) != card.weights_sha256:
        raise ModelError(
            f"{WEIGHTS_FILE} does not match the sha256 in {CARD_FILE} (modified or replaced)",
            path=path,
        )
    try:
        weights = load_file(str(weights_path))
    except (SafetensorError, OSError, ValueError) as err:
        raise ModelError(f"{WEIGHTS_FILE} is unreadable: {err}", path=path) from None
    _check_shapes(path, weights, card)
    weights = {k: np.asarray(v, dtype=np.float32) for k, v in weights.items()}
    _check_finite(path, weights)
    norm = card.normalisation
    stats = (
        np.array([norm.mean, norm.std], np.float32)
        if norm is not None
        else np.array([np.zeros(card.input_dim), np.ones(card.input_dim)], np.float32)
    )
    if not np.allclose(stats, [weights["input_mean"], weights["input_std"]], rtol=1e-6):
        raise ModelError(f"input normalisation in {CARD_FILE} differs from the weights", path=path)
    return LoadedModel(path=path, card=card, weights=weights)


def check_task(
    model: LoadedModel,
    task: Task | str,
    n_points: int | None = None,
    *,
    subject: str = "trial",
    hint: str = "give a {task} model",
) -> None:
    """Refuse to run a model on a `subject` (trial, data) of another task.

    Args:
        model: the loaded model.
        task: the subject's task.
        n_points: the subject's limb points; None: not checked.
        subject: what the model was to run on, as the message names it.
        hint: what to do instead, formatted with the subject's task: the command's own
            way to name a model (``infer``'s --model, ``eval``'s MODEL argument).

    Raises:
        ModelError: the model is for another task or number of limb points.
    """
    task = task_of(task, ModelError)
    if model.card.task != task:
        raise ModelError(
            f"model is for {model.card.task} but the {subject} is {task}; "
            + hint.format(task=task),
            path=model.path,
        )
    if n_points is not None and n_points != model.card.n_points:
        raise ModelError(
            f"model has {model.card.n_points} limb points but the {subject} has {n_points}",
            path=model.path,
        )
