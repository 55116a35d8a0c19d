"""`SessionRecorder`: a live session written as a dresslog trial, in blocks, put in place at
the end.

The file holds what `convert` would write for the same signal (`/ee/wrench`, `/ee/twist`,
`/ee/pose`: the 100 Hz steps the model ran on, placed in its frame), the estimate as
`dresslog infer` writes it (`/limb/force_map/estimate`), the limb's points, and the samples
as they arrived (`/received/*`, standard messages in the robot's frames). It is written
under a temporary name by `TrialWriter` as the session goes, so a 30-minute session is
never held whole, and named only when finished (on Ctrl-C or SIGTERM too).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dresslog.io.writer import TrialWriter
from dresslog.replay.engine import StepResult
from dresslog.spec import Outcome, Task, TrialMetadata
from dresslog.trial import LimbPoints

#: Steps held before they are written (5 s at 100 Hz): few pauses, little memory.
FLUSH_STEPS = 500


class SessionRecorder:
    """Record one live session to `path` (a `.mcap` trial)."""

    def __init__(self, path: str | Path, task: Task, *, overwrite: bool = False) -> None:
        self.path = Path(path)
        # the metadata is written at the end, when the session's source is known
        self._writer = TrialWriter(self.path, TrialMetadata(task=task), overwrite=overwrite)
        self._writer.open()  # a bad output fails now, before anything is subscribed
        self.origin_ns: int | None = None
        self._received: dict[str, tuple[list[int], list[np.ndarray], str]] = {}
        self._steps: list[tuple[int, np.ndarray, np.ndarray, np.ndarray | None]] = []
        self._estimates: list[tuple[int, np.ndarray, np.ndarray]] = []

    def received(self, kind: str, t_ns: int, values: np.ndarray, frame_id: str) -> None:
        """One sample as it arrived, on the robot's clock (kept until session time 0 is set)."""
        times, rows, _ = self._received.setdefault(kind, ([], [], frame_id))
        times.append(t_ns)
        rows.append(values)

    def start(self, origin_ns: int, limb: LimbPoints) -> None:
        """Session time 0 is `origin_ns` on the robot's clock; the limb the estimate is on."""
        self.origin_ns = origin_ns
        self._writer.write_limb_points(0, limb)

    def step(
        self,
        result: StepResult,
        wrench: np.ndarray,
        twist: np.ndarray,
        pose: np.ndarray | None,
    ) -> None:
        """One 100 Hz step as the model got it (placed `wrench`, `twist`, `pose`) and what
        it made of it (`result`, at session time `result.step.t_ns`)."""
        t_ns = result.step.t_ns
        self._steps.append((t_ns, wrench, twist, pose))
        if result.estimate is not None and result.contact is not None:
            self._estimates.append((t_ns, result.estimate, result.contact))
        if len(self._steps) >= FLUSH_STEPS:
            self.flush()

    def flush(self) -> None:
        """Write what was held; samples stamped before session time 0 are kept apart."""
        writer, origin = self._writer, self.origin_ns
        if origin is None:
            return
        if self._steps:
            t_ns = np.array([s[0] for s in self._steps], dtype=np.int64)
            writer.write_wrench(t_ns, np.stack([s[1] for s in self._steps]))
            writer.write_twist(t_ns, np.stack([s[2] for s in self._steps]))
            if self._steps[0][3] is not None:
                writer.write_pose(t_ns, np.stack([s[3] for s in self._steps]))  # type: ignore[misc]
            self._steps = []
        if self._estimates:
            t_ns = np.array([e[0] for e in self._estimates], dtype=np.int64)
            forces = np.stack([e[1] for e in self._estimates])
            writer.write_force_map(
                t_ns, forces, np.stack([e[2] for e in self._estimates]), estimate=True
            )
            self._estimates = []
        for kind, (times, rows, frame) in self._received.items():
            if times:
                t_ns = np.asarray(times, dtype=np.int64) - origin
                writer.write_received(kind, t_ns, np.stack(rows), frame)
                times.clear()
                rows.clear()

    def finish(self, source: dict[str, object]) -> Path:
        """Write the rest and the metadata (with `source`), and name the file."""
        try:
            self.flush()
            self._writer.metadata = TrialMetadata(
                task=self._writer.metadata.task, outcome=Outcome.UNKNOWN, source=source
            )
            self._writer.finish()
            self._writer.place()
        except BaseException as err:
            self._writer.abort()
            self._writer.name_a_full_disk(err)
            raise
        return self.path

    def abort(self) -> None:
        """Drop the session file: its temporary is removed, nothing takes the final name."""
        self._writer.abort()
