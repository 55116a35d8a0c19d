"""`convert()`: an external log (ROS 1/2 bag, bare ROS 2 MCAP, F/T CSV) as a dresslog trial.

The steps: read the wrench, twist and pose streams on the source's clock
(`rosbag.read_bag`, `csv.read_csv`), check their timestamps, resample them
onto one 100 Hz grid over the span they all cover (`resample`), optionally
tare, turn the wrench by the pose, rotate and translate, and write a trial with
`TrialWriter`, which only puts the file in place when everything succeeded.

Time: the output starts at 0 ns; the source time of output time t is
`t + source["start_ns"]`, recorded in the metadata with the topics, rates
and every processing step, so a converted trial says where it came from.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel

from dresslog.convert import resample as rs
from dresslog.convert.checks import (
    beyond_dressing,
    check_stream,
    check_turnable,
    frames_differ,
    log_warnings,
    put_in_time_order,
    tare_mistake,
    unneeded_pose_without_orientation,
)
from dresslog.convert.source import MESSAGE_TYPES, Source, SourceStream
from dresslog.errors import ConversionError, DresslogWarning
from dresslog.io.files import NOT_REGULAR, check_output, no_such, printable
from dresslog.io.writer import TrialWriter
from dresslog.spec import MAX_DURATION, Outcome, Task, TrialMetadata, task_of

MAX_GAP_S = 0.1
#: Farthest a wrist sensor's origin sits from the gripper centre, m: it is on the gripper.
MAX_SENSOR_OFFSET = 2.0
#: Farthest --translate moves a pose, m: a robot's base is not kilometres from the limb,
#: and a pose stored as float32 keeps millimetres only this near.
MAX_TRANSLATE = 1000.0
CSV_SUFFIXES = (".csv", ".tsv", ".txt")
Quaternion = tuple[float, float, float, float]


class ConversionWarning(DresslogWarning):
    """Something in the log deserves a look but does not stop the conversion (e.g. a gap)."""


class ConversionReport(BaseModel):
    """What `convert` did: the output, its size, the source description and any warnings."""

    output: str
    steps: int
    duration_s: float
    messages_in: int
    elapsed_s: float
    source: dict[str, object]
    warnings: list[str]


def load(
    path: str | Path,
    *,
    wrench_topic: str | None = None,
    twist_topic: str | None = None,
    pose_topic: str | None = None,
    pose_tf: str | None = None,
    motion: str | Path | None = None,
    columns: Mapping[str, str] | None = None,
    time_unit: str | None = None,
    clock: Literal["header", "log"] = "header",
) -> Source:
    """Read an external log of any supported kind, chosen by what `path` is."""
    path, motion = Path(path), None if motion is None else Path(motion)
    if not path.exists():
        raise ConversionError(no_such(path, "file or folder"), path=path)
    for named in (path, motion):  # a pipe is read once: the sniffing would consume it
        if named is not None and named.exists() and not named.is_file() and not named.is_dir():
            raise ConversionError(NOT_REGULAR, path=named)
    suffix = path.suffix.lower()
    is_csv = suffix in CSV_SUFFIXES and path.is_file()
    given: dict[str, object] = {"--motion": motion, "--column": columns, "--time-unit": time_unit}
    if is_csv:
        given = {"--wrench-topic": wrench_topic, "--twist-topic": twist_topic}
        given |= {"--pose-topic": pose_topic, "--pose-tf": pose_tf, "--clock log": clock == "log"}
    if unused := [option for option, value in given.items() if value]:
        what = "bags, not to a CSV" if is_csv else "a CSV, not to a bag"
        raise ConversionError(f"{', '.join(unused)}: applies to {what}; leave it out", path=path)
    if is_csv:
        from dresslog.convert.csv import read_csv

        if motion is not None and not motion.is_file():  # as the log itself is told
            problem = "is a folder" if motion.is_dir() else "no such file"
            if not motion.is_dir() and motion.is_symlink():  # where it leads says enough
                raise ConversionError(no_such(motion), path=motion)
            raise ConversionError(f"{problem}; --motion takes a CSV file", path=motion)
        return read_csv(path, motion=motion, columns=columns, time_unit=time_unit)
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise ConversionError("folder has no metadata.yaml, so it is not a ROS 2 bag", path=path)
    if suffix == ".db3":
        raise ConversionError(
            "pass the ROS 2 bag folder (with metadata.yaml), not its .db3 file", path=path
        )
    if not (path.is_dir() or suffix in (".bag", ".mcap")):
        raise ConversionError(
            "unknown input; expected a ROS 1 .bag, a ROS 2 bag folder, an .mcap file or a CSV",
            path=path,
        )
    from dresslog.convert.rosbag import read_bag

    return read_bag(
        path, wrench_topic=wrench_topic, twist_topic=twist_topic, pose_topic=pose_topic,
        pose_tf=pose_tf, clock=clock,
    )  # fmt: skip


def _span(stream: SourceStream) -> str:
    return f"{stream.name} {stream.t_ns[0] / 1e9:.3f}-{stream.t_ns[-1] / 1e9:.3f} s"


def _readable(seconds: float) -> str:
    """A long span as a person reads it: `7260 s (2 h 1 min)`, `1.7e+09 s (19676 days)`."""
    minutes = round(seconds / 60)
    if minutes >= 48 * 60:
        return f"{seconds:.3g} s ({minutes / 1440:.0f} days)"
    return f"{seconds:.0f} s ({minutes // 60} h {minutes % 60} min)"


def common_grid(
    source: Source,
    time_unit: str | None = None,
    start_s: float = 0.0,
    end_s: float | None = None,
) -> np.ndarray:
    """The 100 Hz grid over the time every stream covers (an averaged wrench needs half a bin
    spare), or over its steps from `start_s` up to `end_s` (s from its first step, a
    half-open window), before the duration cap is checked; `time_unit`, a CSV's as given,
    to name in an error.

    An averaged wrench's bin edges fall midway between its samples: on a sample, a
    few microseconds of clock jitter would move it between bins and let vibration
    above 50 Hz leak into the means.
    """
    averaged = rs.averages(source.wrench.t_ns)
    half = rs.PERIOD_NS // 2 if averaged else 0
    start = max(int(s.t_ns[0]) + (half if s is source.wrench else 0) for s in source.streams)
    stop = min(int(s.t_ns[-1]) - (half if s is source.wrench else 0) for s in source.streams)
    if averaged:
        t = source.wrench.t_ns
        phase = int(t[0]) + half + int(np.median(np.diff(t))) // 2
        start += (phase - start) % rs.PERIOD_NS
    windowed = start_s > 0 or end_s is not None
    if windowed and stop - start >= rs.PERIOD_NS:  # else too short or apart: said below
        start, stop = _window(source, start, stop, start_s, end_s)
    if (stop - start) / 1e9 > MAX_DURATION:  # else a grid of billions of steps, or junk
        if windowed:  # --start alone: --end is checked against the cap before the log is read
            raise ConversionError(
                f"--start {start_s:g} s leaves {_readable((stop - start) / 1e9)} of the log, "
                f"more than the {MAX_DURATION:g} s a trial may last: give --end too, an hour "
                "or less after --start",
                path=source.path,
            )
        raise ConversionError(
            f"the log spans {_readable((stop - start) / 1e9)} "
            f"({'; '.join(dict.fromkeys(map(_span, source.streams)))}), more than the "
            f"{MAX_DURATION:g} s a trial may last: give --start and --end to convert an hour "
            "or less of it (or, if it is short, look for a stamp of 0 among clock times, or "
            "two logs in one)",
            path=source.path,
        )
    grid = rs.grid(start, stop)
    if len(grid) < 2:
        first = max(int(s.t_ns[0]) for s in source.streams)
        overlap = (min(int(s.t_ns[-1]) for s in source.streams) - first) / 1e9
        spans = "; ".join(_span(s) for s in source.streams)
        if overlap >= 0:  # too short (or times read in too large a unit), not two clocks
            one = len({s.name for s in source.streams}) == 1
            what = "log covers" if one else f"streams ({spans}) share"
            unit = ""
            if source.format == "csv":
                unit = (
                    f"; are its times in {time_unit}, as --time-unit {time_unit} says?"
                    if time_unit
                    else "; if the times are in another unit, give --time-unit"
                )
            raise ConversionError(
                f"the {what} {overlap:.3g} s, less than two 100 Hz steps{unit}", path=source.path
            )
        on_log = all(s.clock == "log" for s in source.streams)
        hint = (
            ""
            if source.format == "csv" or on_log
            else "; or use the bag's receive times: --clock log"
        )
        raise ConversionError(
            f"streams do not overlap in time ({spans}); they must share one clock{hint}",
            path=source.path,
        )
    return grid


def _step_at(seconds: float) -> int:
    """The first grid step at or after `seconds` from the grid's start."""
    return -(-round(seconds * 1e9) // rs.PERIOD_NS)


def _window(
    source: Source, start: int, stop: int, start_s: float, end_s: float | None
) -> tuple[int, int]:
    """The first and last grid times of the steps from `start_s` up to `end_s` (s from the
    grid's first step, `start`), which must lie within the grid, that is, up to `stop`."""
    steps = (stop - start) // rs.PERIOD_NS + 1
    span = f"every stream covers 0-{steps / rs.RATE_HZ:.2f} s of it"
    past = steps / rs.RATE_HZ + 1  # beyond the log: refused, whatever it is (1e300 s)
    first = _step_at(min(start_s, past))
    end = steps if end_s is None else _step_at(min(end_s, past))
    if end > steps:
        raise ConversionError(
            f"--end {end_s:g} s is past the log's end: {span}; give --end "
            f"{steps / rs.RATE_HZ:.2f} or less",
            path=source.path,
        )
    if end - first < 2:
        raise ConversionError(
            f"--start {start_s:g} s leaves less than two steps of the log: {span}; give "
            f"--start {(steps - 2) / rs.RATE_HZ:.2f} or less",
            path=source.path,
        )
    return start + first * rs.PERIOD_NS, start + (end - 1) * rs.PERIOD_NS


def _resampling(t_ns: np.ndarray) -> str:
    """How `rs.resample` brings a stream with these times onto the grid."""
    if rs.averages(t_ns):
        return "mean over 10 ms bins"
    return "linear interpolation"


def _describe(stream: SourceStream, source: Source) -> dict[str, object]:
    out: dict[str, object] = {
        "messages": stream.message_count,
        "rate_hz": round(rs.median_rate(stream.t_ns), 3),
        "clock": stream.clock,
    }
    if source.format == "csv":
        out["file"] = stream.name
    else:
        out |= {"topic": stream.name, "type": stream.msgtype or MESSAGE_TYPES[stream.kind]}
    if stream.frame_id:
        out["frame_id"] = stream.frame_id
    return out


def convert(
    path: str | Path,
    output: str | Path,
    task: Task | str,
    *,
    wrench_topic: str | None = None,
    twist_topic: str | None = None,
    pose_topic: str | None = None,
    pose_tf: str | None = None,
    motion: str | Path | None = None,
    columns: Mapping[str, str] | None = None,
    time_unit: str | None = None,
    clock: Literal["header", "log"] = "header",
    wrench_frame: Literal["world", "pose"] = "world",
    sensor_rotation: Quaternion | None = None,
    sensor_offset: tuple[float, float, float] | None = None,
    rotate: Quaternion | None = None,
    translate: tuple[float, float, float] | None = None,
    tare_s: float = 0.0,
    start_s: float = 0.0,
    end_s: float | None = None,
    max_gap_s: float = MAX_GAP_S,
    overwrite: bool = False,
) -> ConversionReport:
    """Convert one external log into the trial `output` (100 Hz, times from 0, no ground truth).

    `pose_tf` ("PARENT:CHILD", e.g. "base_link:tool0") takes a bag's pose from its /tf
    and /tf_static, CHILD's in PARENT, where no PoseStamped topic holds it.
    `wrench_frame="pose"` says the sensor's axes turn with the gripper: each step's
    wrench is turned from the pose's orientation into its world axes (after the tare,
    which belongs to the sensor's own axes), first by `sensor_rotation` (x y z w; the
    sensor's axes in the gripper's, as mounted) if given, its torque moved from the
    sensor's origin to the gripper centre by `sensor_offset` (m, where the sensor's
    origin sits in the gripper's axes: tau + r x F). `rotate` then turns every vector
    (force, torque, velocities, pose) into the model's frame, and `translate` (m) moves
    every pose in it, so that the gripper's path lies where the viewer draws the limb
    (the signal holds no position: the estimate is the same); `tare_s` subtracts the mean
    wrench of the first seconds. `start_s` and `end_s` (s from the first step of the time
    every stream covers; `end_s` None: to its end) keep the steps from one up to the
    other, e.g. one trial of a long session: the duration cap, the tare and the checks
    apply to them, and the output's times start at 0 at `start_s`. Gaps longer than
    `max_gap_s` are bridged by interpolation and reported as `ConversionWarning`s (and in
    the report), as are a tare left out under a still garment's weight and one reaching
    into the motion.
    """
    started = time.perf_counter()
    path, output = Path(path), Path(output)
    task = task_of(task, ConversionError)
    check_output(output, source=path, suffix=".mcap", overwrite=overwrite)
    _check_arguments(
        path, motion, clock=clock, wrench_frame=wrench_frame, sensor_rotation=sensor_rotation,
        sensor_offset=sensor_offset, rotate=rotate, translate=translate, tare_s=tare_s,
        start_s=start_s, end_s=end_s, max_gap_s=max_gap_s,
    )  # fmt: skip
    source = load(
        path,
        wrench_topic=wrench_topic,
        twist_topic=twist_topic,
        pose_topic=pose_topic,
        pose_tf=pose_tf,
        motion=motion,
        columns=columns,
        time_unit=time_unit,
        clock=clock,
    )
    messages_in = source.message_count
    if wrench_frame == "pose":
        check_turnable(source)
        mount = source.sensor_mount
        if mount is not None and sensor_rotation is None and sensor_offset is None:
            sensor_rotation, sensor_offset = mount.rotation, mount.offset
            source.notes.append(mount.describe())
    if translate is not None and source.pose is None:
        raise ConversionError(
            "--translate moves the gripper's pose, which the log does not hold", path=path
        )
    left_out = unneeded_pose_without_orientation(source, wrench_frame)
    # one CSV's streams share its time column: one message for it
    reordered = list(
        dict.fromkeys(m for stream in source.streams if (m := put_in_time_order(stream, path)))
    )
    for stream in source.streams:
        check_stream(stream, path)
    grid = common_grid(source, time_unit, start_s, end_s)
    windowed = start_s > 0 or end_s is not None

    found = source.warnings + reordered + left_out
    found += log_warnings(source, grid, max_gap_s, windowed=windowed)
    if message := frames_differ(source, wrench_frame, rotate is not None):
        found.append(message)
    for message in found:
        warnings.warn(message, ConversionWarning, stacklevel=2)

    wrench, twist, pose, processing = _resample_all(
        source, grid, tare_s, rotate, wrench_frame, sensor_rotation, sensor_offset, translate,
        windowed=windowed,
    )  # fmt: skip
    if windowed:  # on the grid's steps: e.g. [10.0, 70.0]
        first = _step_at(start_s)
        processing["window_s"] = [first / rs.RATE_HZ, (first + len(grid)) / rs.RATE_HZ]
    for message in (beyond_dressing(wrench, twist), tare_mistake(wrench, twist, tare_s)):
        if message:
            warnings.warn(message, ConversionWarning, stacklevel=2)
            found.append(message)

    info = _source_info(source, grid, processing, found, motion)
    metadata = TrialMetadata(task=task, spec=None, outcome=Outcome.UNKNOWN, source=info)
    t_ns = grid - grid[0]
    with TrialWriter(output, metadata, overwrite=overwrite) as writer:
        writer.write_wrench(t_ns, wrench)
        writer.write_twist(t_ns, twist)
        if pose is not None:
            writer.write_pose(t_ns, pose)
    return ConversionReport(
        output=str(output),
        steps=len(grid),
        duration_s=len(t_ns) / rs.RATE_HZ,  # each step stands for its 10 ms
        messages_in=messages_in,
        elapsed_s=time.perf_counter() - started,
        source=info,
        warnings=found,
    )


def _check_arguments(
    path: Path,
    motion: str | Path | None,
    *,
    clock: str,
    wrench_frame: str,
    sensor_rotation: Quaternion | None,
    sensor_offset: tuple[float, float, float] | None,
    rotate: Quaternion | None,
    translate: tuple[float, float, float] | None,
    tare_s: float,
    start_s: float,
    end_s: float | None,
    max_gap_s: float,
) -> None:
    """Refuse `convert`'s arguments that could not make a trial, before the log is read."""
    for given in (path, motion):  # their names go into the trial's notes, JSON
        if given is not None and printable(Path(given).name) != Path(given).name:
            raise ConversionError(
                "its name is not UTF-8, which the trial's metadata must be; rename it",
                path=printable(given),
            )
    for option, quat in (("--rotate", rotate), ("--sensor-rotation", sensor_rotation)):
        if quat is not None and not (_finite(quat, 4) and np.abs(quat).max() > 0):
            raise ConversionError(
                f"{option}: a rotation quaternion is 4 finite numbers, x y z w, not all 0"
            )
    mount = [
        n for n, v in (("rotation", sensor_rotation), ("offset", sensor_offset)) if v is not None
    ]
    if mount and wrench_frame != "pose":
        raise ConversionError(
            f"--sensor-{mount[0]} places a sensor on the gripper, with --wrench-frame pose; a "
            "sensor fixed in the world is turned with --rotate"
        )
    if sensor_offset is not None and not (
        _finite(sensor_offset, 3) and np.abs(sensor_offset).max() <= MAX_SENSOR_OFFSET
    ):
        raise ConversionError(
            f"sensor offset must be 3 finite numbers, x y z (metres), each within "
            f"+-{MAX_SENSOR_OFFSET:g}: the sensor is on the gripper"
        )
    if translate is not None and not (
        _finite(translate, 3) and np.abs(translate).max() <= MAX_TRANSLATE
    ):
        raise ConversionError(
            f"--translate: a translation is 3 finite numbers, x y z (metres), each within "
            f"+-{MAX_TRANSLATE:g}"
        )
    if not (_finite(tare_s, None) and tare_s >= 0):
        raise ConversionError(f"tare of {tare_s} s: give a duration of 0 s or more")
    for option, value in (("--start", start_s), ("--end", end_s)):
        if value is not None and not (_finite(value, None) and value >= 0):
            raise ConversionError(f"{option} {value} s: give a time of 0 s or more")
    if end_s is not None and (message := window_mistake(start_s, end_s)):
        raise ConversionError(message)
    if not (_finite(max_gap_s, None) and max_gap_s > 0):
        raise ConversionError(f"max_gap_s {max_gap_s}: give a duration above 0 s")
    if clock not in ("header", "log") or wrench_frame not in ("world", "pose"):
        raise ConversionError(
            f"clock {clock!r} / wrench frame {wrench_frame!r}: use header or log / world or pose"
        )


def window_mistake(start_s: float, end_s: float) -> str | None:
    """What is wrong with a window from `start_s` to `end_s` (finite, 0 or more) before the
    log is read: not in order, shorter than two steps or longer than a trial may last."""
    if start_s >= end_s:
        return f"--start {start_s:g} s is not before --end {end_s:g} s; give a start before the end"
    if end_s - start_s < 2 / rs.RATE_HZ:
        return (
            f"--start {start_s:g} s to --end {end_s:g} s holds less than two 100 Hz steps; give "
            f"a window of {2 / rs.RATE_HZ:g} s or more"
        )
    if end_s - start_s > MAX_DURATION:
        return (
            f"--start {start_s:g} s to --end {end_s:g} s is more than the {MAX_DURATION:g} s a "
            "trial may last; give an hour or less"
        )
    return None


def _finite(value: object, count: int | None) -> bool:
    """`value` is `count` finite numbers (one number if `count` is None)."""
    try:
        numbers = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    shape = () if count is None else (count,)
    return numbers.shape == shape and bool(np.isfinite(numbers).all())


def _resample_all(
    source: Source,
    grid: np.ndarray,
    tare_s: float,
    rotate: Quaternion | None,
    wrench_frame: Literal["world", "pose"] = "world",
    sensor_rotation: Quaternion | None = None,
    sensor_offset: tuple[float, float, float] | None = None,
    translate: tuple[float, float, float] | None = None,
    *,
    windowed: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, dict[str, object]]:
    """Wrench, twist and pose on the grid, tared, rotated and moved, and how each was made."""
    wrench = rs.resample(source.wrench.t_ns, source.wrench.values, grid)
    processing: dict[str, object] = {"wrench": _resampling(source.wrench.t_ns)}
    if source.twist is not None:
        twist = rs.resample(source.twist.t_ns, source.twist.values, grid)
        processing["twist"] = _resampling(source.twist.t_ns)
    else:
        assert source.pose is not None
        # a fast pose's differences are noisy: its velocity is averaged like a wrench
        velocity = rs.twist_from_pose(source.pose.t_ns, source.pose.values)
        twist = rs.resample(source.pose.t_ns, velocity, grid)
        processing["twist"] = f"differentiated from pose, then {_resampling(source.pose.t_ns)}"
    pose = None
    if source.pose is not None:
        pose = rs.interpolate_pose(source.pose.t_ns, source.pose.values, grid)
        processing["pose"] = "linear interpolation, quaternions normalised"
    if tare_s > 0:
        if (span_s := (grid[-1] - grid[0]) / 1e9) < tare_s:
            raise ConversionError(
                f"tare of {tare_s} s is longer than the {'window' if windowed else 'log'} "
                f"({span_s:.2f} s); give a shorter --tare, the seconds the garment hangs still "
                "at its start",
                path=source.path,
            )
        step_s = (grid[1] - grid[0]) / 1e9
        if tare_s < step_s:  # its window would hold no sample to average
            raise ConversionError(
                f"tare of {tare_s:g} s is shorter than one {step_s:g} s step; give 0 for none "
                f"or at least {step_s:g} s",
                path=source.path,
            )
        wrench = rs.tare(grid, wrench, tare_s)
        processing["tare_s"] = tare_s
    if wrench_frame == "pose":
        assert pose is not None  # check_turnable
        via = ""
        if sensor_rotation is not None:  # the sensor's mount: its axes in the gripper's
            wrench = rs.rotate_vectors(wrench, sensor_rotation)
            via = f" (the sensor mounted at {[float(v) for v in sensor_rotation]})"
        if sensor_offset is not None:  # torque about the gripper centre: tau + r x F
            offset = np.asarray(sensor_offset, dtype=np.float64)
            wrench = np.concatenate(
                [wrench[:, :3], wrench[:, 3:] + np.cross(offset, wrench[:, :3])], 1
            )
            via += f" (torque moved by {offset.tolist()} m)"
        wrench = rs.rotate_by_orientation(wrench, pose[:, 3:7])
        processing["wrench_frame"] = f"from the gripper's axes{via} into world axes by the pose"
    if rotate is not None:
        wrench, twist = rs.rotate_vectors(wrench, rotate), rs.rotate_vectors(twist, rotate)
        pose = rs.rotate_pose(pose, rotate) if pose is not None else None
        processing["rotation_xyzw"] = [float(v) for v in rotate]
    if translate is not None:
        assert pose is not None  # checked once the log was read
        pose = rs.translate_pose(pose, translate)
        processing["translation_m"] = [float(v) for v in translate]
    return wrench, twist, pose, processing


def _source_info(
    source: Source,
    grid: np.ndarray,
    processing: dict[str, object],
    found: list[str],
    motion: str | Path | None,
) -> dict[str, object]:
    """The metadata's `source`: where the trial came from and what was done to it."""
    info: dict[str, object] = {
        "file": printable(source.path.resolve()),  # its folders' names may not be UTF-8
        "format": source.format,
        "start_ns": int(grid[0]),
        "time": "output t = source t - start_ns",
        "rate_hz": rs.RATE_HZ,
        "streams": {s.kind: _describe(s, source) for s in source.streams},
        "processing": processing,
    }
    if motion is not None:  # a CSV's: load refuses --motion for a bag
        info["motion_file"] = printable(Path(motion).resolve())
    if source.notes:
        info["notes"] = source.notes
    if found:
        info["warnings"] = found
    return info
