"""The replay engine: a source of steps, an estimator, sinks (Rerun, MCAP, metrics).

One code path for `dresslog infer`, `view` and the live view of a running
simulation. Rerun is imported only when a Rerun sink writes.
"""

from dresslog.replay.batch import BatchReport, TrialFailure, replay_files
from dresslog.replay.engine import (
    Estimator,
    Replay,
    Sink,
    Step,
    StepResult,
    TrialContext,
    run,
    trial_context,
    trial_steps,
)
from dresslog.replay.live import SimulationSource, live_source
from dresslog.replay.mcap_sink import McapSink
from dresslog.replay.metrics import MetricsSink, TrialMetrics
from dresslog.replay.pipeline import InferenceReport, replay_file
from dresslog.replay.rerun_sink import RerunSink
from dresslog.replay.viewer import live_viewer

__all__ = [
    "BatchReport",
    "Estimator",
    "InferenceReport",
    "McapSink",
    "MetricsSink",
    "Replay",
    "RerunSink",
    "SimulationSource",
    "Sink",
    "Step",
    "StepResult",
    "TrialContext",
    "TrialFailure",
    "TrialMetrics",
    "live_source",
    "live_viewer",
    "replay_file",
    "replay_files",
    "run",
    "trial_context",
    "trial_steps",
]
