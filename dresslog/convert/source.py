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
#: Values per sample of each kind: force+torque, linear+angular, position+quaternion (x y z w).
WIDTHS = {"wrench": 6, "twist": 6, "pose": 7}


@dataclass
class SourceStream:
    """One measured signal as recorded: `t_ns` (T,) int64 on the source clock, `values` (T, D)."""

    kind: str
    name: str
    t_ns: np.ndarray
    values: np.ndarray
    frame_id: str = ""
    clock: str = "header"

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass
class Source:
    """The streams found in one external log, before resampling."""

    path: Path
    format: str
    wrench: SourceStream
    twist: SourceStream | None = None
    pose: SourceStream | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def streams(self) -> list[SourceStream]:
        return [s for s in (self.wrench, self.twist, self.pose) if s is not None]

    @property
    def message_count(self) -> int:
        return sum(len(s) for s in self.streams)
