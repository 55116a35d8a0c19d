"""What `convert` refuses or warns about in a log: its streams' stamps and values before
resampling, and gaps, clocks, frames, implausible signals and tares after.

Refusals are `ConversionError`s naming the file (and a bag's topic); warnings come back
as strings, which `convert` issues and records in its report.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dresslog.convert import resample as rs
from dresslog.convert import tf
from dresslog.convert.source import COMPONENTS, Source, SourceStream
from dresslog.errors import ConversionError
from dresslog.io import well_known as wk
from dresslog.trial import MOVING_SPEED

#: How far back a sample may be stamped, behind one logged before it, and still be
#: put in its place: a transport's reordering, not a clock that jumped back.
MAX_LATE_S = 0.1


def _where(stream: SourceStream, path: Path) -> str:
    """A bag's stream is named by its topic; a CSV's by its file, which the error names."""
    return "" if stream.name == path.name else f"{stream.name}: "


def put_in_time_order(stream: SourceStream, path: Path) -> str | None:
    """Sort samples stamped a little out of order and drop exact repeats; say what was done.

    A bag lists messages as they arrived: a transport's reordering or a message logged
    twice leaves a few stamps out of order. A stamp repeated with other values (a driver
    stamping a batch with one time) or a jump back of more than `MAX_LATE_S` (a clock
    reset, two logs in one) is refused: sorting would interleave what does not belong.
    """
    t_ns, values = stream.t_ns, stream.values
    if rs.first_disorder(t_ns) is None or (t_ns == t_ns[0]).all():  # in order, or unset
        return None
    where, clock = _where(stream, path), f"{stream.clock} clock"
    order = np.argsort(t_ns, kind="stable")
    sorted_t, sorted_v = t_ns[order], values[order]
    same = np.diff(sorted_t) == 0
    equal = (sorted_v[1:] == sorted_v[:-1]) | (np.isnan(sorted_v[1:]) & np.isnan(sorted_v[:-1]))
    equal = equal.all(axis=1)  # a row as its neighbour, NaN matching NaN
    behind = np.maximum.accumulate(t_ns) - t_ns
    if (worst := int(np.argmax(behind))) and behind[worst] > MAX_LATE_S * 1e9:
        raise ConversionError(
            f"{where}time goes back {behind[worst] / 1e9:.3g} s at sample {worst} of "
            f"{len(t_ns)} ({clock}): a clock reset, or two logs in one; convert each part "
            "on its own",
            path=path,
        )
    clash = np.flatnonzero(same & ~equal)
    if len(clash):
        stamp, first, second = sorted_t[clash[0]], order[clash[0]], order[clash[0] + 1]
        raise ConversionError(
            f"{where}samples {first} and {second} of {len(t_ns)} share the stamp {stamp} ns "
            f"({clock}) with other values: a driver stamping a batch with one time, or times "
            "written more coarsely than the rate",
            path=path,
        )
    late = int(np.count_nonzero(behind > 0))
    repeat = np.r_[False, same & equal]
    done = [f"{late} stamped before one logged earlier, sorted"] if late else []
    done += [f"{np.count_nonzero(repeat)} logged twice, dropped"] if repeat.any() else []
    stream.t_ns, stream.values = sorted_t[~repeat], sorted_v[~repeat]
    if stream.log_ns is not None:
        stream.log_ns = stream.log_ns[order][~repeat]
    return f"{stream.name}: of {len(t_ns)} samples, {' and '.join(done)}"


def check_stream(stream: SourceStream, path: Path) -> None:
    """Enough samples, strictly increasing times, finite values (in float32) and a pose's
    orientations set: else a ConversionError."""
    where = _where(stream, path)
    if len(stream) < 2:
        raise ConversionError(
            f"{where}only {len(stream)} {stream.kind} sample(s); a trial needs a log of "
            "several steps",
            path=path,
        )
    if (stream.t_ns == stream.t_ns[0]).all():
        column = "; pick another time column with --column time=HEADER" if not where else ""
        raise ConversionError(
            f"{where}every {stream.kind} timestamp is {stream.t_ns[0]} ns (unset?){column}",
            path=path,
        )
    if (bad := rs.first_disorder(stream.t_ns)) is not None:
        raise ConversionError(
            f"{where}timestamps not increasing at sample {bad} of {len(stream)} "
            f"({stream.t_ns[bad - 1]} then {stream.t_ns[bad]} ns, {stream.clock} clock)",
            path=path,
        )
    # the model reads float32: a value past its range would reach it as infinite
    unreadable = ~(np.abs(stream.values) <= np.finfo(np.float32).max)  # NaN too
    if unreadable.any():
        row, col = (int(i[0]) for i in np.nonzero(unreadable))
        seconds = (stream.t_ns[row] - stream.t_ns[0]) / 1e9
        raise ConversionError(
            f"{where}{stream.values[row, col]} {stream.kind} {COMPONENTS[stream.kind][col]} at "
            f"sample {row} ({seconds:.3f} s in); drop or fill that sample",
            path=path,
        )
    # a zero quaternion is not the identity: normalised, it would pass for one
    if stream.kind == "pose" and len(zero := _unset_orientations(stream)):
        raise ConversionError(
            f"{where}pose orientation is the zero quaternion at {len(zero)} of {len(stream)} "
            f"samples (first: sample {zero[0]}), ROS 1's unset value; drop those samples or "
            "fill in the orientation",
            path=path,
        )


def _unset_orientations(pose: SourceStream) -> np.ndarray:
    """Samples whose quaternion is zero: no rotation at all (ROS 1's unset value)."""
    return np.flatnonzero(np.linalg.norm(pose.values[:, 3:7], axis=1) < 1e-6)


#: Gaps listed one by one before the rest are summed up in one warning.
MAX_GAPS_LISTED = 5


def _gap_warnings(source: Source, grid: np.ndarray, max_gap_s: float) -> list[str]:
    """One warning per gap the grid reaches into (a file's gap once, though wrench and
    motion share it), then a sum."""
    gaps = {}
    for stream in source.streams:
        for at, length in rs.gaps(stream.t_ns, round(max_gap_s * 1e9)):
            if at < grid[-1] and at + length > grid[0]:  # not in a part cut off
                gaps[(stream.name, at)] = length
    found = [
        f"gap of {length / 1e9:.3f} s in {name} at {(at - grid[0]) / 1e9:.3f} s "
        f"(output time); bridged by interpolation"
        for (name, at), length in list(gaps.items())[:MAX_GAPS_LISTED]
    ]
    if (more := len(gaps) - MAX_GAPS_LISTED) > 0:
        longest = max(gaps.values()) / 1e9
        found.append(f"{more} more gaps (the longest of all {longest:.3f} s); is the log whole?")
    return found


#: Beyond these a log is not of a robot dressing a person (forces of a few newtons, speeds
#: of centimetres per second), but most likely of another unit read as SI.
PLAUSIBLE = {"force": (1000.0, "N"), "torque": (100.0, "N m"), "speed": (5.0, "m/s")}


def beyond_dressing(wrench: np.ndarray, twist: np.ndarray) -> str | None:
    """A warning when the converted signal is far beyond any dressing robot's."""
    peaks = {
        "force": np.linalg.norm(wrench[:, :3], axis=1).max(),
        "torque": np.linalg.norm(wrench[:, 3:], axis=1).max(),
        "speed": np.linalg.norm(twist[:, :3], axis=1).max(),
    }
    beyond = [
        f"{name} up to {peak:.3g} {PLAUSIBLE[name][1]}"
        for name, peak in peaks.items()
        if peak > PLAUSIBLE[name][0]
    ]
    if not beyond:
        return None
    return (
        f"{', '.join(beyond)}, far beyond a robot dressing a person: are the columns in SI "
        "units? (raw sensor counts, N mm or mm/s read as N, N m and m/s?)"
    )


#: A still start this long, s, is the garment hanging at rest before the motion, not a
#: pause as the gripper gets going; over it the mean force is the garment's weight.
MIN_STILL_S = 0.2
#: Above this force, N, a still start is not tared: a sensor zeroed with the garment hanging
#: reads there only its noise and drift (the bundled robot log, tared, 0.002 N), where a
#: hanging garment weighs its mass times g (the simulated gown or shorts, 0.25 kg, 2.45 N);
#: 0.5 N, a 50 g garment's weight, lies far above the one and below the other.
UNTARED_FORCE = 0.5


def _still_steps(twist: np.ndarray) -> int:
    """How many steps the converted log begins with, the gripper slower than MOVING_SPEED."""
    moving = np.flatnonzero(np.linalg.norm(twist[:, :3], axis=1) >= MOVING_SPEED)
    return int(moving[0]) if len(moving) else len(twist)


def tare_mistake(wrench: np.ndarray, twist: np.ndarray, tare_s: float) -> str | None:
    """A warning when the tare (`tare_s`, 0 for none) is likely wrong for the converted log.

    The simulated trials are tared with the garment hanging, so a garment's weight left
    on the sensor reads as force on the limb at every step; yet a weight of a few newtons
    lies within the training data's spread, and `infer` cannot tell. Two mistakes are
    seen on the log itself: no tare though the gripper starts still under a garment's
    weight (`wrench` as converted, untared), and a tare window that reaches past the
    still start into the motion, whose force it then subtracts from every step.
    """
    still = _still_steps(twist)
    still_s = still / rs.RATE_HZ  # each step stands for its 10 ms
    if tare_s == 0:
        if still_s < MIN_STILL_S:
            return None
        force = float(np.linalg.norm(wrench[:still, :3].mean(axis=0)))  # what a tare removes
        if force <= UNTARED_FORCE:
            return None
        return (
            f"the force while the gripper is still at the start is {force:.2f} N, where the "
            "simulated trials start near 0 (tared with the garment hanging); if the sensor "
            f"was not zeroed with the garment hanging, convert with --tare {still_s:g} (the "
            "still start here)"
        )
    if round(tare_s * 1e9) <= still * rs.PERIOD_NS:  # as `rs.tare` counts its window
        return None
    if not still:
        return (
            f"the gripper moves from the first step, so the tare's {tare_s:g} s take in force "
            "from the motion, not the garment hanging still; tare only a log that starts still"
        )
    return (
        f"the gripper starts moving at {still_s:.2f} s, within the tare's {tare_s:g} s, so the "
        f"tare takes in force from the motion; --tare {still_s:g} or less keeps to the still "
        "start"
    )


def log_warnings(
    source: Source, grid: np.ndarray, max_gap_s: float, *, windowed: bool = False
) -> list[str]:
    """Gaps bridged, streams on different clocks (or header clocks that disagree), and time
    cut off the wrench (by the other streams, not by a window asked for)."""
    found = _gap_warnings(source, grid, max_gap_s)
    if len({s.clock for s in source.streams}) > 1:
        clocks = ", ".join(f"{s.name} on its {s.clock} clock" for s in source.streams)
        found.append(f"streams on different clocks ({clocks}): off by the logging delay")
    elif message := _clock_skew(source.streams):
        found.append(message)
    wrench_s = (source.wrench.t_ns[-1] - source.wrench.t_ns[0]) / 1e9
    if not windowed and (kept := (grid[-1] - grid[0]) / 1e9) < 0.9 * wrench_s:
        found.append(
            f"the trial covers {kept:.2f} s of the wrench's {wrench_s:.2f} s: only the time "
            "every stream covers"
        )
    return found


#: How far apart two streams' header clocks may run, against the bag's receive times.
MAX_CLOCK_SKEW_S = 0.05


def _clock_skew(streams: list[SourceStream]) -> str | None:
    """Streams whose header stamps lead their receive times by different amounts: the
    sensors' clocks disagree, and aligning by stamp would shift one signal in time."""
    lead = {
        s.name: float(np.median(s.t_ns - s.log_ns)) / 1e9
        for s in streams
        if s.clock == "header" and s.log_ns is not None
    }
    if len(lead) < 2 or max(lead.values()) - min(lead.values()) <= MAX_CLOCK_SKEW_S:
        return None
    leads = ", ".join(f"{name} {value:+.3f} s" for name, value in lead.items())
    return (
        f"header stamps lead the bag's receive times by different amounts ({leads}): the "
        "streams' clocks disagree, and aligned by stamp they are shifted (then convert on "
        "receive times with --clock log), or one stream arrives later than it is stamped "
        "(then the stamps are right)"
    )


def frames_differ(source: Source, wrench_frame: str, rotated: bool) -> str | None:
    """Frame names that contradict the wrench's treatment: in another frame than the
    motion and left as is (a sensor's own axes, likely), or in the motion's own frame
    and turned by the pose (world axes turned a second time, likely)."""
    motion = source.twist or source.pose
    frames = (source.wrench.frame_id, motion.frame_id if motion is not None else "")
    if not all(frames) or frames[0] == wk.FRAMES[wk.WRENCH]:  # a trial's own, world-aligned
        return None
    same = tf.frame_name(frames[0]) == tf.frame_name(frames[1])  # ROS 1's /base is base
    if wrench_frame == "pose" and same:
        return (
            f"the wrench is in frame {frames[0]!r}, as the motion is: if that frame's axes "
            "are the world's, --wrench-frame pose turns the wrench a second time"
        )
    if wrench_frame == "pose" or same or rotated:
        return None
    return (
        f"the wrench is in frame {frames[0]!r}, the motion in {frames[1]!r}: the model reads "
        "both in world axes; if the sensor's axes turn with the gripper, give --wrench-frame "
        "pose, if they are fixed but turned, --rotate"
    )


def unneeded_pose_without_orientation(source: Source, wrench_frame: str) -> list[str]:
    """A pose whose orientation was never set, beside a twist that gives the velocity,
    is left out (with a warning) rather than refused: the trial does not need it."""
    pose = source.pose
    if pose is None or source.twist is None or wrench_frame == "pose":
        return []
    if not len(_unset_orientations(pose)):
        return []
    source.pose = None
    return [
        f"{pose.name}: orientation unset (zero quaternions), so the pose is left out; the "
        f"velocity comes from {source.twist.name}"
    ]


def check_turnable(source: Source) -> None:
    """`--wrench-frame pose` needs the gripper's orientation, as logged (not filled in)."""
    if source.pose is not None and source.pose.has_orientation:
        return
    if source.format == "csv":
        how = "give position and qx..qw columns" if source.pose is None else "add qx..qw columns"
    else:
        how = "give the gripper's PoseStamped topic with --pose-topic"
    raise ConversionError(
        f"--wrench-frame pose turns the wrench by the gripper's orientation, which the log "
        f"does not hold; {how}",
        path=source.path,
    )
