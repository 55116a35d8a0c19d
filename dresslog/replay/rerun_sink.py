"""The Rerun sink: a replay as a Rerun recording, to an .rrd file or a live viewer.

Steps are buffered and sent column-wise (`send_columns`, one call per entity
per flush), never one log call per step per entity: a 700-step trial is a few
dozen calls. A file sink writes under a temporary name that is renamed only when
complete, with the colour scale fitted to the trial's ground truth; it flushes
every `FILE_FLUSH_STEPS` when it knows that scale from the start (a recorded
trial, or a converted log without truth), so a half-hour log is never held in
memory whole, and otherwise once at the end. A live sink flushes every few steps
with a fixed colour scale.
Rerun is imported lazily: `import dresslog.replay` stays cheap.
"""

from __future__ import annotations

import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from dresslog.errors import TrialWriteError
from dresslog.io import well_known as wk
from dresslog.io.files import (
    check_output,
    discard,
    discard_stale_temporaries,
    make_folders,
    printable,
    put_in_place,
    remove_folders,
    temporary_path,
)
from dresslog.replay import blueprint as bp
from dresslog.replay.colors import color_scale, heat_colors, legend
from dresslog.replay.metrics import MetricsSink
from dresslog.spec import Outcome, Task, task_of
from dresslog.trial import contact_vectors

if TYPE_CHECKING:
    import rerun as rr

    from dresslog.replay.engine import StepResult, TrialContext

APPLICATION_ID = "dresslog"


def application_id(task: Task | str) -> str:
    """One per task: a viewer keeps one layout per application, and a gown's (maps side by
    side, the arm's camera) would show a shorts trial opened beside it, and the reverse."""
    return f"{APPLICATION_ID}-{task_of(task, TrialWriteError).value}"


POINT_RADIUS = 0.01
LEGEND_RADIUS = 0.015
LABEL_COLOR = [255, 255, 255]
#: Contact arrows grow with force but saturate: ARROW_MAX m long, half of it at ARROW_HALF N.
ARROW_MAX = 0.08
ARROW_HALF = 0.5
ARROW_COLOR = [200, 30, 30]
#: The measured force on the gripper, drawn at it the same way but longer (its forces are
#: newtons, the limb's contacts tenths): GRIP_ARROW_MAX m long, half of it at GRIP_ARROW_HALF N.
GRIP_ARROW_MAX = 0.15
GRIP_ARROW_HALF = 2.0
#: Purple: the gripper's axes take red, green and blue, the limb's contacts red.
GRIP_ARROW_COLOR = [150, 60, 210]
#: The garment as a thin wireframe: a filled mesh in front of the ground-truth limb
#: would tint its heat map and skew the comparison with the estimate.
GARMENT_LINE_RADIUS = 0.0008
GARMENT_COLOR = [80, 120, 180, 110]
#: x, y, z in red, green, blue, as Rerun and RViz draw axes.
XYZ_COLORS = [[220, 50, 50], [40, 160, 60], [50, 100, 230]]
#: Colour scale where no ground truth fixes one (N): a live view, whose range is not
#: known in advance, a converted log, whose estimate alone would stretch any weak
#: force to the top of the scale, and a trial whose truth puts no force on the limb
#: (one cut short before the garment reaches it), which has no scale to fit.
FIXED_VMAX = 0.5
#: Stamps from here on (ns; September 2001) are wall-clock times, not times since a
#: start: a converted log that has them gets a `timestamp` timeline too.
EPOCH_STAMPS = 10**18
#: Steps a file sink sends at once (10 s at 100 Hz) when its colour scale is known from
#: the start: a 30-minute log held whole until the end peaked at 3.5 GB.
FILE_FLUSH_STEPS = 1000


@dataclass
class _Buffer:
    """Steps received since the last flush, as plain lists (cheap to append)."""

    step: list[int] = field(default_factory=list)
    t_ns: list[int] = field(default_factory=list)
    phi: list[np.ndarray] = field(default_factory=list)
    truth: list[np.ndarray | None] = field(default_factory=list)
    estimate: list[np.ndarray | None] = field(default_factory=list)
    rmse: list[float | None] = field(default_factory=list)
    pose: list[np.ndarray | None] = field(default_factory=list)
    contacts: list[np.ndarray | None] = field(default_factory=list)
    garment: list[np.ndarray | None] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.step)


