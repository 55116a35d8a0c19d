"""`evaluate_dataset` and `dataset_bounds`: a model scored on a split (`dresslog eval`)."""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.dataset import DatasetArrays, Manifest, Split, load_dataset, load_manifest
from dresslog.dataset.manifest import as_split
from dresslog.errors import DatasetError, DresslogWarning
from dresslog.experiments.plots import plot_eval
from dresslog.io.files import atomic_path, check_output, printable
from dresslog.model.bounds import describe_oracle
from dresslog.model.conditions import Conditions, folder_conditions, trained_conditions
from dresslog.model.evaluate import ErrorProfile, Scores, SequenceScores, score_sequences
from dresslog.model.files import (
    LoadedModel,
    check_task,
    load_model,
)
from dresslog.spec import Outcome, Task

#: The outcomes every report lists, with n 0 where a split has none (others where present).
OUTCOMES = (Outcome.DRESSED.value, Outcome.MISSED.value, Outcome.CAUGHT.value)


@dataclass(frozen=True)
class EvalReport:
    task: str
    model: str
    data: str
    split: str
    manifest_sha256: str
    overall: Scores
    per_outcome: dict[str, Scores] = field(default_factory=dict)
    #: limb part -> the scores over its points alone (`SequenceScores.part_scores`)
    per_part: dict[str, Scores] = field(default_factory=dict)
    #: oracle name -> its ratio on the same split (`dresslog.model.bounds`), if asked
    #: for (None if not; empty if the split has no force, so nothing to place)
    bounds: dict[str, float] | None = None
    #: the data's speeds and rotations, and the model's training trials', in words
    #: (`dresslog.model.conditions`)
    conditions: str = ""
    trained: str = ""
    #: what of the data's conditions the model was not trained on, one phrase each
    outside: list[str] = field(default_factory=list)

    def to_json(self) -> str:
        """JSON with nan as null (JSON has no nan)."""
        return json.dumps(finite(asdict(self)), indent=2)

    def headline(self) -> str:
        """What was scored on what, and how well: the table's first line, the plot's title."""
        n = self.overall.n
        return (
            f"{self.task} model {self.model} on {self.data} ({self.split} split, "
            f"{n} sequence{'s' * (n != 1)}): ratio {self.overall.ratio:.3f}"
        )

    def table(self) -> str:
        """What `eval` prints: the headline, then one row per group (all, each outcome, then
        each limb part over its points alone) with n, RMSE, the all-zero RMSE, their ratio,
        contact precision and recall."""
        head = (
            f"{'group':<10}{'n':>6}{'RMSE (N)':>12}{'zero (N)':>12}{'ratio':>8}"
            f"{'prec':>7}{'rec':>7}"
        )
        rows = [("all", self.overall), *((o, s) for o, s in self.per_outcome.items() if s.n)]
        lines = [self.headline()]
        # an offset outside the training's is named on the `outside` line alone
        if self.conditions == self.trained and not self.outside:
            lines.append(f"trials    {self.conditions}, as the model was trained on")
        else:
            lines += [f"trials    {self.conditions}", f"trained   {self.trained}"]
        if self.outside:
            lines.append(
                f"outside   {'; '.join(self.outside)}: these figures measure how the model "
                "generalises (as `dresslog sweep` does)"
            )
        lines.append(head)
        lines += [_row(name, s) for name, s in rows]
        if parts := [(part, s) for part, s in self.per_part.items() if s.n]:
            lines.append("each limb part over its own points:")
            lines += [_row(name, s) for name, s in parts]
        forceless = [o for o, s in self.per_outcome.items() if s.n and s.zero_rmse == 0]
        if forceless and self.overall.zero_rmse > 0:  # a split with none at all is warned of
            lines.append(
                f"nan: no {' or '.join(forceless)} sequence carries force on the limb, so their "
                "all-zero RMSE is 0 and the ratios to it, as contact recall, are not numbers"
            )
        lines.append(
            f"half the truth: the estimate at each step's true total force "
            f"{self.overall.ratio_at_true_total:.3f}, the true shape at the estimate's "
            f"total {self.overall.ratio_true_shape:.3f}"
        )
        if self.bounds:
            lines.append(
                "oracle ratios on the same sequences (estimates handed part of the truth):"
            )
            lines += [
                f"  {name:<22}{value:>7.3f}  {describe_oracle(name)}"
                for name, value in self.bounds.items()
            ]
        elif self.bounds is not None:
            lines.append("oracle ratios: none, no force on the limb in these sequences")
        return "\n".join(lines)


