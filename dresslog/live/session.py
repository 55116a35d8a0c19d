"""A live session: samples in, 100 Hz steps through the estimator, a trial file out.

`LiveSession` knows nothing of ROS: whoever receives a robot's messages (`ros.LiveNode`,
or a test) hands it each sample with its stamp. It refuses what cannot be placed on one
clock (a stamp going back), resamples as `convert` does (`StreamResampler`), tares and
places each step with the same `SignalOptions.place`, pushes it through the one replay
engine (`Replay`, whose sinks publish it), and records it all (`SessionRecorder`), so
that `dresslog infer` on the session file gives the estimate published live.
"""

from __future__ import annotations

import time
import warnings
from array import array
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.convert import resample as rs
from dresslog.convert.checks import MAX_LATE_S, frames_differ
from dresslog.convert.signal import tare_bias
from dresslog.convert.source import MESSAGE_TYPES, Source, SourceStream
from dresslog.errors import DresslogWarning, LiveError
from dresslog.io import well_known as wk
from dresslog.limb import build_limb, limb_points
from dresslog.live.options import LiveOptions
from dresslog.live.recorder import SessionRecorder
from dresslog.live.resampler import GridStep, StreamResampler
from dresslog.replay.engine import Estimator, Replay, Sink, Step, StepResult, TrialContext
from dresslog.spec import TrialMetadata
from dresslog.trial import LimbPoints

#: Below this rate (Hz) a stream is warned of: the model's steps come from a faster signal.
SLOW_HZ = 90.0
#: Below this rate (Hz) a stream cannot make 100 Hz steps at all.
TOO_SLOW_HZ = 10.0


class LiveWarning(DresslogWarning):
    """Something in a live stream deserves a look; the session goes on (e.g. a late stamp)."""


