"""The paper's experiments on dataset folders: train a model, evaluate it, sweep it (Sec. V).

This is the glue between `dresslog.dataset` (folders, manifests, cached arrays) and
`dresslog.model` (network, training, metrics), so that the CLI commands and a Python
user make the same one call. Simulation and decoding run in spawned worker processes:
call these from under ``if __name__ == "__main__":`` in a script.

Public API
----------
``train_dataset(data, out, *, epochs=10, batch_size=16, hidden=50, layers=3, lr=1e-3,
normalise=False, balance_loss=False, keep_best=False, lr_schedule="constant",
input_differences=False, window=None, seed=0, overwrite=False, workers=None, progress=True,
on_epoch=None) -> ModelCard``
    Trains on the training split (holding out a tenth of it, `dresslog.model.train`'s
    ``val_fraction``, for the per-epoch validation loss), scores the test split, and
    saves a model folder whose card names the data by its manifest hash and keeps the
    per-epoch losses, with their plot (``training.png``). Resumes from
    ``.<out>.checkpoint.safetensors`` beside `out`.
``evaluate_dataset(model, data, *, split="test", bounds=False, workers=None, progress=True)
-> EvalReport``
    RMSE after Eq. 2, the all-zero baseline and their ratio, overall and per outcome,
    with contact-map precision and recall; with ``bounds``, the oracle ratios too.
``dataset_bounds(data, *, split="test", workers=None) -> dict[str, float]``
    Those oracle ratios alone (`dresslog.model.bounds`): how low the data let any model go.
``sweep(model, out, *, speeds=(), rotations=(), n=128, seed=0, ...) -> SweepReport``
    Figs. 12 and 13: the same `n` fresh sequences (sweep seeds, disjoint from every
    training and test seed) re-simulated per setting; RMSE per setting and its ratio to
    the in-range setting; `out/sweep.csv`, `out/sweep.json` and `out/sweep.png`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import ValidationError

from dresslog.dataset import DatasetArrays, Split, generate, load_dataset, load_manifest
from dresslog.dataset.executors import check_executor
from dresslog.dataset.manifest import FORMAT as DATASET_FORMAT
from dresslog.dataset.manifest import MANIFEST_FILE
from dresslog.errors import DatasetError, first_problem
from dresslog.io.files import atomic_path, exclusive
from dresslog.model.evaluate import Scores, evaluate
from dresslog.model.files import (
    CARD_FILE,
    DataProvenance,
    EpochRecord,
    LoadedModel,
    ModelCard,
    check_model_folder,
    check_task,
    load_model,
)
from dresslog.model.files import FORMAT as MODEL_FORMAT
from dresslog.model.options import VAL_FRACTION, check_options, held_out
from dresslog.plots import plot_sweep, plot_training
from dresslog.spec import Task, TrialSpec

#: The learning curve `train_dataset` draws into the model folder.
TRAINING_PLOT = "training.png"


#: Mid-range speeds (m/s) the paper used for the rotation sweep (12.5 and 17.5 cm/s).
ROTATION_SPEED = {Task.GOWN: 0.125, Task.SHORTS: 0.175}


# -- training ------------------------------------------------------------------------
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
    lr_schedule: Literal["constant", "cosine"] = "constant",
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
    check_options(  # from the manifest: a bad option fails before minutes of decoding
        steps, held_out(len(steps), VAL_FRACTION), epochs=epochs, batch_size=batch_size,
        hidden=hidden, layers=layers, lr=lr, window=window, keep_best=keep_best,
    )  # fmt: skip
    checkpoint = out.with_name(f".{out.name}.checkpoint.safetensors")
    # a second run on the same output would share (and garble) the checkpoint
    with exclusive(out.with_name(f".{out.name}.train.lock"), "dresslog train", out):
        arrays = load_dataset(data, workers=workers, progress=progress)
        rows = arrays.rows(Split.TRAIN)
        if len(rows) < 2:
            raise DatasetError(f"needs at least 2 training trials, has {len(rows)}", path=data)
        from dresslog.model.files import save_model
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
            from dresslog.model.numpy_lstm import NumpyEstimator

            scores = evaluate(
                NumpyEstimator(weights), arrays.sequences(test), arrays.force_maps(test)
            )
            metrics = {f"test_{k}": v for k, v in scores.as_metrics().items()}
        provenance = DataProvenance(manifest_sha256=arrays.manifest_sha256, description=str(data))
        card = make_card(arrays.task, weights, history, data=provenance, metrics=metrics)
        card = save_model(out, weights, card, overwrite=overwrite)
        plot_training(out / TRAINING_PLOT, card)
        checkpoint.unlink(missing_ok=True)
    return card


# -- evaluation ----------------------------------------------------------------------
@dataclass(frozen=True)
class EvalReport:
    task: str
    model: str
    data: str
    split: str
    manifest_sha256: str
    overall: Scores
    per_outcome: dict[str, Scores] = field(default_factory=dict)
    #: oracle name -> its ratio on the same split (`dresslog.model.bounds`), if asked
    #: for (None if not; empty if the split has no force, so nothing to place)
    bounds: dict[str, float] | None = None

    def to_json(self) -> str:
        """JSON with nan as null (JSON has no nan)."""
        return json.dumps(_finite(asdict(self)), indent=2)

    def table(self) -> str:
        head = (
            f"{'group':<10}{'n':>6}{'RMSE (N)':>12}{'zero (N)':>12}{'ratio':>8}"
            f"{'prec':>7}{'rec':>7}"
        )
        rows = [("all", self.overall), *self.per_outcome.items()]
        lines = [f"{self.task} model {self.model} on {self.data} ({self.split} split)", head]
        for name, s in rows:
            lines.append(
                f"{name:<10}{s.n:>6}{s.rmse:>12.5f}{s.zero_rmse:>12.5f}{s.ratio:>8.3f}"
                f"{s.contact_precision:>7.3f}{s.contact_recall:>7.3f}"
            )
        lines.append(
            f"half the truth: the estimate at each step's true total force "
            f"{self.overall.ratio_at_true_total:.3f}, the true shape at the estimate's "
            f"total {self.overall.ratio_true_shape:.3f}"
        )
        if self.bounds:
            lines.append("oracle ratios on the same sequences (the data's limits):")
            lines += [f"  {name:<28}{value:>8.3f}" for name, value in self.bounds.items()]
        elif self.bounds is not None:
            lines.append("oracle ratios: none, no force on the limb in these sequences")
        return "\n".join(lines)


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return value


def _check_data_task(model: LoadedModel, task: Task, n_points: int | None = None) -> None:
    """`check_task` worded for eval and sweep, which take the model as MODEL."""
    hint = "give a {task} model (e.g. samples/models/{task})"
    check_task(model, task, n_points, subject="data", hint=hint)


def _scores(model: LoadedModel, arrays: DatasetArrays, rows: np.ndarray) -> Scores:
    return evaluate(model, arrays.sequences(rows), arrays.force_maps(rows))


def evaluate_dataset(
    model: str | Path,
    data: str | Path,
    *,
    split: Split | str = Split.TEST,
    bounds: bool = False,
    workers: int | None = None,
    progress: bool = True,
) -> EvalReport:
    """Score `model` on one split of `data`, overall and per outcome (dressed/missed/caught).

    With `bounds`, also the oracle ratios of `dresslog.model.bounds` on the same split,
    so the model's ratio can be read against what the data allow.
    """
    if split not in set(Split):
        raise DatasetError(f"split {split!r} is not one of {', '.join(Split)}")
    loaded = load_model(model)
    _check_data_task(loaded, load_manifest(data).task)
    arrays = load_dataset(data, workers=workers, progress=progress)
    _check_data_task(loaded, arrays.task, arrays.n_points)
    rows = arrays.rows(split)
    if not len(rows):
        raise DatasetError(f"the dataset has no {Split(split)} trials", path=data)
    per_outcome = {}
    for outcome in sorted(set(arrays.outcomes[rows].tolist())):
        per_outcome[outcome] = _scores(loaded, arrays, arrays.rows(split, outcome))
    return EvalReport(
        task=arrays.task.value,
        model=str(model),
        data=str(data),
        split=Split(split).value,
        manifest_sha256=arrays.manifest_sha256,
        overall=_scores(loaded, arrays, rows),
        per_outcome=per_outcome,
        bounds=_bounds(arrays, rows) if bounds else None,
    )


def dataset_bounds(
    data: str | Path, *, split: Split | str = Split.TEST, workers: int | None = None
) -> dict[str, float]:
    """The oracle ratios of `dresslog.model.bounds` on one split of `data`, with no model."""
    arrays = load_dataset(data, workers=workers, progress=False)
    return _bounds(arrays, arrays.rows(split))


def _bounds(arrays: DatasetArrays, rows: np.ndarray) -> dict[str, float]:
    from dresslog.limb import build_limb, limb_points
    from dresslog.model.bounds import oracle_ratios

    truths = arrays.force_maps(rows)
    if not any(t.any() for t in truths):
        return {}  # no force anywhere: nothing to place, no bound
    train = arrays.rows(Split.TRAIN)
    points = limb_points(build_limb(arrays.task)).points
    return oracle_ratios(truths, points, arrays.force_maps(train) if len(train) else None)


# -- generalisation sweeps -----------------------------------------------------------
@dataclass(frozen=True)
class Setting:
    """One sweep setting: its name, the spec fields it fixes, and its scores."""

    name: str
    kind: str  # "baseline", "speed" or "rotation"
    value: float
    axis: str
    overrides: dict[str, Any]
    scores: Scores | None = None

    @property
    def folder(self) -> str:
        return self.name.replace(":", "_")


@dataclass(frozen=True)
class SweepReport:
    task: str
    model: str
    n: int
    baseline_rmse: float
    settings: list[Setting]

    def ratio(self, setting: Setting) -> float:
        assert setting.scores is not None
        return setting.scores.rmse / self.baseline_rmse if self.baseline_rmse else math.nan

    def table(self) -> str:
        lines = [f"{'setting':<18}{'n':>5}{'RMSE (N)':>12}{'zero (N)':>12}{'x in-range':>12}"]
        for s in self.settings:
            assert s.scores is not None
            lines.append(
                f"{s.name:<18}{s.scores.n:>5}{s.scores.rmse:>12.5f}"
                f"{s.scores.zero_rmse:>12.5f}{self.ratio(s):>12.2f}"
            )
        return "\n".join(lines)


def parse_rotation(text: str) -> tuple[str, float]:
    """'y:-15' -> ('y', -15.0): degrees about an axis, forearm at the elbow, foot at the ankle."""
    axis, sep, degrees = text.partition(":")
    try:
        if not sep or axis not in ("x", "y", "z"):
            raise ValueError
        return axis, float(degrees) + 0.0  # -0 is 0: one setting, one folder
    except ValueError:
        raise DatasetError(f"rotation {text!r} is not AXIS:DEGREES, e.g. y:-15") from None


def parse_speed(text: str | float) -> float:
    """'0.2' -> 0.2 (m/s)."""
    try:
        return float(text)
    except ValueError:
        raise DatasetError(f"speed {text!r} is not a number in m/s, e.g. 0.2") from None


def sweep_settings(
    task: Task,
    speeds: Sequence[float | str],
    rotations: Sequence[str],
    duration: float | None = None,
) -> list[Setting]:
    """The in-range baseline, then one setting per speed and per rotation.

    Every setting's fields are checked as a spec here, so a bad value stops the sweep
    before its first trial, not after the settings before it.
    """
    extra = {"duration": duration} if duration else {}
    settings = [Setting("in-range", "baseline", math.nan, "", dict(extra))]
    for speed in map(parse_speed, speeds):
        settings.append(Setting(f"speed:{speed:g}", "speed", speed, "", {"speed": speed, **extra}))
    for text in rotations:
        axis, degrees = parse_rotation(text)
        fields = {
            "speed": ROTATION_SPEED[task],
            "limb_rotation": {"axis": axis, "degrees": degrees},
            **extra,
        }
        settings.append(Setting(f"rot:{axis}:{degrees:g}", "rotation", degrees, axis, fields))
    unique: dict[str, Setting] = {}  # a value given twice (0.1 and 0.10) is swept once
    for setting in settings:
        unique.setdefault(setting.name, setting)
    settings = list(unique.values())
    for setting in settings:
        try:
            TrialSpec.model_validate({"task": task, **setting.overrides})
        except ValidationError as err:
            raise DatasetError(f"{setting.name}: invalid {first_problem(err)}") from None
    return settings


def _dresslog_folder(folder: Path) -> str | None:
    """ "a dataset" or "a model" if `folder` is one of ours (another tool's manifest.json
    does not count), else None."""
    for name, what, kind in ((MANIFEST_FILE, "a dataset", DATASET_FORMAT),
                             (CARD_FILE, "a model", MODEL_FORMAT)):  # fmt: skip
        try:
            if json.loads((folder / name).read_text(encoding="utf-8")).get("format") == kind:
                return what
        except (OSError, UnicodeDecodeError, ValueError, AttributeError):
            continue
    return None


def default_sweep_folder(model: str | Path) -> Path:
    """`MODEL-sweep` in the current folder: never beside a bundled model, in the package."""
    return Path(f"{Path(model).resolve().name}-sweep")


def sweep(
    model: str | Path,
    out: str | Path,
    *,
    speeds: Sequence[float | str] = (),
    rotations: Sequence[str] = (),
    n: int = 128,
    seed: int = 0,
    duration: float | None = None,
    workers: int | None = None,
    executor: str = "process",
    progress: bool = True,
) -> SweepReport:
    """Re-simulate the same `n` fresh sequences per setting and score the model on each.

    Each setting is a dataset folder under `out` (so an interrupted sweep resumes); the
    sweep seeds are the same in every setting, so settings differ only in what they fix.
    """
    if n < 1:
        raise DatasetError(f"a sweep needs at least 1 sequence per setting, not {n}")
    loaded = load_model(model)
    task = loaded.card.task
    if not speeds and not rotations:
        raise DatasetError("give at least one --speeds or --rotations value")
    settings = sweep_settings(task, speeds, rotations, duration)  # bad values: no folder
    check_executor(executor)
    out = Path(out)
    resolved = out.resolve()
    for folder in (resolved, *resolved.parents):  # nor anywhere inside one
        what = _dresslog_folder(folder)
        if what is not None:
            where = "is" if folder == resolved else f"is inside {folder},"
            message = f"{where} {what} folder; give the sweep a folder of its own"
            raise DatasetError(message, path=out)
    out.mkdir(parents=True, exist_ok=True)
    done: list[Setting] = []
    for setting in settings:
        folder = out / setting.folder
        generate(
            task,
            n,
            folder,
            splits={Split.SWEEP: n},
            overrides=setting.overrides,
            seed=seed,
            workers=workers,
            executor=executor,
            progress=progress,
            label=f"{task.value} {setting.name}",
        )
        arrays = load_dataset(folder, workers=workers, progress=False)
        _check_data_task(loaded, arrays.task, arrays.n_points)
        scores = _scores(loaded, arrays, arrays.rows(Split.SWEEP))
        done.append(Setting(**{**asdict(setting), "scores": scores}))
    baseline = done[0].scores
    assert baseline is not None
    report = SweepReport(task.value, str(model), n, baseline.rmse, done)
    _write_sweep(out, report)
    return report


def _write_sweep(out: Path, report: SweepReport) -> None:
    rows = ["setting,kind,axis,value,n,rmse,zero_rmse,ratio_to_in_range"]
    for s in report.settings:
        assert s.scores is not None
        value = "" if math.isnan(s.value) else f"{s.value:g}"
        rows.append(
            f"{s.name},{s.kind},{s.axis},{value},{s.scores.n},{s.scores.rmse:.6g},"
            f"{s.scores.zero_rmse:.6g},{report.ratio(s):.4g}"
        )
    for name, text in (
        ("sweep.csv", "\n".join(rows) + "\n"),
        ("sweep.json", json.dumps(_finite(asdict(report)), indent=2) + "\n"),
    ):
        with atomic_path(out / name) as tmp:
            tmp.write_text(text)
    plot_sweep(out / "sweep.png", report)
