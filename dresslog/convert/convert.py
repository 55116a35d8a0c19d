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
from typing import Any, Literal

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
from dresslog.convert.options import ConvertOptions
from dresslog.convert.signal import SignalOptions, tare_bias, tare_mistake_before
from dresslog.convert.source import MESSAGE_TYPES, Source, SourceStream
from dresslog.errors import ConversionError, DresslogWarning
from dresslog.io.files import NOT_REGULAR, check_output, no_such, printable
from dresslog.io.writer import TrialWriter
from dresslog.spec import MAX_DURATION, Outcome, Task, TrialMetadata

CSV_SUFFIXES = (".csv", ".tsv", ".txt")


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
    half = rs.PERIOD_NS // 2 if rs.averages(source.wrench.t_ns) else 0
    others = [s for s in source.streams if s is not source.wrench]
    start = rs.grid_start(source.wrench.t_ns, [int(s.t_ns[0]) for s in others])
    stop = min(int(s.t_ns[-1]) - (half if s is source.wrench else 0) for s in source.streams)
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
    options: ConvertOptions | Task | str,
    **keywords: Any,
) -> ConversionReport:
    """Convert one external log into the trial `output` (100 Hz, times from 0, no ground truth).

    `options` says how (`ConvertOptions`: topics, the signal's frame and tare, a window),
    or is the task, with the options as keywords (`ConvertOptions.build`'s: e.g.
    `convert(log, out, "gown", pose_tf="base_link:tool0", tare_s=0.5)`). Gaps longer than
    the signal's `max_gap_s` are bridged by interpolation and reported as
    `ConversionWarning`s (and in the report), as are a tare left out under a still
    garment's weight and one reaching into the motion.

    Raises:
        ConversionError: the log cannot make a trial, or the options contradict each
            other (`OptionError`), before anything is written.
    """
    started = time.perf_counter()
    if not isinstance(options, ConvertOptions):
        options = ConvertOptions.build(options, **keywords)
    elif keywords:
        raise TypeError(f"give {', '.join(keywords)} in the options, or the task, not both")
    path, output = Path(path), Path(output)
    check_output(output, source=path, suffix=".mcap", overwrite=options.overwrite)
    options.check_names(path)
    source = load(
        path,
        wrench_topic=options.wrench_topic,
        twist_topic=options.twist_topic,
        pose_topic=options.pose_topic,
        pose_tf=options.pose_tf,
        motion=options.motion,
        columns=options.columns,
        time_unit=options.time_unit,
        clock=options.clock,
    )
    messages_in = source.message_count
    signal = options.signal
    if signal.wrench_frame == "pose":
        check_turnable(source)
        if (placed := signal.mounted(source.sensor_mount)) is not signal:
            signal = placed
            source.notes.append(source.sensor_mount.describe())  # type: ignore[union-attr]
    if signal.translate is not None and source.pose is None:
        raise ConversionError(
            "--translate moves the gripper's pose, which the log does not hold", path=path
        )
    left_out = unneeded_pose_without_orientation(source, signal.wrench_frame)
    # one CSV's streams share its time column: one message for it
    reordered = list(
        dict.fromkeys(m for stream in source.streams if (m := put_in_time_order(stream, path)))
    )
    for stream in source.streams:
        check_stream(stream, path)
    grid = common_grid(source, options.time_unit, options.start_s, options.end_s)
    windowed = options.windowed

    found = source.warnings + reordered + left_out
    found += log_warnings(source, grid, signal.max_gap_s, windowed=windowed)
    if message := frames_differ(source, signal.wrench_frame, signal.rotate is not None):
        found.append(message)
    for message in found:
        warnings.warn(message, ConversionWarning, stacklevel=2)

    wrench, twist, pose, processing = _resample_all(source, grid, signal, windowed=windowed)
    if windowed:  # on the grid's steps: e.g. [10.0, 70.0]
        first = _step_at(options.start_s)
        processing["window_s"] = [first / rs.RATE_HZ, (first + len(grid)) / rs.RATE_HZ]
    for message in (
        beyond_dressing(wrench, twist),
        tare_mistake(wrench, twist, signal.tare_s),
    ):
        if message:
            warnings.warn(message, ConversionWarning, stacklevel=2)
            found.append(message)

    info = _source_info(source, grid, processing, found, options.motion)
    metadata = TrialMetadata(task=options.task, spec=None, outcome=Outcome.UNKNOWN, source=info)
    t_ns = grid - grid[0]
    with TrialWriter(output, metadata, overwrite=options.overwrite) as writer:
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


def resampling(source: Source) -> dict[str, str]:
    """How `resample_streams` brings each of the source's streams onto the grid."""
    done = {"wrench": _resampling(source.wrench.t_ns)}
    if source.twist is not None:
        done["twist"] = _resampling(source.twist.t_ns)
    else:
        assert source.pose is not None
        done["twist"] = f"differentiated from pose, then {_resampling(source.pose.t_ns)}"
    if source.pose is not None:
        done["pose"] = "linear interpolation, quaternions normalised"
    return done


def resample_streams(
    source: Source, grid: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Wrench, twist and pose of the source on the grid, as measured (not yet placed)."""
    wrench = rs.resample(source.wrench.t_ns, source.wrench.values, grid)
    if source.twist is not None:
        twist = rs.resample(source.twist.t_ns, source.twist.values, grid)
    else:
        assert source.pose is not None
        # a fast pose's differences are noisy: its velocity is averaged like a wrench
        velocity = rs.twist_from_pose(source.pose.t_ns, source.pose.values)
        twist = rs.resample(source.pose.t_ns, velocity, grid)
    pose = None
    if source.pose is not None:
        pose = rs.interpolate_pose(source.pose.t_ns, source.pose.values, grid)
    return wrench, twist, pose


def _resample_all(
    source: Source, grid: np.ndarray, signal: SignalOptions, *, windowed: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, dict[str, object]]:
    """Wrench, twist and pose on the grid, tared, rotated and moved, and how each was made."""
    wrench, twist, pose = resample_streams(source, grid)
    bias = None
    if signal.tare_s > 0:
        span_s, step_s = (grid[-1] - grid[0]) / 1e9, (grid[1] - grid[0]) / 1e9
        what = "window" if windowed else "log"
        if message := tare_mistake_before(span_s, step_s, signal.tare_s, what):
            raise ConversionError(message, path=source.path)
        bias = tare_bias(grid, wrench, signal.tare_s)
    wrench, twist, pose = signal.place(wrench, twist, pose, bias)
    return wrench, twist, pose, {**resampling(source), **signal.steps()}


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