class LiveSession:
    """Receive samples, estimate each 100 Hz step as soon as it is complete, record it all.

    Use as a context manager: leaving it finishes the session file (also on Ctrl-C or
    an error in the stream: what was received stays a valid trial); `estimator` None
    records without estimating.
    """

    def __init__(
        self,
        options: LiveOptions,
        estimator: Estimator | None,
        sinks: Sequence[Sink] = (),
        *,
        model: str | None = None,
    ) -> None:
        self.options = options
        self.limb: LimbPoints = limb_points(build_limb(options.task))
        self.resampler = StreamResampler(options.motion, has_pose=options.pose_topic is not None)
        self.replay = Replay(estimator, sinks)
        self.model = model
        self.recorder = (
            SessionRecorder(options.output, options.task, overwrite=options.overwrite)
            if options.output is not None
            else None
        )
        self.origin_ns: int | None = None  # the source time of session time 0
        self.steps = 0
        self.messages = 0
        self.found: list[str] = []  # warnings, for the session's metadata
        self._last: dict[str, int] = {}
        self._first: dict[str, int] = {}
        self._frames: dict[str, str] = {}
        self._said: set[str] = set()
        self._topics = options.topics  # looked up at every sample: made once
        self._counts: dict[str, int] = dict.fromkeys(options.topics, 0)
        self._late: dict[str, int] = dict.fromkeys(options.topics, 0)
        self._pending: list[GridStep] = []  # steps inside the tare, until it is known
        self._bias: np.ndarray | None = None
        self._started = False
        self.compute_ns = array("q")  # per step, ns: placing, estimating, publishing
        self.node: Any = None  # the ROS 2 node feeding it, if one does (`ros.LiveNode`)

    # -- samples -------------------------------------------------------------------
    def receive(
        self, kind: str, t_ns: int, values: np.ndarray, frame_id: str = ""
    ) -> list[StepResult]:
        """One sample of `kind` (wrench, twist, pose) stamped `t_ns` on the robot's clock;
        the results of the steps it completed (published by the sinks already)."""
        last = self._last.get(kind)
        if last is not None and t_ns <= last:
            behind, topic = (last - t_ns) / 1e9, self._topics[kind]
            if behind > MAX_LATE_S:
                raise LiveError(
                    f"{topic}: time goes back {behind:.3g} s (a clock reset, or a log played "
                    "again); the session ends here, with what came before"
                )
            self._late[kind] += 1
            if self._late[kind] == 1:
                self.warn(
                    f"{topic}: a message stamped {behind * 1e3:.3g} ms before one received "
                    "earlier; dropped (as are any more such, counted in the session's notes)"
                )
            return []
        values = np.asarray(values, dtype=np.float64)
        if not np.isfinite(values).all():
            self._warn_once(f"nan:{kind}", f"{self._topics[kind]}: NaN or infinite values; dropped")
            return []
        self._last[kind] = t_ns
        self._first.setdefault(kind, t_ns)
        self._frames.setdefault(kind, frame_id)
        self._counts[kind] += 1
        self.messages += 1
        if self.recorder is not None:
            self.recorder.received(kind, t_ns, values, frame_id)
        grid_steps = self.resampler.add(kind, t_ns, values)
        if grid_steps and not self._started:
            self._start()
        results: list[StepResult] = []
        for grid_step in grid_steps:
            results += self._tared(grid_step)
        return results

    def warn(self, message: str) -> None:
        """Warn of `message` and keep it for the session's metadata."""
        self.found.append(message)
        warnings.warn(message, LiveWarning, stacklevel=3)

    def _warn_once(self, key: str, message: str) -> None:
        if key not in self._said:
            self._said.add(key)
            self.warn(message)

    # -- steps ---------------------------------------------------------------------
    def _start(self) -> None:
        """The first step is complete: check the streams' rates and frames, fix session
        time 0 (the earliest sample) and open the sinks."""
        rates = self.resampler.rates
        for kind, rate in rates.items():
            topic = self.options.topics[kind]
            if rate < TOO_SLOW_HZ:
                raise LiveError(
                    f"{topic} arrives at {rate:.3g} Hz by its stamps, too slow for the "
                    f"model's 100 Hz steps; is it the right topic?"
                )
            if rate < SLOW_HZ:
                self.warn(
                    f"{topic} arrives at {rate:.3g} Hz, slower than the model's 100 Hz steps: "
                    "interpolated onto them, so the model sees a smoothed signal"
                )
        if message := frames_differ(self._source(), self.options.signal.wrench_frame,
                                    self.options.signal.rotate is not None):  # fmt: skip
            self.warn(f"{message}; going on with the options as given")
        self.origin_ns = min(self._first.values())
        if self.recorder is not None:
            self.recorder.start(self.origin_ns, self.limb)
        topics = "topics " + ", ".join(self.options.topics.values())
        metadata = TrialMetadata(
            task=self.options.task, source={"format": wk.LIVE_FORMAT, "file": topics}
        )
        self.replay.start(TrialContext(metadata, self.limb, has_truth=False, model=self.model))
        self._started = True

    def _source(self) -> Source:
        """The streams' first samples as a `Source`, for `convert`'s checks."""
        streams = {
            kind: SourceStream(
                kind, topic, np.zeros(1, np.int64), np.zeros((1, 1)), self._frames.get(kind, "")
            )
            for kind, topic in self.options.topics.items()
        }
        return Source(
            Path(self.options.wrench_topic), "ros2", streams["wrench"],
            streams.get("twist"), streams.get("pose"),
        )  # fmt: skip

    def _tared(self, grid_step: GridStep) -> list[StepResult]:
        """Steps within the tare wait for it: the wrench's mean over them is subtracted
        from every step, theirs too, as `convert` does."""
        tare_s = self.options.signal.tare_s
        if tare_s == 0 or self._bias is not None:
            return [self._run(grid_step)]
        self._pending.append(grid_step)
        if grid_step.t_ns < self._pending[0].t_ns + round(tare_s * 1e9):
            return []
        grid = np.array([s.t_ns for s in self._pending], dtype=np.int64)
        self._bias = tare_bias(grid, np.stack([s.wrench for s in self._pending]), tare_s)
        pending, self._pending = self._pending, []
        return [self._run(s) for s in pending]

    def _run(self, grid_step: GridStep) -> StepResult:
        began = time.perf_counter_ns()
        assert self.origin_ns is not None
        pose = None if grid_step.pose is None else grid_step.pose[None]
        wrench, twist, pose = self.options.signal.place(
            grid_step.wrench[None], grid_step.twist[None], pose, self._bias
        )
        t_ns = grid_step.t_ns - self.origin_ns
        phi = np.concatenate([wrench[0], twist[0, :3]]).astype(np.float32)
        step = Step(grid_step.index, t_ns, phi, pose=None if pose is None else pose[0])
        result = self.replay.push(step)  # published: what is written waits till after
        if self.recorder is not None:
            self.recorder.step(result, wrench[0], twist[0], None if pose is None else pose[0])
        self.steps += 1
        self.compute_ns.append(time.perf_counter_ns() - began)
        return result

    # -- the end ---------------------------------------------------------------------
    def source_info(self) -> dict[str, object]:
        """The session file's `source`: topics, rates, what was done to the signal."""
        streams: dict[str, object] = {}
        for kind, topic in self.options.topics.items():
            streams[kind] = {
                "topic": topic,
                "type": MESSAGE_TYPES[kind],
                "messages": self._counts[kind],
                "rate_hz": round(self.resampler.rates.get(kind, 0.0), 3),
                "clock": "header",
            } | ({"frame_id": self._frames[kind]} if self._frames.get(kind) else {})
            if self._late[kind]:
                streams[kind]["dropped_late"] = self._late[kind]  # type: ignore[index]
        processing: dict[str, object] = {"wrench": self.resampler.how("wrench")}
        if self.options.motion == "twist":
            processing["twist"] = self.resampler.how("twist")
        else:
            processing["twist"] = f"differentiated from pose, then {self.resampler.how('velocity')}"
        if self.options.pose_topic is not None:
            processing["pose"] = "linear interpolation, quaternions normalised"
        processing |= self.options.signal.steps()
        info: dict[str, object] = {
            "format": wk.LIVE_FORMAT,
            "file": "topics " + ", ".join(self._topics.values()),
            "start_ns": self.origin_ns,
            "time": "output t = source t - start_ns",
            "rate_hz": rs.RATE_HZ,
            "streams": streams,
            "processing": processing,
            "causal": "each step estimated once the samples after it arrived (live)",
        }
        if self.model:
            info["model"] = self.model
        if self.found:
            info["warnings"] = self.found
        return info

    def finish(self) -> Path | None:
        """Close the sinks and put the session file in place (None: nothing to record, no
        step having been complete)."""
        try:
            if self._started:
                self.replay.finish()
        except BaseException:
            if self.recorder is not None:
                self.recorder.abort()
            raise
        if self.recorder is None:
            return None
        if self.steps == 0:
            self.recorder.abort()
            return None
        return self.recorder.finish(self.source_info())

    def abort(self) -> None:
        """Stop without finalising: the replay's sinks and the session file are dropped."""
        self.replay.abort()
        if self.recorder is not None:
            self.recorder.abort()
