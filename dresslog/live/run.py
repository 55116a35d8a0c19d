"""`run_live`: `dresslog live` as a library call: model, session, ROS 2 node, report."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.live.options import LiveOptions
from dresslog.live.session import LiveSession
from dresslog.replay.engine import Sink


@dataclass
class LiveReport:
    """What a live session did: steps estimated, messages received, the file written, the
    time each step took (placing, estimating, publishing, ms), the latency from each wrench
    message's arrival to the estimate's publication where it completed a step, the time
    every wrench message took to handle (ms), and why it ended."""

    steps: int
    messages: int
    output: Path | None
    model: str | None
    compute_ms: list[float] = field(default_factory=list)
    latency_ms: list[float] = field(default_factory=list)
    handled_ms: list[float] = field(default_factory=list)
    ended: str = "stopped"

    def summary(self) -> str:
        """One line for the terminal."""
        line = f"{self.steps} steps ({self.steps / 100:.2f} s at 100 Hz)"
        line += f" from {self.messages} messages"
        if self.model:
            line += f", model {self.model}"
        if self.latency_ms:
            p50, p99 = np.percentile(self.latency_ms, [50, 99])
            line += f"; a wrench's arrival to the estimate {p50:.2f} ms at p50, {p99:.2f} ms at p99"
        if self.output is not None:
            line += f" -> {self.output}"
        return line


def run_live(
    options: LiveOptions,
    *,
    announce: Callable[[str], object] | None = None,
    stop_after: float | None = None,
    context: Any = None,
) -> LiveReport:
    """Listen to the options' topics and publish the estimate until Ctrl-C or SIGTERM (or
    `stop_after` s), recording the session to `options.output` if given; `announce` is
    told what is listened to once all is ready (`context`: an rclpy context to run in).

    The session file is finished whatever ends the session, an error in the stream too (a
    clock reset): it then holds what came before, and the error is raised after.

    Raises:
        LiveError: no ROS 2, a topic silent or of another type, a clock reset.
        ModelError: the model is for the other task, or missing.
    """
    from dresslog.live.ros import import_rclpy, spin
    from dresslog.model.bundled import resolve_model

    import_rclpy()  # before anything is opened: how to install it, in one line
    loaded = resolve_model(options.model, options.task, None, required=True)
    assert loaded is not None
    sinks: list[Sink] = []
    if options.connect is not None:
        from dresslog.replay.rerun_sink import RerunSink
        from dresslog.replay.viewer import live_viewer

        recording = live_viewer(options.task, connect=options.connect)
        sinks.append(RerunSink(recording=recording, flush_every=10))
    model = loaded.describe()
    session = LiveSession(options, loaded.estimator(), sinks, model=model)
    if announce is not None:
        topics = ", ".join(options.topics.values())
        announce(f"Listening to {topics}; publishing on {options.prefix}/force_map (Ctrl-C ends)")
    ended = "stopped"
    try:
        spin(options, session, stop_after=stop_after, context=context)
    except KeyboardInterrupt:
        ended = "interrupted"
    except BaseException:
        session.finish()
        raise
    output = session.finish()
    node = session.node
    return LiveReport(
        steps=session.steps,
        messages=session.messages,
        output=output,
        model=model,
        compute_ms=[ns / 1e6 for ns in session.compute_ns],
        latency_ms=[] if node is None else [ns / 1e6 for ns in node.latency_ns],
        handled_ms=[] if node is None else [ns / 1e6 for ns in node.handled_ns],
        ended=ended,
    )
