"""`replay_files`: a day's trials through `replay_file` at once (`dresslog infer T1 T2 ...`).

A bad trial is one failure, not the end of the batch; each model is loaded once, not once
per trial; and the scores are averaged over the trials with ground truth, so a folder of
trials is scored without a dataset's manifest.
"""

from __future__ import annotations

import os
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from dresslog.errors import DresslogError, TrialWriteError
from dresslog.io.files import check_not_source, check_output_folder, named_as_recording
from dresslog.model.files import LoadedModel, load_model
from dresslog.replay.pipeline import InferenceReport, replay_file


@dataclass(frozen=True)
class TrialFailure:
    """A trial that could not be replayed, and why (nothing was written for it)."""

    trial: Path
    error: DresslogError | OSError


@dataclass
class BatchReport:
    """Every trial's report or failure, in the order given, and their mean scores."""

    reports: list[InferenceReport] = field(default_factory=list)
    failures: list[TrialFailure] = field(default_factory=list)

    @property
    def mean_rmse(self) -> float | None:
        """Mean trial RMSE (N) over the trials with ground truth; None if none has it."""
        scores = [r.rmse for r in self.reports if r.rmse is not None]
        return statistics.fmean(scores) if scores else None

    @property
    def mean_ratio(self) -> float | None:
        """Mean RMSE over the same trials' mean all-zero RMSE, as `dresslog eval` takes a
        split's ratio; None without ground truth or with no force on the limb in any."""
        zeros = [r.zero_rmse for r in self.reports if r.zero_rmse is not None]
        if self.mean_rmse is None or not zeros or statistics.fmean(zeros) == 0:
            return None
        return self.mean_rmse / statistics.fmean(zeros)

    def summary(self) -> str:
        """The mean scores in a line, saying which trials they are over; a line per task
        when trials of both are given, as a task's all-zero RMSE is its own scale."""
        tasks = sorted({r.task for r in self.reports}, key=lambda task: task.value)
        if len(tasks) > 1:
            return "\n".join(
                f"{task.value}: " + BatchReport([r for r in self.reports if r.task == task])
                .summary() for task in tasks
            )  # fmt: skip
        done = len(self.reports)
        scored = sum(r.rmse is not None for r in self.reports)
        if self.mean_rmse is None:
            return f"{_trials(done)} replayed, none with ground truth: no RMSE to average"
        left_out = f" ({done - scored} without ground truth left out)" if scored < done else ""
        line = f"mean over {_trials(scored)}{left_out}: RMSE {self.mean_rmse:.4g} N"
        if self.mean_ratio is None:
            return line + "; no ratio (no force on the limb in any)"
        return line + f", ratio to the all-zero estimate's {self.mean_ratio:.3f}"


def _trials(n: int) -> str:
    return f"{n} trial" if n == 1 else f"{n} trials"


def default_rrd(trial: Path) -> Path:
    """Where a trial's recording goes unless named: TRIAL.rrd beside it."""
    return trial.with_suffix(".rrd") if trial.name else trial  # `.` is refused as input first


def outputs_in(folder: str | Path, trials: Sequence[Path], suffix: str) -> list[Path]:
    """Each trial's output in `folder`, named after it (`a/t.mcap` -> `folder/t.rrd`).

    Checked before any trial, as no trial could go there: a folder to make named as a
    recording (`out.rrd`, a slip for one trial's file), a file where it goes, two trials of
    one name, or an output that is its trial (the trial's own folder for its `.mcap` copy).
    """
    folder = Path(folder)
    said = "with several trials, the output" if len(trials) > 1 else "an output ending in /"
    misnamed = named_as_recording(folder, said)
    if misnamed is not None and not folder.is_dir():
        raise TrialWriteError(misnamed, path=folder)
    check_output_folder(folder, "the trials' outputs")
    named: dict[Path, Path] = {}  # output -> the trial it is of
    for trial in trials:
        out = folder / f"{trial.stem}{suffix}"
        if out in named:
            raise TrialWriteError(
                f"{named[out]} and {trial} would both be written to {out}; "
                "infer them into separate folders"
            )
        check_not_source(out, trial, "give another folder")  # a trial's own folder
        named[out] = trial
    return list(named)


