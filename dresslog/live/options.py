"""`LiveOptions`: what `dresslog live` listens to, how it places the signal, where it reports."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, model_validator

from dresslog.convert.signal import OptionError, SignalOptions
from dresslog.errors import LiveError
from dresslog.spec import Task, task_of

#: Total estimated force on the limb above which the summary raises its flag, N.
HIGH_FORCE_N = 10.0
#: How long each topic may stay silent at the start before `live` gives up, s.
WAIT_S = 5.0
#: Where the estimate goes: `<prefix>/force_map`, `/contact_map`, `/summary`.
PREFIX = "/dresslog"


class LiveOptions(BaseModel):
    """`dresslog live`'s options.

    `wrench_topic` carries `geometry_msgs/msg/WrenchStamped`; the velocity comes from
    `twist_topic` (`TwistStamped`) or, differentiated as `convert` does, from `pose_topic`
    (`PoseStamped`), which a wrench in the gripper's axes needs in any case. `signal` places
    the signal as `convert`'s options do (frame, sensor mount, tare, rotation). The estimate
    is published under `prefix` in `frame_id`; the summary flags a total force above
    `high_force_n`. `wait_s`: how long a topic may stay silent at the start. `best_effort`
    subscribes as a sensor driver publishing best effort needs.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    task: Task
    model: Path | None = None
    wrench_topic: str
    twist_topic: str | None = None
    pose_topic: str | None = None
    signal: SignalOptions = SignalOptions()
    output: Path | None = None
    overwrite: bool = False
    connect: str | None = None
    high_force_n: float = HIGH_FORCE_N
    wait_s: float = WAIT_S
    frame_id: str = "world"
    prefix: str = PREFIX
    best_effort: bool = False

    @model_validator(mode="before")
    @classmethod
    def _checked(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        data = dict(data)
        data["task"] = task_of(data.get("task"), LiveError)
        signal = data.get("signal") or SignalOptions()
        if isinstance(signal, dict):
            signal = SignalOptions(**signal)
        if data.get("twist_topic") is None and data.get("pose_topic") is None:
            raise OptionError("give --twist-topic or --pose-topic: the model needs the velocity")
        if data.get("pose_topic") is None and (
            signal.wrench_frame == "pose" or signal.translate is not None
        ):
            what = "--wrench-frame pose" if signal.wrench_frame == "pose" else "--translate"
            raise OptionError(f"{what} needs the gripper's pose: give --pose-topic")
        for name in ("high_force_n", "wait_s"):
            value = data.get(name)
            if value is not None and not (math.isfinite(value) and value > 0):
                raise LiveError(f"{name} {value}: give a number above 0")
        topics = [data.get(k) for k in ("wrench_topic", "twist_topic", "pose_topic")]
        given = [t for t in topics if t is not None]
        if len(set(given)) != len(given):
            raise OptionError(f"one topic for two streams ({', '.join(given)}); give each its own")
        return data

    @classmethod
    def build(cls, task: Task | str, **options: Any) -> LiveOptions:
        """The options from flat keywords, as the command takes them: the signal's
        (`SignalOptions`' fields) go into `signal`."""
        signal = SignalOptions.take(options)
        return cls.model_validate(dict(options, task=task, signal=signal))

    @property
    def motion(self) -> str:
        """Where the velocity comes from: "twist", or "pose" (differentiated)."""
        return "twist" if self.twist_topic is not None else "pose"

    @property
    def topics(self) -> dict[str, str]:
        """Each stream's topic: wrench, and twist and/or pose."""
        given = {"wrench": self.wrench_topic, "twist": self.twist_topic, "pose": self.pose_topic}
        return {kind: topic for kind, topic in given.items() if topic is not None}
