"""The replay engine: a source of steps, an estimator, sinks; one loop for every caller.

`infer` on a file, `view` and the live view of a running simulation all push the
same `Step`s through the same `Replay`, so what a sink sees does not depend on
where the data came from. The estimator is run one 9-D step at a time, as a robot
would run it, and Eq. 2 is applied here. (Evaluation over a whole test split runs
the same numpy network over many sequences at once, `dresslog.model.evaluate`; a
test holds the two equal.)
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from dresslog.errors import ModelError, TrialFormatError
from dresslog.io import well_known as wk
from dresslog.model.postprocess import apply_contact
from dresslog.replay.metrics import step_rmse
from dresslog.spec import TrialMetadata
from dresslog.trial import LimbPoints, Trial


class Estimator(Protocol):
    """A stateful force-map model: one 9-D step in, force and contact maps (N,) out.

    `dresslog.model.NumpyEstimator` is one; the engine enforces Eq. 2 on whatever
    comes back (idempotent on an estimate that already has it). One with an `n_points`
    attribute (N) is refused at the start for a trial of another limb.
    """

    def reset(self) -> None:
        """Forget the last trial's state: the next step is a trial's first."""
        ...

    def step(self, phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The force map (N,) and the contact map (N,) after one 9-D step `phi`."""
        ...


@dataclass(frozen=True)
class TrialContext:
    """What sinks need before the first step."""

    metadata: TrialMetadata
    limb_points: LimbPoints | None
    garment_triangles: np.ndarray | None = None
    source_path: Path | None = None
    trial: Trial | None = None
    has_estimate: bool = True
    has_truth: bool = True  # False for a converted log: nothing to draw beside the estimate
    model: str | None = None  # which model makes the estimate, as a recording names it


@dataclass(frozen=True)
class Step:
    """One 100 Hz step: the measurement phi_t and whatever ground truth came with it."""

    index: int
    t_ns: int
    phi: np.ndarray
    truth: np.ndarray | None = None
    pose: np.ndarray | None = None
    contacts: np.ndarray | None = None
    garment: np.ndarray | None = None


@dataclass(frozen=True)
class StepResult:
    """A step and the model's view of it: contact map, Eq. 2 estimate, the step's RMSE."""

    step: Step
    contact: np.ndarray | None = None
    estimate: np.ndarray | None = None
    rmse: float | None = None


class Sink(Protocol):
    """Receives every step result, then writes its output in two phases.

    `close` writes everything under a temporary name (where failures happen: a full
    disk, a bad value), `commit` only renames it into place, and `abort` leaves nothing
    behind: so a replay whose second output fails never replaces the first one's
    earlier file (only a rename failing between two commits could).
    """

    def open(self, context: TrialContext) -> None:
        """Prepare for a trial described by `context`, before its first step."""
        ...

    def write(self, result: StepResult) -> None:
        """Take one step's result, as it comes (the whole trial is not kept for it)."""
        ...

    def close(self) -> None:
        """Write everything out under a temporary name: where a failure should happen."""
        ...

    def commit(self) -> None:
        """Put the closed output in place under its final name (a rename, nothing more)."""
        ...

    def abort(self) -> None:
        """Leave nothing behind: no temporary file, no half output under the final name."""
        ...