def _row(name: str, s: Scores) -> str:
    return (
        f"{name:<10}{s.n:>6}{s.rmse:>12.5f}{s.zero_rmse:>12.5f}{s.ratio:>8.3f}"
        f"{s.contact_precision:>7.3f}{s.contact_recall:>7.3f}"
    )


def finite(value: Any) -> Any:
    """`value` with every nan or infinite float, however deeply nested, as None: JSON has
    no nan, and `json.dumps` would write one that strict readers refuse."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [finite(v) for v in value]
    return value


def data_conditions(manifest: Manifest) -> Conditions:
    """The conditions of a dataset's trials, from its manifest."""
    return folder_conditions(manifest.task, manifest.overrides, manifest.rotation_range)


def check_data_task(model: LoadedModel, task: Task, n_points: int | None = None) -> None:
    """`check_task` worded for eval and sweep, which take the model as MODEL."""
    hint = "give a {task} model (e.g. samples/models/{task})"
    check_task(model, task, n_points, subject="data", hint=hint)


def warn_no_force(where: str | Path, sequences: str, consequence: str, cure: str) -> None:
    """Say that no `sequences` (of the data at `where`) carries force on the limb, so
    `consequence`: trials that end before the garment reaches the limb are the natural
    first try, and a model trained or scored on them gives numbers (none, nan) that do not
    say why. The warning points at the caller's caller, as `stacklevel=2` would there."""
    warnings.warn(
        f"{printable(where)}: no {sequences} carries force on the limb, so {consequence}; {cure}",
        DresslogWarning,
        stacklevel=3,
    )


def limb_parts(task: Task) -> dict[str, np.ndarray]:
    """Each part of the task's limb (fist, elbow, ...; the names `info` shares force by)
    and the mask of its points in a force map, largest first."""
    from dresslog.limb import build_limb, limb_points

    points = limb_points(build_limb(task))
    masks = {name: points.segment == i for i, name in enumerate(points.segment_names)}
    return dict(sorted(masks.items(), key=lambda item: -int(item[1].sum())))


def score_rows(model: LoadedModel, arrays: DatasetArrays, rows: np.ndarray) -> Scores:
    """The model's scores on these rows of the dataset (a sweep's setting)."""
    return score_sequences(model, arrays.sequences(rows), arrays.force_maps(rows)).scores()


def evaluate_dataset(
    model: str | Path,
    data: str | Path,
    *,
    split: Split | str = Split.TEST,
    bounds: bool = False,
    plot: str | Path | None = None,
    per_sequence: str | Path | None = None,
    overwrite: bool = False,
    workers: int | None = None,
    progress: bool = True,
) -> EvalReport:
    """Score `model` on one split of `data`, overall and per outcome (dressed/missed/caught).

    Args:
        model: the model folder.
        data: the dataset folder.
        split: which split to score on.
        bounds: also the oracle ratios of `dresslog.model.bounds` on the same split, so
            the model's ratio can be read against what the data allow.
        plot: a PNG of where along the limb and at what total force the model errs
            (`plot_eval`).
        per_sequence: a CSV of each sequence's spec, outcome and scores (`PER_SEQUENCE`).
        overwrite: replace an existing `plot` or `per_sequence` file.
        workers: processes decoding the trials; None: one per core.
        progress: show progress bars.

    Returns:
        The report: scores overall and per outcome, the data's conditions beside the
        model's training ones; ``table()`` is what ``eval`` prints.

    Raises:
        DatasetError: no dataset at `data`, or a split it holds no trials of.
        ModelError: no model at `model`, or one of another task or limb-point count.
    """
    split = as_split(split)  # before anything is loaded
    if plot is not None:
        check_output(plot, suffix=".png", overwrite=overwrite)
    if per_sequence is not None:
        check_output(per_sequence, suffix=".csv", overwrite=overwrite)
    loaded = load_model(model)
    manifest = load_manifest(data)
    check_data_task(loaded, manifest.task)
    _check_held(data, manifest, split)
    held, trained = data_conditions(manifest), trained_conditions(loaded.card)
    arrays = load_dataset(data, workers=workers, progress=progress)
    check_data_task(loaded, arrays.task, arrays.n_points)
    rows = arrays.rows(split)
    profile = ErrorProfile(arrays.n_points) if plot is not None else None
    each = score_sequences(
        loaded,
        arrays.sequences(rows),
        arrays.force_maps(rows),
        profile=profile,
        parts=limb_parts(arrays.task),
    )
    overall, outcomes = each.scores(), arrays.outcomes[rows]
    # the three outcomes always, empty ones with n 0 (a script's keys do not come and go)
    present = set(outcomes.tolist())
    per_outcome = {
        outcome: each.scores(outcomes == outcome)
        for outcome in [*OUTCOMES, *sorted(present - set(OUTCOMES))]
    }
    if overall.zero_rmse == 0:  # every ratio divides by it: nan, which the table cannot explain
        warn_no_force(
            data,
            f"{split} sequence (outcomes: {', '.join(sorted(present))})",
            "the all-zero RMSE is 0 and the ratios to it, as contact recall, are not numbers (nan)",
            "score the model on longer trials (generate --duration)",
        )
    report = EvalReport(
        task=arrays.task.value,
        model=str(model),
        data=str(data),
        split=split.value,
        manifest_sha256=arrays.manifest_sha256,
        overall=overall,
        per_outcome=per_outcome,
        per_part=each.part_scores(),
        bounds=_bounds(arrays, rows) if bounds else None,
        conditions=held.describe(),
        trained=trained.describe(),
        outside=held.outside(trained),
    )
    if profile is not None and plot is not None:
        plot_eval(plot, profile, arrays.task, report.headline(), overwrite=overwrite)
    if per_sequence is not None:
        _write_per_sequence(per_sequence, manifest, arrays.files[rows], each, overwrite)
    return report