def _check_given_once(trials: Sequence[Path]) -> None:
    """Refuse a trial given twice (a glob and its name, `t.mcap ./t.mcap`): it would be
    replayed twice into one output and counted twice in the mean."""
    seen: dict[str, Path] = {}
    for trial in trials:
        first = seen.setdefault(os.path.realpath(trial), trial)  # a loop: the reader says so
        if first is not trial:
            said = "given twice" if first == trial else f"is {first}, given already"
            raise TrialWriteError(f"{said}; give each trial once", path=trial)


def _outputs(named: str | Path | None, trials: list[Path], suffix: str) -> list[Path | None]:
    """Each trial's output: in the folder `named` for several trials, where it is one (as
    `cp` takes a folder) or ends in `/`, else the file `named`."""
    if named is None:
        return [None] * len(trials)
    # `-o out/`: a trailing separator names a folder (made if missing), as it does for rsync
    folder = isinstance(named, str) and named.endswith(("/", os.sep))
    if len(trials) == 1 and not folder and not Path(named).is_dir():
        return [Path(named)]
    return [*outputs_in(named, trials, suffix)]


def replay_files(
    trials: Sequence[str | Path],
    *,
    model: str | Path | None = None,
    rrd: str | Path | None = None,
    mcap: str | Path | None = None,
    on_trial: Callable[[InferenceReport | TrialFailure], None] | None = None,
    overwrite: bool = False,
    progress: bool = False,
) -> BatchReport:
    """Replay each trial into its `.rrd`, and with `mcap` into a copy of it with the estimate.

    A trial's `DresslogError` or `OSError` is its failure and the next trial runs. A
    given `model` that does not load fails the batch before any trial when there are
    several (it would fail each alike); with one trial, what is wrong with the trial is
    still said first.

    Args:
        trials: the trial files, each given once.
        model: the model folder; None: the bundled model of each trial's task.
        rrd: with one trial, the recording's file (TRIAL.rrd beside the trial by
            default) or an existing folder; with several, a folder (made if missing)
            for each TRIAL.rrd.
        mcap: likewise for a copy of each trial with the estimate added.
        on_trial: hears each trial's report or failure as it comes.
        overwrite: replace existing outputs; else a trial whose output exists fails.
        progress: draw each trial's steps on a progress bar when stderr is a terminal.

    Returns:
        Every trial's report or failure, in order.

    Raises:
        TrialWriteError: `rrd` or `mcap` cannot hold every output (`outputs_in`),
            before any trial; a trial given twice.
        ModelError: with several trials, a model that does not load.
    """
    paths = [Path(t) for t in trials]
    _check_given_once(paths)
    named = _outputs(rrd, paths, ".rrd")
    rrds = [out or default_rrd(t) for t, out in zip(paths, named, strict=True)]
    mcaps = _outputs(mcap, paths, ".mcap")
    models: dict[Path, LoadedModel] = {}
    if model is not None and len(paths) > 1:
        models[Path(model)] = load_model(model)
    batch = BatchReport()
    for trial, out, copy in zip(paths, rrds, mcaps, strict=True):
        outcome: InferenceReport | TrialFailure
        try:
            outcome = replay_file(
                trial, model=model, rrd=out, mcap=copy, models=models, overwrite=overwrite,
                progress=progress,
            )  # fmt: skip
            batch.reports.append(outcome)
        except (DresslogError, OSError) as err:
            outcome = TrialFailure(trial, err)
            batch.failures.append(outcome)
        if on_trial is not None:
            on_trial(outcome)
    return batch