class Replay:
    """Push steps through an estimator (optional: ground truth alone) into sinks."""

    def __init__(self, estimator: Estimator | None, sinks: Sequence[Sink] = ()) -> None:
        self.estimator = estimator
        self.sinks = list(sinks)
        self.context: TrialContext | None = None
        self.timings: dict[str, float] = {}
        self._opened: list[Sink] = []

    def start(self, context: TrialContext) -> None:
        """Reset the estimator and open every sink for a trial; a sink that fails to open
        aborts those opened before it.

        Raises:
            ModelError: the estimator is for another number of limb points than the trial's.
        """
        context = replace(context, has_estimate=self.estimator is not None)
        self.context = context
        if self.estimator is not None:
            if (n_points := getattr(self.estimator, "n_points", None)) is not None:
                check_points(context, n_points)  # else numpy's broadcast error at a step
            self.estimator.reset()
        try:
            for sink in self.sinks:
                sink.open(context)
                self._opened.append(sink)
        except BaseException:
            self.abort()
            raise

    def push(self, step: Step) -> StepResult:
        """One step through the model and every sink; the latency a robot would see."""
        if not np.isfinite(step.phi).all():
            path = self.context.source_path if self.context else None
            raise TrialFormatError(
                f"NaN or infinite measurement at step {step.index}; the model cannot run on it",
                path=path,
            )
        result = StepResult(step)
        if self.estimator is not None:
            forces, contact = self.estimator.step(step.phi)
            estimate = apply_contact(forces, contact)
            if not np.isfinite(estimate).all():  # weights that overflow on this signal
                context = self.context
                raise ModelError(
                    f"the model{f' ({context.model})' if context and context.model else ''} "
                    f"estimates NaN or infinite forces at step {step.index}; no estimate is "
                    "written",
                    path=context.source_path if context else None,
                )
            rmse = None if step.truth is None else step_rmse(step.truth, estimate)
            result = StepResult(step, contact, estimate, rmse)
        for sink in self.sinks:
            sink.write(result)
        return result

    def finish(self) -> None:
        """Close every sink, then commit them all; if one fails, every sink is aborted."""
        try:
            for sink in self.sinks:
                sink.close()
            for sink in self.sinks:
                sink.commit()
        except BaseException:
            self.abort()
            raise
        finally:
            self._opened = []

    def abort(self) -> None:
        """Abort every sink opened so far (a replay stopped before `finish`)."""
        for sink in self._opened:
            sink.abort()
        self._opened = []

    def run(
        self, context: TrialContext, steps: Iterable[Step], *, keep: bool = True
    ) -> list[StepResult]:
        """start, push every step, finish; `timings` holds the seconds spent in each part.

        Returns every step's result, or none with `keep=False`: a long log's whole
        estimate is the sinks' to keep or write as it comes (half a GB for 30 minutes).
        """
        clock = time.perf_counter
        t0 = clock()
        self.start(context)
        results: list[StepResult] = []
        try:
            for step in steps:
                result = self.push(step)
                if keep:
                    results.append(result)
        except BaseException:
            self.abort()
            raise
        t1 = clock()
        self.finish()
        self.timings = {"infer": t1 - t0, "write": clock() - t1}
        return results


def run(
    context: TrialContext,
    steps: Iterable[Step],
    estimator: Estimator | None,
    sinks: Sequence[Sink] = (),
) -> list[StepResult]:
    """Replay a whole source into the sinks; a failure on any step leaves no file behind."""
    return Replay(estimator, sinks).run(context, steps)


# -- sources -------------------------------------------------------------------
def _match(t_ns: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Index into sorted `t_ns` of each time in `at`, or -1 where `t_ns` has no sample then."""
    if len(t_ns) == 0:
        return np.full(len(at), -1)
    idx = np.clip(np.searchsorted(t_ns, at), 0, len(t_ns) - 1)
    return np.where(t_ns[idx] == at, idx, -1)


def trial_context(trial: Trial, path: str | Path | None = None) -> TrialContext:
    """The context of a recorded trial (a simulated one, or a converted log without limb points)."""
    limb = trial.limb_points
    if limb is None:  # a converted log: draw the estimate on the task's nominal limb
        from dresslog.limb import build_limb, limb_points

        limb = limb_points(build_limb(trial.metadata.task))
        maps = trial.force_map
        if maps is not None and maps.forces.shape[1] != len(limb):  # (the reader checks
            raise TrialFormatError(  # a map against limb points the trial holds itself)
                f"force maps have {maps.forces.shape[1]} values but the trial has no "
                f"{wk.LIMB_POINTS} and the {trial.metadata.task.value}'s limb has {len(limb)} "
                "points; write its limb points with the maps",
                path=path,
                channel=wk.FORCE_MAP,
            )
    return TrialContext(
        metadata=trial.metadata,
        limb_points=limb,
        garment_triangles=None if trial.garment is None else trial.garment.triangles,
        source_path=None if path is None else Path(path),
        trial=trial,
        has_truth=trial.force_map is not None,
    )


def trial_steps(trial: Trial) -> Iterator[Step]:
    """The steps of a recorded trial, ground truth matched to each measurement by timestamp."""
    meas = trial.measurements

    def lookup(stream: Any, field: str) -> list:
        """Per step: the sample stamped exactly then, or None (e.g. garment only at 10 Hz)."""
        if stream is None:
            return [None] * len(meas)
        values = getattr(stream, field)
        return [values[j] if j >= 0 else None for j in _match(stream.t_ns, meas.t_ns).tolist()]

    truth = lookup(trial.force_map, "forces")
    poses = lookup(trial.pose, "values")
    items = lookup(trial.contacts, "items")
    cloth = lookup(trial.garment, "vertices")
    for i, t in enumerate(meas.t_ns.tolist()):
        yield Step(i, t, meas.phi[i], truth[i], poses[i], items[i], cloth[i])


def check_points(context: TrialContext, n_points: int) -> None:
    """A model fits a trial only if both have the same number of limb points."""
    have = context.limb_points
    if have is not None and len(have) != n_points:
        raise ModelError(
            f"model estimates {n_points} limb points but the trial has {len(have)}",
            path=context.source_path,
        )
