"""The MCAP sink: a copy of the replayed trial with `/limb/force_map/estimate` added.

The copy is written through `TrialWriter` from the decoded trial, so it is a
well-formed dresslog file (same metadata, every stream, new estimate channel
replacing any old one) and appears under its name only when complete.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from dresslog.errors import TrialFormatError, TrialWriteError
from dresslog.io import well_known as wk
from dresslog.io.files import check_output
from dresslog.io.reader import TrialReader
from dresslog.io.writer import TrialWriter
from dresslog.trial import LimbPoints, Trial

if TYPE_CHECKING:
    from dresslog.replay.engine import StepResult, TrialContext


class McapSink:
    """Buffer the estimates; on close write the trial and the estimate channel in bulk."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._trial: Trial | None = None
        self._limb: LimbPoints | None = None
        self._t_ns: list[int] = []
        self._forces: list[np.ndarray] = []
        self._contact: list[np.ndarray] = []
        self._finished: TrialWriter | None = None  # the finished copy's, until `commit`

    def open(self, context: TrialContext) -> None:
        if context.trial is None:
            raise TrialWriteError("an MCAP copy needs a recorded trial as source", path=self.path)
        check_output(self.path, context.source_path, suffix=".mcap")
        if self.path.exists() and not _holds_an_estimate(self.path):
            raise TrialWriteError(
                "exists and is not an earlier estimate copy (a recording?); give --mcap-out "
                "another name (or folder), or delete it first",
                path=self.path,
            )
        self._trial = context.trial
        self._limb = context.limb_points
        self._t_ns, self._forces, self._contact = [], [], []

    def write(self, result: StepResult) -> None:
        if result.estimate is None or result.contact is None:
            return
        self._t_ns.append(result.step.t_ns)
        self._forces.append(result.estimate)
        self._contact.append(result.contact)

    def close(self) -> None:
        trial = self._trial
        assert trial is not None
        writer = TrialWriter(self.path, trial.metadata, overwrite=True)
        try:
            writer.open()
            copy_trial(writer, trial, self._limb)
            if self._t_ns:
                writer.write_force_map(
                    np.asarray(self._t_ns, dtype=np.int64),
                    np.stack(self._forces),
                    np.stack(self._contact),
                    estimate=True,
                )
            writer.finish()  # named by `commit`, beside the other outputs
            self._finished = writer
        except BaseException as err:  # an interrupt while finishing included
            writer.abort()
            writer.name_a_full_disk(err)
            raise

    def commit(self) -> None:
        if self._finished is not None:
            self._finished.place()
            self._finished = None

    def abort(self) -> None:
        """Drop the finished copy not yet named, and the folders made for it; `close`
        removes a half-written one itself."""
        if self._finished is not None:
            self._finished.abort()
        self._finished = None


def _holds_an_estimate(path: Path) -> bool:
    """Whether `path` is what this sink writes, so a re-run may replace it."""
    try:
        with TrialReader(path) as reader:
            return reader.has(wk.ESTIMATE)
    except TrialFormatError:
        return False


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
