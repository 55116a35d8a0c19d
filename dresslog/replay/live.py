"""Live replay: a running simulation feeds the replay engine step by step.

`simulate(spec, sink)` pushes `SimStart`/`SimStep` to a sink as it computes
them; `SimulationSource` is such a sink, turning each step into the engine's
`Step`, so `dresslog record --live` shows the estimate beside ground truth
through the same code as `dresslog infer`. Only `record_live` imports the simulator
(and pybullet with it), when it is called.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Self

import numpy as np

from dresslog.errors import DresslogError, DresslogWarning
from dresslog.replay.engine import Estimator, Replay, Sink, Step, TrialContext
from dresslog.replay.metrics import MetricsSink, TrialMetrics
from dresslog.spec import TrialMetadata, TrialSpec

if TYPE_CHECKING:
    import rerun as rr

    from dresslog.sim.simulate import SimResult, SimStart, SimStep

#: Steps per Rerun flush in a live view: 10 steps = 100 ms of simulated time.
LIVE_FLUSH_STEPS = 10


class SimulationSource:
    """A `simulate()` sink that replays each step through an estimator into engine sinks.

    Use as a context manager around `simulate(spec, source)`: leaving it commits
    the sinks, or aborts them if the simulation raised; `metrics` then holds the trial's
    RMSE against the simulation's ground truth.
    """

    def __init__(
        self, estimator: Estimator | None, sinks: Sequence[Sink] = (), model: str | None = None
    ) -> None:
        self._scores = MetricsSink()
        self.replay = Replay(estimator, [self._scores, *sinks])
        self.model = model

    @property
    def metrics(self) -> TrialMetrics:
        """What the replay measured so far: whole once the source is finished."""
        return self._scores.metrics

    def start(self, info: SimStart) -> None:
        """Open the replay with the scene the simulation starts from (limb points, garment
        triangles)."""
        metadata = TrialMetadata(task=info.spec.task, spec=info.spec)
        self.replay.start(
            TrialContext(metadata, info.limb_points, info.triangles, model=self.model)
        )

    def step(self, step: SimStep) -> None:
        """Push one simulated step (its 9-D measurement and ground truth) through the replay."""
        phi = np.concatenate([step.wrench[:6], step.twist[:3]]).astype(np.float32)
        self.replay.push(
            Step(
                index=step.index,
                t_ns=step.t_ns,
                phi=phi,
                truth=step.force_map,
                pose=step.pose,
                contacts=step.contacts,
                garment=step.garment,
            )
        )

    def finish(self) -> TrialMetrics:
        """Close and commit the replay's sinks; returns the trial's metrics."""
        self.replay.finish()
        return self.metrics

    def abort(self) -> None:
        """Abort the replay's sinks: a simulation that raised leaves no output behind."""
        self.replay.abort()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if exc_type is None:
            self.finish()
        else:
            self.abort()


def live_source(
    model: str | Path | None,
    spec: TrialSpec,
    path: str | Path,
    *,
    recording: rr.RecordingStream | None = None,
    connect: str | None = None,
) -> SimulationSource:
    """What `dresslog record --live` passes to `simulate`: model (or bundled) -> live viewer.

    Without a model (none given, none bundled) the live view shows ground truth alone. A
    `spec` the model was not trained on (a faster speed, a turned limb) is warned of, as
    `infer` warns of such a trial at `path`.
    """
    from dresslog.model.bundled import resolve_model
    from dresslog.model.conditions import training_warning
    from dresslog.replay.rerun_sink import RerunSink
    from dresslog.replay.viewer import live_viewer

    loaded = resolve_model(model, spec.task, None, required=False)
    if loaded is not None and (outside := training_warning(spec, loaded.card)):
        warnings.warn(f"{path}: {outside}", DresslogWarning, stacklevel=3)
    estimator = loaded.estimator() if loaded is not None else None
    rec = recording if recording is not None else live_viewer(spec.task, connect=connect)
    sink = RerunSink(recording=rec, flush_every=LIVE_FLUSH_STEPS)
    return SimulationSource(estimator, [sink], loaded.describe() if loaded is not None else None)


def record_live(
    spec: TrialSpec,
    path: str | Path,
    *,
    model: str | Path | None = None,
    overwrite: bool = False,
    recording: rr.RecordingStream | None = None,
    connect: str | None = None,
) -> tuple[SimResult, TrialMetrics]:
    """`dresslog record --live`: simulate `spec` to `path` while a viewer shows the replay.

    The MCAP is written exactly as `record_trial` writes it; the live view gets the
    same steps through `SimulationSource`: to `recording` if given, else to the viewer
    at the gRPC URL `connect` (say, on the researcher's desktop while the simulation
    runs on a server), else to a viewer spawned here.
    """
    from dresslog.sim import record_trial

    live = live_source(model, spec, path, recording=recording, connect=connect)
    result: SimResult | None = None
    try:
        with live:
            result = record_trial(spec, path, overwrite=overwrite, sinks=[live])
    except RuntimeError as err:  # Rerun's stream to a viewer that went away
        if "grpc" not in str(err).lower():
            raise
        if result is None:  # during the simulation: its file was removed with it
            raise DresslogError(
                "the Rerun viewer went away while the trial streamed to it, so nothing was "
                "written; record again (without --live, or with --connect to a running viewer)"
            ) from None
        # the stream fails only as it is flushed at the end: the trial is whole, keep it
        warnings.warn(
            f"the Rerun viewer went away before the live view ended; the trial itself was "
            f"recorded in full to {path}",
            DresslogWarning,
            stacklevel=2,
        )
    return result, live.metrics
