"""The MCAP sink: a copy of the replayed trial with `/limb/force_map/estimate` added.

The copy is written through `TrialWriter` from the decoded trial, so it is a
well-formed dresslog file (same metadata, every stream, new estimate channel
replacing any old one) and appears under its name only when complete. The trial
is copied as the replay opens and the estimate written every `FLUSH_STEPS`, so a
long log's estimate is never held whole.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from dresslog.errors import TrialWriteError
from dresslog.io import well_known as wk
from dresslog.io.files import check_output
from dresslog.io.reader import summary_counts
from dresslog.io.writer import TrialWriter
from dresslog.trial import LimbPoints, Trial

if TYPE_CHECKING:
    from dresslog.replay.engine import StepResult, TrialContext

#: Estimates written at once (10 s at 100 Hz): a 30-minute log's, held to the end and
#: encoded at once, took over a GB.
FLUSH_STEPS = 1000


class McapSink:
    """Copy the trial as it opens; write the estimates in blocks as they come."""

    def __init__(self, path: str | Path, *, overwrite: bool = False) -> None:
        self.path = Path(path)
        self.overwrite = overwrite  # an earlier estimate copy is replaced only so
        self._writer: TrialWriter | None = None  # the copy being written, until `close`
        self._t_ns: list[int] = []
        self._forces: list[np.ndarray] = []
        self._contact: list[np.ndarray] = []
        self._finished: TrialWriter | None = None  # the finished copy's, until `commit`

    def open(self, context: TrialContext) -> None:
        """Start the copy: the trial's own channels written at once, under a temporary name.

        Raises:
            TrialWriteError: the source is no recorded trial, or the output may not be
                written.
        """
        if context.trial is None:
            raise TrialWriteError("an MCAP copy needs a recorded trial as source", path=self.path)
        check_copy_output(self.path, context.source_path, overwrite=self.overwrite)
        trial, limb = context.trial, context.limb_points
        self._t_ns, self._forces, self._contact = [], [], []
        self._writer = TrialWriter(self.path, trial.metadata, overwrite=self.overwrite)
        self._writing(lambda writer: copy_trial(writer.open(), trial, limb))

    def write(self, result: StepResult) -> None:
        """Keep the step's estimate; every FLUSH_STEPS of them go to the copy as one block."""
        if result.estimate is None or result.contact is None:
            return
        self._t_ns.append(result.step.t_ns)
        self._forces.append(result.estimate)
        self._contact.append(result.contact)
        if len(self._t_ns) >= FLUSH_STEPS:
            self._writing(self._flush)

    def close(self) -> None:
        """Write the last block and finish the copy, still under its temporary name."""

        def finish(writer: TrialWriter) -> None:
            self._flush(writer)
            writer.finish()  # named by `commit`, beside the other outputs

        self._writing(finish)
        self._finished, self._writer = self._writer, None

    def _flush(self, writer: TrialWriter) -> None:
        """The estimates received since the last block, to the copy."""
        if self._t_ns:
            t_ns, forces, contact = self._t_ns, self._forces, self._contact
            self._t_ns, self._forces, self._contact = [], [], []
            writer.write_force_map(
                np.asarray(t_ns, dtype=np.int64),
                np.stack(forces),
                np.stack(contact),
                estimate=True,
            )

    def _writing(self, work: Callable[[TrialWriter], object]) -> None:
        """Do `work` on the open copy; if it fails, nothing of the copy is left."""
        writer = self._writer
        assert writer is not None
        try:
            work(writer)
        except BaseException as err:  # an interrupt while finishing included
            writer.abort()
            self._writer = None
            writer.name_a_full_disk(err)
            raise

    def commit(self) -> None:
        """Rename the finished copy into place."""
        if self._finished is not None:
            self._finished.place()
            self._finished = None

    def abort(self) -> None:
        """Drop the copy, half-written or finished and not yet named, and the folders
        made for it."""
        for writer in (self._writer, self._finished):
            if writer is not None:
                writer.abort()
        self._writer = self._finished = None


def check_copy_output(path: Path, source: Path | None, *, overwrite: bool) -> None:
    """Fail before any work if the estimate copy cannot go to `path`: a trial recorded or
    converted there is never replaced, an earlier copy only with `overwrite`."""
    check_output(path, source, suffix=".mcap")  # its name and folder
    if path.exists() and not _holds_an_estimate(path):
        raise TrialWriteError(
            "exists and is not an earlier estimate copy (a recording?); give --mcap-out "
            "another name (or folder), or delete it first",
            path=path,
        )
    check_output(path, source, suffix=".mcap", overwrite=overwrite)


def _holds_an_estimate(path: Path) -> bool:
    """Whether `path` is what this sink writes, so a re-run may replace it; from its
    summary, as a whole read of a 30-minute copy peaked at 600 MB and stayed held."""
    return (summary_counts(path) or {}).get(wk.ESTIMATE, 0) > 0


def copy_trial(writer: TrialWriter, trial: Trial, limb: LimbPoints | None = None) -> None:
    """Every stream of `trial` except an old estimate, in bulk where the writer allows.

    `limb` says where the estimate's points are when the trial has no limb points of
    its own: a converted log gets the nominal limb its estimate was drawn on.
    """
    limb = trial.limb_points if trial.limb_points is not None else limb
    if limb is not None:
        writer.write_limb_points(int(trial.wrench.t_ns[0]), limb)
    writer.write_wrench(trial.wrench.t_ns, trial.wrench.values)
    writer.write_twist(trial.twist.t_ns, trial.twist.values)
    if trial.pose is not None:
        writer.write_pose(trial.pose.t_ns, trial.pose.values)
    if trial.force_map is not None:
        fm = trial.force_map
        writer.write_force_map(fm.t_ns, fm.forces, fm.contact if fm.contact.size else None)
    if trial.contacts is not None:
        for t, items in zip(trial.contacts.t_ns.tolist(), trial.contacts.items, strict=True):
            writer.write_contacts(t, items)
    if trial.garment is not None:
        g = trial.garment
        for i, t in enumerate(g.t_ns.tolist()):
            writer.write_garment(t, g.vertices[i], g.triangles if i == 0 else None)
