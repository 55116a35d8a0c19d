"""Record one simulated trial to an MCAP file through `TrialWriter`.

A trial that goes unstable raises `SimulationError`; the writer's exception
path removes its temporary file, so no file appears under the final name.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.io.writer import TrialWriter
from dresslog.sim.simulate import SimResult, SimStart, SimStep, StepSink, simulate
from dresslog.spec import TrialMetadata, TrialSpec


class WriterSink:
    """Hands contacts and garment states to the writer in batches, the rest at the end.

    Contacts and garment states go to the writer in step order, `BATCH` steps at a
    time (and at `flush`); wrench, twist, pose and force map are held and written
    whole in `flush`: writing in bulk, rather than between physics steps, is much
    cheaper, and the file is the same.
    """

    #: Steps whose contacts and garment states are held before they are written.
    BATCH = 250

    def __init__(self, writer: TrialWriter) -> None:
        self.writer = writer
        self._triangles: np.ndarray | None = None
        self._t: list[int] = []
        self._wrench: list[np.ndarray] = []
        self._twist: list[np.ndarray] = []
        self._pose: list[np.ndarray] = []
        self._fmap: list[np.ndarray] = []
        self._pending: list[tuple[int, np.ndarray, np.ndarray | None]] = []

    def start(self, info: SimStart) -> None:
        self.writer.write_limb_points(0, info.limb_points)
        self._triangles = info.triangles

    def step(self, step: SimStep) -> None:
        self._t.append(step.t_ns)
        self._wrench.append(step.wrench)
        self._twist.append(step.twist)
        self._pose.append(step.pose)
        self._fmap.append(step.force_map)
        self._pending.append((step.t_ns, step.contacts, step.garment))
        if len(self._pending) >= self.BATCH:
            self._write_pending()

    def _write_pending(self) -> None:
        """Write the held contacts and garment states, in step order."""
        writer = self.writer
        for t_ns, contacts, garment in self._pending:
            writer.write_contacts(t_ns, contacts)
            if garment is not None:
                writer.write_garment(t_ns, garment, self._triangles)
                self._triangles = None
        self._pending.clear()

    def flush(self) -> None:
        self._write_pending()
        if not self._t:
            return
        t = np.asarray(self._t, dtype=np.int64)
        self.writer.write_wrench(t, np.asarray(self._wrench))
        self.writer.write_twist(t, np.asarray(self._twist))
        self.writer.write_pose(t, np.asarray(self._pose))
        self.writer.write_force_map(t, np.asarray(self._fmap, dtype=np.float32))


class ProgressBar:
    """A `simulate()` sink drawing the recorded steps on a progress bar (on a terminal only).

    Use as a context manager, which closes the bar. A 7 s trial takes seconds, but a
    long one (`--duration 600`) a minute or more, with nothing else to show for it.
    """

    def __init__(self) -> None:
        self._bar: Any = None

    def start(self, info: SimStart) -> None:
        from tqdm import tqdm

        total = round(info.spec.duration * info.spec.sim.record_hz)
        # disable=None: no bar when stderr is not a terminal (a log file, a test)
        self._bar = tqdm(total=total, unit="step", desc=info.spec.task.value, disable=None)

    def step(self, step: SimStep) -> None:
        self._bar.update()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()


class FanOut:
    """One `simulate()` sink that forwards to several (e.g. the recorder and a live view)."""

    def __init__(self, *sinks: StepSink) -> None:
        self.sinks = sinks

    def start(self, info: SimStart) -> None:
        for sink in self.sinks:
            sink.start(info)

    def step(self, step: SimStep) -> None:
        for sink in self.sinks:
            sink.step(step)


def record_trial(
    spec: TrialSpec,
    path: str | Path,
    *,
    overwrite: bool = False,
    sinks: Sequence[StepSink] = (),
    progress: bool = False,
) -> SimResult:
    """Simulate `spec` and write it to `path` (atomically); `sinks` see every step too.

    `progress` draws the steps on a progress bar when stderr is a terminal.
    """
    metadata = TrialMetadata(task=spec.task, spec=spec)
    with TrialWriter(path, metadata, overwrite=overwrite) as writer, ProgressBar() as bar:
        sink = WriterSink(writer)
        sinks = [sink, *sinks, *([bar] if progress else [])]
        result = simulate(spec, FanOut(*sinks) if len(sinks) > 1 else sink)
        sink.flush()
        writer.metadata = metadata.model_copy(
            update={"outcome": result.outcome, "caught_on": result.caught_on}
        )
    return result