class RerunSink:
    """Log a replay to Rerun; `RerunSink(path)` for a file, `RerunSink(recording=...)` live."""

    def __init__(
        self,
        path: str | Path | None = None,
        *,
        recording: rr.RecordingStream | None = None,
        flush_every: int | None = None,
        overwrite: bool = False,
    ) -> None:
        if (path is None) == (recording is None):
            raise ValueError("give either an output path or a live recording stream")
        self.path = None if path is None else Path(path)
        self.overwrite = overwrite  # an existing file at `path` is replaced only so
        self.recording = recording
        self.flush_every = flush_every if recording is not None else None
        self.vmax = self._initial_vmax()
        self._metrics = MetricsSink()
        self.context: TrialContext | None = None
        self._buf = _Buffer()
        self._tmp: Path | None = None
        self._made: list[Path] = []  # folders made for the file, removed again if it fails
        self._path_so_far: list[np.ndarray] = []
        self._edges: np.ndarray | None = None

    # -- sink protocol -----------------------------------------------------------
    def open(self, context: TrialContext) -> None:
        """Start a trial: a live view gets its blueprint and the static scene now; a file
        starts now when the colour scale is known from the trial, else as it closes.

        Raises:
            TrialWriteError: the output may not be written.
        """
        self.context = context
        self.vmax = self._initial_vmax()  # a second trial through the sink gets its own scale
        self._edges = _edges(context.garment_triangles)
        self._buf = _Buffer()
        self._path_so_far = []
        self._first_ns: int | None = None
        self._metrics.open(context)
        if self.path is not None:
            check_output(self.path, context.source_path, suffix=".rrd", overwrite=self.overwrite)
            if (vmax := _known_vmax(context)) is not None:  # else fitted as it closes
                self.vmax = vmax
                self._start_file()
        else:
            assert self.recording is not None
            self.recording.send_blueprint(self.blueprint())
            self._send_static()

    def write(self, result: StepResult) -> None:
        """Buffer the step; a live view (or a file already started) is sent a block of steps
        once enough have come."""
        b, s = self._buf, result.step
        if self._first_ns is None:
            self._first_ns = s.t_ns
        b.step.append(s.index)
        b.t_ns.append(s.t_ns)
        b.phi.append(s.phi)
        b.truth.append(s.truth)
        b.estimate.append(result.estimate)
        b.rmse.append(result.rmse)
        b.pose.append(s.pose)
        b.contacts.append(s.contacts)
        b.garment.append(s.garment)
        self._metrics.write(result)
        if (every := self._flush_size()) and len(b) >= every:
            self.flush()

    def _flush_size(self) -> int | None:
        """Steps sent at once: a live view's every few; a file's every FILE_FLUSH_STEPS
        once its recording has started (its colour scale known), else all as it closes."""
        if self.path is None:
            return self.flush_every
        return FILE_FLUSH_STEPS if self.recording is not None else None

    def close(self) -> None:
        """Send what is buffered, the path and the spec with the trial's RMSE; a file is
        written under its temporary name.

        Raises:
            TrialWriteError: Rerun cannot write the file.
        """
        self._metrics.close()
        if self.path is None:
            self.flush()
            if self.recording is not None:
                self._send_spec()  # now with the trial's RMSE
                self.recording.flush()
            return
        try:
            if self.recording is None:  # not streamed: the scale fits the truth just seen
                # calibrated on the truth, so a poor estimate cannot rescale it
                self.vmax = _fitted_vmax(_present(self._buf.truth)[1])
                self._start_file()
            rec = self.recording
            assert rec is not None
            self._send_static()
            self.flush()
            self._send_path()
            rec.flush()
            rec.disconnect()
        except RuntimeError as err:  # Rerun's own I/O errors (disk full, permissions)
            self.abort()
            raise TrialWriteError(f"could not write the recording: {err}", path=self.path) from None
        except BaseException:
            self.abort()
            raise
        finally:
            self.recording = None

    def _start_file(self) -> None:
        """The file's recording stream, saving to a temporary name beside the output."""
        import rerun as rr

        assert self.path is not None and self.context is not None
        self._made = make_folders(self.path)
        discard_stale_temporaries(self.path)  # a killed run's
        self._tmp = temporary_path(self.path)
        rec = rr.RecordingStream(
            application_id(self.context.metadata.task), recording_id=self._recording_id()
        )
        self.recording = rec
        try:
            rec.save(self._tmp, default_blueprint=self.blueprint())
        except RuntimeError as err:
            self.abort()
            raise TrialWriteError(f"could not write the recording: {err}", path=self.path) from None

    def commit(self) -> None:
        """Rename the finished file into place (a live view has nothing to move)."""
        if self.path is not None and self._tmp is not None:
            tmp, self._tmp = self._tmp, None
            put_in_place(tmp, self.path, overwrite=self.overwrite)
            self._made = []

    def abort(self) -> None:
        """Stop writing, remove the temporary file and the folders made for it."""
        if self.path is not None and self.recording is not None:
            self.recording.disconnect()
            self.recording = None
        if self._tmp is not None:
            discard(self._tmp)
        remove_folders(self._made)  # those still empty
        self._made = []

    def _initial_vmax(self) -> float | None:
        """A live view's fixed colour scale; a file's (None) is fitted to its truth as it closes."""
        return FIXED_VMAX if self.path is None else None

    def blueprint(self) -> Any:
        """The default layout, its camera framed on this trial's limb and gripper's start."""
        ctx = self.context
        assert ctx is not None
        points = None if ctx.limb_points is None else ctx.limb_points.points
        return bp.default_blueprint(
            ctx.has_estimate,
            points,
            ctx.has_truth,
            live=self.path is None,
            gripper_start=self._gripper_start(),
        )

    def _gripper_start(self) -> np.ndarray | None:
        """Where a file's gripper starts: from its trial, as a streamed file's layout is
        sent before any step, else from the steps; a live view's camera does without."""
        ctx = self.context
        if self.path is None or ctx is None:
            return None
        trial = ctx.trial
        if trial is not None and trial.pose is not None and len(trial.pose):
            return np.asarray(trial.pose.values[0, :3])
        poses = _present(self._buf.pose)[1]
        return None if poses is None else poses[0, :3]

    # -- logging -----------------------------------------------------------------
    def _recording_id(self) -> str:
        """Readable and unique: two replays of one trial (say, two models) never merge."""
        ctx = self.context
        name = printable(ctx.source_path.stem) if ctx and ctx.source_path else "live"
        return f"{name}-{uuid.uuid4().hex[:8]}"

    def _send_static(self) -> None:
        """Limb points and their colour key, the garment's and series' styles, the spec, once."""
        import rerun as rr

        rec, ctx = self.recording, self.context
        assert rec is not None and ctx is not None
        limb = ctx.limb_points
        if limb is not None:
            pts = np.asarray(limb.points, dtype=np.float32)
            # positions only: static colours would shadow every step's heat colours
            for present, path in (
                (ctx.has_truth, bp.TRUTH_LIMB),
                (ctx.has_estimate, bp.ESTIMATE_LIMB),
            ):
                if present:
                    rec.log(path, rr.Points3D(pts, radii=POINT_RADIUS), static=True)
            if self.vmax is not None:
                swatches, labels = legend(self.vmax)
                at = bp.legend_positions(pts, len(labels))
                key = rr.Points3D(at, radii=LEGEND_RADIUS, colors=swatches)
                rec.log(bp.LEGEND, key, static=True)
                below = at - [0, 0, 2.5 * LEGEND_RADIUS]
                text = rr.Points3D(below, radii=1e-4, colors=[LABEL_COLOR], labels=labels)
                rec.log(bp.LEGEND_LABELS, text, static=True)
        if self._edges is not None:
            style = rr.LineStrips3D.from_fields(radii=GARMENT_LINE_RADIUS, colors=GARMENT_COLOR)
            rec.log(bp.GARMENT, style, static=True)
        series = [
            (bp.EE_FORCE, ["fx", "fy", "fz"], XYZ_COLORS),
            (bp.EE_TORQUE, ["tx", "ty", "tz"], XYZ_COLORS),
            (bp.EE_VELOCITY, ["vx", "vy", "vz"], XYZ_COLORS),
        ]
        if ctx.has_truth:
            series.append((bp.TOTAL_TRUTH, ["ground truth"], [[90, 170, 255]]))
        if ctx.has_estimate:
            series.append((bp.TOTAL_ESTIMATE, ["estimate"], [[230, 90, 20]]))
        if ctx.has_truth and ctx.has_estimate:
            series.append((bp.RMSE, ["RMSE"], [[200, 30, 60]]))
        for path, names, colors in series:
            rec.log(path, rr.SeriesLines(names=names, colors=colors), static=True)
        self._send_spec()

    def _send_spec(self) -> None:
        import rerun as rr

        assert self.recording is not None
        text = rr.TextDocument(self._spec_text(), media_type="text/markdown")
        self.recording.log(bp.SPEC, text, static=True)

    def _spec_text(self) -> str:
        """What the trial is and what made the estimate, in a few lines above its metadata."""
        ctx = self.context
        assert ctx is not None
        md = ctx.metadata
        origin = md.source.get("file")
        if md.source.get("format") == wk.LIVE_FORMAT:  # a `dresslog live` session, or its file
            where = f" from `{printable(ctx.source_path.name)}`" if ctx.source_path else ""
            what = f"**{md.task.value}** trial{where}, live from ROS 2 {origin}"
        elif ctx.source_path:
            what = f"**{md.task.value}** trial from `{printable(ctx.source_path.name)}`"
            if origin:  # a robot's log: no simulation decided an outcome
                what += f", converted from `{printable(Path(str(origin)).name)}`"
            else:
                what += f", outcome {md.outcome.value}"
        else:  # the outcome is decided as the simulation ends; `record` prints it
            what = f"**{md.task.value}** trial, live simulation"
        if md.spec is not None:
            what += f": {md.spec.describe()}"
        if ctx.trial is not None and ctx.trial.limb_points is None:
            what += ". Drawn on the task's nominal limb: the log does not say where the limb was"
        lines = [what + "."]
        if ctx.has_estimate:
            lines.append(f"Estimate by model {ctx.model or '(given in code)'}.")
        m = self._metrics.metrics
        if m.rmse is not None and m.zero_rmse is not None:
            ratio = f" (ratio {m.ratio:.3f})" if m.ratio is not None else ""
            lines.append(
                f"Trial RMSE {m.rmse:.4g} N against {m.zero_rmse:.4g} N for an all-zero "
                f"estimate{ratio}."
            )
        vmax = f"{self.vmax:.3g} N" if self.vmax is not None else "auto"
        shared = " (one scale for truth and estimate)" if ctx.has_truth and ctx.has_estimate else ""
        # the top colour holds every force over vmax, the busiest steps' peaks among them
        lines.append(f"Colour: grey = no force, dark to bright = 0 to {vmax} and over{shared}.")
        # an outcome not known (a live simulation's, a robot's log's) and fields a trial
        # does not have (a log's spec, a success's failure reason) are left out, not shown
        hidden = {"software"} if md.outcome != Outcome.UNKNOWN else {"software", "outcome"}
        dump = md.model_dump_json(indent=1, exclude=hidden, exclude_none=True)
        return "\n\n".join(lines) + f"\n\n```json\n{dump}\n```"

    def flush(self) -> None:
        """Send the buffered steps column-wise and empty the buffer."""
        import rerun as rr

        b, rec = self._buf, self.recording
        if not len(b) or rec is None:
            return
        self._buf = _Buffer()
        vmax = self.vmax if self.vmax is not None else 1.0
        step = np.asarray(b.step, dtype=np.int64)
        t_ns = np.asarray(b.t_ns, dtype=np.int64)

        first = self._first_ns or 0
        wall = self._wall_clock(first)

        def index(mask: np.ndarray | None = None) -> list[rr.TimeColumn]:
            s, t = (step, t_ns) if mask is None else (step[mask], t_ns[mask])
            columns = [
                rr.TimeColumn(bp.STEP, sequence=s),
                rr.TimeColumn(bp.TIME, duration=(t - first).astype("timedelta64[ns]")),
            ]
            if wall is not None:
                stamps = (t + wall).astype("datetime64[ns]")
                columns.append(rr.TimeColumn(bp.TIMESTAMP, timestamp=stamps))
            return columns

        def send(path: str, mask: np.ndarray | None, columns: Any) -> None:
            rec.send_columns(path, indexes=index(mask), columns=columns)

        phi = np.stack(b.phi).astype(np.float64)
        send(bp.EE_FORCE, None, rr.Scalars.columns(scalars=phi[:, 0:3]))
        send(bp.EE_TORQUE, None, rr.Scalars.columns(scalars=phi[:, 3:6]))
        send(bp.EE_VELOCITY, None, rr.Scalars.columns(scalars=phi[:, 6:9]))
        for maps, limb, total in (
            (b.truth, bp.TRUTH_LIMB, bp.TOTAL_TRUTH),
            (b.estimate, bp.ESTIMATE_LIMB, bp.TOTAL_ESTIMATE),
        ):
            mask, stacked = _present(maps)
            if stacked is None:
                continue
            t, n = stacked.shape
            flat = stacked.reshape(-1)
            send(
                limb,
                mask,
                [
                    *rr.Points3D.columns(colors=heat_colors(flat, vmax)).partition([n] * t),
                    *rr.AnyValues.columns(**{bp.FORCE_FIELD: _rows(flat, t, n)}),
                ],
            )
            send(total, mask, rr.Scalars.columns(scalars=stacked.sum(axis=1, dtype=np.float64)))
        mask, rmse = _present(b.rmse)
        if rmse is not None:
            send(bp.RMSE, mask, rr.Scalars.columns(scalars=rmse))
        self._send_pose(b, phi, send)
        self._send_contacts(b, send)
        mask, garment = _present(b.garment)
        if garment is not None and self._edges is not None:
            g, e = len(garment), len(self._edges)
            segments = garment[:, self._edges].reshape(-1, 2, 3)  # (g * e, 2, 3)
            send(bp.GARMENT, mask, rr.LineStrips3D.columns(strips=segments).partition([e] * g))

    def _wall_clock(self, first_ns: int) -> int | None:
        """What to add to a stamp (ns) for its wall-clock time, if the trial has one.

        A converted log starts at 0 and records its source's first stamp (`start_ns`); a
        trial written otherwise may carry wall-clock stamps itself. Stamps after 2001
        are taken for wall-clock times.
        """
        ctx = self.context
        start = ctx.metadata.source.get("start_ns") if ctx is not None else None
        if isinstance(start, int) and start >= EPOCH_STAMPS:
            return start
        return 0 if first_ns >= EPOCH_STAMPS else None

    def _send_pose(self, b: _Buffer, phi: np.ndarray, send: Any) -> None:
        import rerun as rr

        mask, pose = _present(b.pose)
        if pose is None:
            return
        if not self._path_so_far:  # axes only where there is a pose to place them
            assert self.recording is not None
            self.recording.log(bp.EE, rr.TransformAxes3D(0.08), static=True)
        send(bp.EE, mask, rr.Transform3D.columns(translation=pose[:, :3], quaternion=pose[:, 3:7]))
        # the garment's pull on the gripper (world axes, as the wrench is), from where it is
        arrows = _arrows(pose[:, :3], phi[mask, 0:3], GRIP_ARROW_MAX, GRIP_ARROW_HALF,
                         GRIP_ARROW_COLOR, radius=0.004)  # fmt: skip
        send(bp.EE_FORCE_ARROW, mask, arrows)
        self._path_so_far.append(pose[:, :3])
        if self.path is None:  # a live view's path grows as it flushes; a file's is sent once
            self._send_path()

    def _send_path(self) -> None:
        """The gripper's path so far as one static line."""
        import rerun as rr

        if not self._path_so_far or self.recording is None:
            return
        path = np.concatenate(self._path_so_far)
        self.recording.log(
            bp.EE_PATH, rr.LineStrips3D([path], colors=[60, 60, 60], radii=0.002), static=True
        )

    def _send_contacts(self, b: _Buffer, send: Any) -> None:
        import rerun as rr

        mask = np.array([c is not None for c in b.contacts])
        if not mask.any():
            return
        items = [c for c in b.contacts if c is not None]
        counts = [len(c) for c in items]
        allc = np.concatenate(items)
        send(
            bp.CONTACTS,
            mask,
            rr.Points3D.columns(
                positions=allc["position"],
                radii=np.full(len(allc), 0.003),
                colors=np.tile(np.array([[20, 20, 20]], np.uint8), (len(allc), 1)),
            ).partition(counts),
        )
        arrows = _arrows(
            allc["position"], contact_vectors(allc), ARROW_MAX, ARROW_HALF, ARROW_COLOR
        )
        send(bp.CONTACT_FORCES, mask, arrows.partition(counts))


