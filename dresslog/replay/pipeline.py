"""The file-level entry point `replay_file` (behind `dresslog infer` and `view`).

It reads a trial, picks a model (given, or the bundled one for the trial's task),
and hands the steps to the one replay engine; it also times its stages, which
`dresslog infer --timings` and the benchmark report.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from dresslog.errors import DresslogWarning, TrialFormatError
from dresslog.io import well_known as wk
from dresslog.io.files import check_output
from dresslog.io.reader import off_rate, read_trial
from dresslog.model.bundled import resolve_model
from dresslog.model.conditions import training_warning
from dresslog.model.files import LoadedModel
from dresslog.replay.engine import (
    Replay,
    Sink,
    StepResult,
    TrialContext,
    trial_context,
    trial_steps,
)
from dresslog.replay.mcap_sink import McapSink, check_copy_output
from dresslog.replay.metrics import MetricsSink, TrialMetrics
from dresslog.replay.rerun_sink import RerunSink
from dresslog.spec import Task
from dresslog.trial import STEP_HZ, Trial, median_rate


@dataclass
class InferenceReport:
    """What one replay did: steps, RMSE if the trial has ground truth, outputs, stage times (s)."""

    trial: Path
    task: Task
    steps: int
    model: Path | None = None
    metrics: TrialMetrics = field(default_factory=TrialMetrics)
    outputs: list[Path] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def rmse(self) -> float | None:
        """The trial's RMSE against its ground truth; None without one."""
        return self.metrics.rmse

    @property
    def zero_rmse(self) -> float | None:
        """The all-zero estimate's RMSE, the baseline `rmse` is read against; None without
        truth."""
        return self.metrics.zero_rmse

    def summary(self) -> str:
        """One line for the terminal: what ran, where it went, how the estimate compares
        with the truth, and (what a log without truth has) how much force it estimates."""
        m = self.metrics
        model = f"model {self.model}" if self.model else "ground truth only (no model)"
        line = f"{self.trial}: {self.steps} steps, {self.task.value}, {model}"
        if self.outputs:
            line += " -> " + ", ".join(str(p) for p in self.outputs)
        if scores := m.scores():
            line += f"; {scores}"
        if m.peak_total == 0:
            line += "; no force estimated on the limb"
        elif m.peak_total is not None:
            line += (
                f"; estimated force on the limb {m.mean_total:.3g} N on average, at most "
                f"{m.peak_total:.3g} N ({m.peak_s:.2f} s), on {m.touching:.0%} of steps"
            )
        return line


def step_rate_problem(trial: Trial, path: Path) -> TrialFormatError | None:
    """Wrench or twist at another rate than the models' 100 Hz steps, or a trial of one
    step, as the error to raise.

    Steps are matched by stamp, so a 1 kHz wrench beside a 100 Hz twist would run as
    every tenth sample, unaveraged, and a 50 Hz trial at half the model's speed. One
    step is no sequence to run a recurrent model on (and scored `RMSE 0 N`): `record`
    and `convert` make none.
    """
    if len(trial.measurements) < 2:
        return TrialFormatError(
            f"has one step ({wk.WRENCH} and {wk.TWIST} at one time), "
            "less than two steps, and the model needs two or more; re-record it, or "
            "re-convert a longer log",
            path=path,
        )
    for topic, stream in ((wk.WRENCH, trial.wrench), (wk.TWIST, trial.twist)):
        rate = median_rate(stream.t_ns)
        if rate and abs(STEP_HZ / rate - 1) > 0.02:  # a step 2% off the model's
            return TrialFormatError(off_rate(rate), path=path, channel=topic)
    return None