#: The columns of `eval --per-sequence`: a sequence's trial, what its spec drew, its scores.
PER_SEQUENCE = (
    "file", "outcome", "steps", "seed", "speed", "limb_offset_x", "limb_offset_y",
    "limb_offset_z", "limb_rotation", "rmse", "zero_rmse", "ratio",
)  # fmt: skip


def _write_per_sequence(
    path: str | Path,
    manifest: Manifest,
    files: np.ndarray,
    each: SequenceScores,
    overwrite: bool = True,
) -> None:
    """One row per scored sequence, in the split's order: which trials the model gets
    wrong, and what their specs (speed, limb pose) have in common."""
    import csv

    entries = {entry.file: entry for entry in manifest.trials}
    with atomic_path(path, overwrite=overwrite) as tmp, tmp.open("w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(PER_SEQUENCE)
        for k, file in enumerate(files):
            entry, rmse, zero = entries[str(file)], each.rmse[k], each.zero_rmse[k]
            spec, turned = entry.spec, entry.spec.limb_rotation
            writer.writerow([
                file, entry.outcome.value, entry.steps, spec.seed, f"{spec.speed:.6g}",
                *(f"{v:.6g}" for v in spec.limb_offset),
                f"{turned.axis} {turned.degrees:+g}" if turned.degrees else "",
                f"{rmse:.6g}", f"{zero:.6g}", f"{rmse / zero:.4g}" if zero else "",
            ])  # fmt: skip


def dataset_bounds(
    data: str | Path, *, split: Split | str = Split.TEST, workers: int | None = None
) -> dict[str, float]:
    """The oracle ratios of `dresslog.model.bounds` on one split of `data`, with no model.

    Args:
        data: the dataset folder.
        split: which split.
        workers: processes decoding the trials; None: one per core.

    Returns:
        Each oracle's name and ratio; empty when the split carries no force.

    Raises:
        DatasetError: no dataset at `data`, or a split it holds no trials of.
    """
    split = as_split(split)
    _check_held(data, load_manifest(data), split)
    arrays = load_dataset(data, workers=workers, progress=False)
    return _bounds(arrays, arrays.rows(split))


def _check_held(data: str | Path, manifest: Manifest, split: Split) -> None:
    """Refuse a split the dataset has no trials of, naming those it has, from the manifest
    before any decoding."""
    if manifest.split(split):
        return
    held = [s.value for s in Split if manifest.split(s)]
    hint = f"; it holds {', '.join(held)} trials: pass --split {held[0]}" if held else ""
    if held == [Split.SWEEP.value]:
        hint = "; a sweep setting's trials are scored by `dresslog sweep`"
    raise DatasetError(f"the dataset has no {split} trials{hint}", path=data)


def _bounds(arrays: DatasetArrays, rows: np.ndarray) -> dict[str, float]:
    from dresslog.limb import build_limb, limb_points
    from dresslog.model.bounds import oracle_ratios

    truths = arrays.force_maps(rows)
    if not any(t.any() for t in truths):
        return {}  # no force anywhere: nothing to place, no bound
    train = arrays.rows(Split.TRAIN)
    points = limb_points(build_limb(arrays.task)).points
    return oracle_ratios(truths, points, arrays.force_maps(train) if len(train) else None)