def _arrows(
    origins: np.ndarray,
    forces: np.ndarray,
    longest: float,
    half: float,
    color: list[int],
    radius: float | None = None,
) -> Any:
    """Arrows3D columns along `forces` (N, 3) from `origins`, growing with force but
    saturating: `longest` m long at most, half of it at `half` N."""
    import rerun as rr

    magnitude = np.linalg.norm(forces, axis=1, keepdims=True)
    length = longest * magnitude / (magnitude + half)
    return rr.Arrows3D.columns(
        origins=origins,
        vectors=forces * (length / np.maximum(magnitude, 1e-12)),
        colors=np.tile(np.array([color], np.uint8), (len(forces), 1)),
        radii=None if radius is None else np.full(len(forces), radius),
    )


def _known_vmax(context: TrialContext) -> float | None:
    """A file's colour scale before its first step, where the trial says it: fitted to
    the ground truth of its steps (as a file sink fits it at the end), or fixed without
    truth; None where only the steps will tell (no recorded trial)."""
    if not context.has_truth:
        return FIXED_VMAX
    trial = context.trial
    if trial is None or trial.force_map is None:
        return None
    maps = trial.force_map  # the steps' truth: the maps stamped at a step (`trial_steps`)
    return _fitted_vmax(maps.forces[np.isin(maps.t_ns, trial.measurements.t_ns)])


def _fitted_vmax(truth: np.ndarray | None) -> float:
    """The colour scale fitted to the ground truth, or a converted log's fixed one where
    there is no force to fit."""
    fitted = color_scale(truth)
    return FIXED_VMAX if fitted is None else fitted


def _present(items: Sequence[np.ndarray | float | None]) -> tuple[np.ndarray, np.ndarray | None]:
    """Mask of the steps that have this item, and those items stacked (None if no step has)."""
    mask = np.array([x is not None for x in items], dtype=bool)
    if not mask.any():
        return mask, None
    return mask, np.stack([x for x in items if x is not None])


def _rows(flat: np.ndarray, t: int, n: int) -> Any:
    """`t` rows of `n` values as an Arrow list array: Rerun takes it without a Python loop."""
    import pyarrow as pa

    offsets = np.arange(0, t * n + 1, n, dtype=np.int32)
    return pa.ListArray.from_arrays(pa.array(offsets), pa.array(flat))


def _edges(triangles: np.ndarray | None) -> np.ndarray | None:
    """Each edge of a triangle mesh once, (E, 2) vertex indices; None without a mesh."""
    if triangles is None or not len(triangles):
        return None
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    pairs = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    return np.unique(np.sort(pairs, axis=1), axis=0)