class ProgressBar:
    """A sink drawing the replayed steps on a progress bar (on a terminal only), gone when
    done: a 7 s trial takes a second, a 30-minute log a minute with nothing else to show."""

    def __init__(self) -> None:
        self._bar: Any = None

    def open(self, context: TrialContext) -> None:
        """Show a bar over the trial's steps (their count when the trial is a file)."""
        from tqdm import tqdm

        trial, path = context.trial, context.source_path
        total = len(trial.measurements) if trial is not None else None
        # disable=None: no bar when stderr is not a terminal (a log file, a test)
        name = path.name if path is not None else None
        self._bar = tqdm(total=total, unit="step", desc=name, disable=None, leave=False)

    def write(self, result: StepResult) -> None:
        """Advance the bar by one step."""
        self._bar.update()

    def close(self) -> None:
        """Take the bar off the terminal: it writes no output."""
        self.abort()

    def commit(self) -> None:
        """Nothing to put in place: the bar writes no output."""

    def abort(self) -> None:
        """Take the bar off the terminal, if it is still there."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def replay_file(
    trial_path: str | Path,
    *,
    model: str | Path | None = None,
    require_model: bool = True,
    rrd: str | Path | None = None,
    mcap: str | Path | None = None,
    sinks: tuple[Sink, ...] = (),
    models: dict[Path, LoadedModel] | None = None,
    overwrite: bool = False,
    progress: bool = False,
) -> InferenceReport:
    """Stream a trial file step by step through a model into .rrd / MCAP / extra sinks.

    Args:
        trial_path: the trial (MCAP) to replay.
        model: the model folder; None: the bundled model of the trial's task.
        require_model: False: with no model given or bundled, a trial with ground truth
            is replayed with it alone (what `dresslog view` shows without a model), as
            is one at another rate than the models' (with a warning).
        rrd: a Rerun recording to write.
        mcap: a copy of the trial with the estimate added.
        sinks: more sinks to feed every step.
        models: folder -> loaded model, where a batch keeps the models it has loaded,
            so each is loaded once.
        overwrite: replace an existing `rrd` or `mcap`.
        progress: draw the steps on a progress bar when stderr is a terminal.

    Returns:
        What the replay did: steps, RMSE where the trial has truth, outputs, timings.

    Raises:
        TrialFormatError: the trial is unreadable or not a dresslog trial.
        ModelError: the model does not load or does not fit the trial.
        TrialWriteError: an output may not or cannot be written.
    """
    clock = time.perf_counter
    timings: dict[str, float] = {}
    t0 = clock()
    trial = read_trial(trial_path)  # what is wrong with the input is said first
    context = trial_context(trial, trial_path)
    timings["read"] = clock() - t0
    named = {".rrd": rrd, ".mcap": mcap}
    outputs = [Path(p) for p in named.values() if p is not None]
    if rrd is not None:
        check_output(Path(rrd), source=Path(trial_path), suffix=".rrd", overwrite=overwrite)
    if mcap is not None:
        check_copy_output(Path(mcap), Path(trial_path), overwrite=overwrite)
    if rrd is not None:  # start-up cost, reported apart from the work itself
        t0 = clock()
        import rerun  # noqa: F401

        timings["import_rerun"] = clock() - t0

    t0 = clock()
    task = trial.metadata.task
    n_points = len(trial.limb_points) if trial.limb_points is not None else None
    # a trial without ground truth (a converted log) has nothing to show but an estimate,
    # and an estimate copy (`mcap`) nothing to copy but one
    need_model = require_model or trial.force_map is None or mcap is not None
    loaded = resolve_model(model, task, n_points, required=need_model, loaded=models)
    if loaded is not None and (problem := step_rate_problem(trial, Path(trial_path))):
        if need_model:
            raise problem
        warnings.warn(f"{problem}; shown with ground truth alone", DresslogWarning, stacklevel=2)
        loaded = None
    estimator = loaded.estimator() if loaded is not None else None
    if loaded is not None:
        context = replace(context, model=loaded.describe())
        simulated = trial.metadata.spec is not None
        if far := loaded.unfamiliar(trial.measurements.phi, simulated=simulated):
            warnings.warn(f"{trial_path}: {far}", DresslogWarning, stacklevel=2)
        elif (spec := trial.metadata.spec) and (outside := training_warning(spec, loaded.card)):
            # a signal in range can still come from a new pose
            warnings.warn(f"{trial_path}: {outside}", DresslogWarning, stacklevel=2)
    timings["load_model"] = clock() - t0

    metrics = MetricsSink()
    all_sinks: list[Sink] = [metrics, *sinks, *([ProgressBar()] if progress else [])]
    if rrd is not None:
        all_sinks.append(RerunSink(rrd, overwrite=overwrite))
    if mcap is not None:
        all_sinks.append(McapSink(mcap, overwrite=overwrite))
    replay = Replay(estimator, all_sinks)
    replay.run(context, trial_steps(trial), keep=False)
    timings.update(replay.timings)
    return InferenceReport(
        trial=Path(trial_path),
        task=task,
        steps=metrics.metrics.steps,
        model=loaded.path if loaded is not None else None,
        metrics=metrics.metrics,
        outputs=outputs,
        timings=timings,
    )
