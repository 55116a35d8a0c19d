"""What a reader of an external log hands the converter: raw streams on the source's clock."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dresslog.io import well_known as wk

#: The kinds of stream a converter looks for, and the ROS 2 message type of each.
MESSAGE_TYPES = {
    kind: wk.SCHEMAS[topic]
    for kind, topic in (("wrench", wk.WRENCH), ("twist", wk.TWIST), ("pose", wk.POSE))
}
#: Each kind's values per sample: force+torque, linear+angular, position+quaternion (x y z w).
COMPONENTS = {
    "wrench": ("force x", "force y", "force z", "torque x", "torque y", "torque z"),
    "twist": ("linear x", "linear y", "linear z", "angular x", "angular y", "angular z"),
    "pose": ("position x", "position y", "position z", "qx", "qy", "qz", "qw"),
}
WIDTHS = {kind: len(names) for kind, names in COMPONENTS.items()}


def stamps_unset(stamps: np.ndarray) -> bool:
    """Header stamps left 0 by a driver that never fills them, for the bag's log times to
    stand in. A clock that starts at 0, as simulation time does, may stamp the first message
    0, and only that one."""
    return bool((stamps[1:] == 0).any())


def unset_note(name: str) -> str:
    """The note on a stream (or tf link) timed by the bag's log times for want of stamps."""
    return f"{name}: header stamps unset, used the bag's log times"


@dataclass
class SourceStream:
    """One measured signal as recorded: `t_ns` (T,) int64 on the source clock, `values` (T, D)."""

    kind: str
    name: str
    t_ns: np.ndarray
    values: np.ndarray
    frame_id: str = ""
    clock: str = "header"
    #: a bag's own receive times (T,), beside header stamps: how far apart the clocks are
    log_ns: np.ndarray | None = None
    #: False for a pose whose orientation the log lacks (filled in as the identity)
    has_orientation: bool = True
    #: the message type read, where not the kind's own (a pose built from tf)
    msgtype: str = ""
    #: the messages read for it, where they are not one a sample (a pose from tf: every
    #: TFMessage of the bag's tf topics); 0 for one a sample
    messages: int = 0

    @property
    def message_count(self) -> int:
        return self.messages or len(self)

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass(frozen=True)
class SensorMount:
    """Where a bag's tf tree fixes the wrench's header frame in the gripper's frame: the
    sensor's origin (m) and axes (x y z w) there, which `--wrench-frame pose` takes as
    `--sensor-offset` and `--sensor-rotation` when neither is given."""

    frame: str
    gripper: str
    offset: tuple[float, float, float]
    rotation: tuple[float, float, float, float]

    def describe(self) -> str:
        offset = ", ".join(f"{v:+.4g}" for v in self.offset)
        rotation = ", ".join(f"{v:+.4g}" for v in self.rotation)
        return (
            f"the wrench's frame {self.frame} is fixed on {self.gripper} in the tf tree, at "
            f"({offset}) m turned ({rotation}): taken as --sensor-offset and "
            "--sensor-rotation"
        )


@dataclass
class Source:
    """The streams found in one external log, before resampling."""

    path: Path
    format: str
    wrench: SourceStream
    twist: SourceStream | None = None
    pose: SourceStream | None = None
    notes: list[str] = field(default_factory=list)
    #: what reading found worth a warning (a CSV's last line cut off), for `convert` to report
    warnings: list[str] = field(default_factory=list)
    #: where the tf tree fixes the wrench's sensor on the gripper (`--pose-tf`), if it does
    sensor_mount: SensorMount | None = None

    @property
    def streams(self) -> list[SourceStream]:
        return [s for s in (self.wrench, self.twist, self.pose) if s is not None]

    @property
    def message_count(self) -> int:
        return sum(s.message_count for s in self.streams)
