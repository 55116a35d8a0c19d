"""The gripper's pose from a bag's tf tree: `--pose-tf PARENT:CHILD`.

A ROS robot rarely logs its gripper's pose as a PoseStamped topic: robot_state_publisher
puts each link relative to its parent on `/tf` (tf2_msgs/msg/TFMessage, one
TransformStamped per link, at the joint-state rate) and the fixed links on
`/tf_static`. Here every transform of those topics is collected into edges child ->
parent, the chain from CHILD up to PARENT is found and composed into CHILD's pose in
PARENT, a `SourceStream` of kind "pose" as a PoseStamped topic would give.

Static edges are constant (the last one published). The pose's times are the header
stamps of the chain's dynamic edges: shared, as robot_state_publisher's are, or else
those of the fastest edge within the time every dynamic edge covers, the others
interpolated there (position linearly, orientation by normalised lerp; never
extrapolated). A dynamic edge whose stamps are unset (0) is timed by the bag's log
times instead, as any other topic is. The TFMessages are read in bulk by `tfmessage`,
one layout per run of payloads that repeat their frames, rosbags deserialising any other
one by one.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.convert import resample as rs
from dresslog.convert import tfmessage
from dresslog.convert.source import SensorMount, SourceStream, stamps_unset, unset_note
from dresslog.errors import ConversionError

TF_TYPE = "tf2_msgs/msg/TFMessage"
OPTION = "--pose-tf"
#: Frames listed in an error: enough to spot the gripper's, not a screenful.
LISTED_FRAMES = 12
#: The pose (position, quaternion x y z w) of a frame in itself.
IDENTITY = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


@dataclass
class Edge:
    """Where `child` sits in `parent`: position + quaternion (T, 7) at header stamps `t_ns`
    (the log times, where `unset`)."""

    parent: str
    child: str
    static: bool
    t_ns: np.ndarray
    log_ns: np.ndarray
    values: np.ndarray
    #: a dynamic edge's header stamps were unset (0): `t_ns` are its log times
    unset: bool = False


def parse_frames(value: str, path: Path) -> tuple[str, str]:
    """PARENT and CHILD of `--pose-tf PARENT:CHILD`, without ROS 1's leading slashes."""
    parent, colon, child = value.partition(":")
    parent, child = frame_name(parent.strip()), frame_name(child.strip())
    if not colon or not parent or not child or ":" in child:
        raise ConversionError(
            f"{OPTION} {value!r}: give PARENT:CHILD, the gripper's frame in the one its pose "
            "is wanted in, e.g. base_link:tool0",
            path=path,
        )
    if parent == child:
        raise ConversionError(f"{OPTION} {value!r}: PARENT and CHILD are one frame", path=path)
    return parent, child


def frame_name(name: str) -> str:
    """A frame's name as tf2 gives it: ROS 1's tf allowed "/base_link", tf2 "base_link"."""
    return name.lstrip("/")


def tree_frames(edges: dict[str, list[Edge]]) -> set[str]:
    """Every frame of the tf tree: each edge's child and parent."""
    return set(edges) | {e.parent for found in edges.values() for e in found}


def collect_edges(
    topics: Iterable[tuple[bool, Sequence[int], Sequence[bytes]]],
    deserialize: Callable[[bytes], Any],
    *,
    ros1: bool,
) -> dict[str, list[Edge]]:
    """Each child frame's edges (one unless two parents claim it) from the raw TFMessages of
    each tf topic, given as (it is /tf_static, log times ns, payloads)."""
    found: dict[tuple[str, str], list[tuple[np.ndarray, ...]]] = {}
    read = 0  # messages of the topics before: rows keep the order they were sent in
    for static, log_ns, payloads in topics:
        logged = np.asarray(log_ns, dtype=np.int64)
        for run in tfmessage.decode(payloads, deserialize, ros1=ros1):
            statics = np.full(len(run.message), static)
            found.setdefault((frame_name(run.parent), frame_name(run.child)), []).append(
                (read + run.message, run.slot, statics, run.t_ns, logged[run.message], run.values)
            )
        read += len(payloads)
    rows_of = {}
    for key, parts in found.items():
        columns = [np.concatenate(column) for column in zip(*parts, strict=True)]
        sent = np.lexsort((columns[1], columns[0]))  # as sent: message by message, in order
        rows_of[key] = [column[sent] for column in columns]
    edges: dict[str, list[Edge]] = {}
    first_sent = sorted(rows_of, key=lambda key: (rows_of[key][0][0], rows_of[key][1][0]))
    for parent, child in first_sent:  # the edges in the order their frames first came
        _, _, statics, t_ns, logged, pose = rows_of[parent, child]
        static, unset = bool(statics.all()), False
        if static:  # latched, maybe republished: the last one holds
            keep = np.array([np.argmax(logged)])
        else:  # by stamp, a transform logged twice (or on both topics) once
            dynamic = np.flatnonzero(~statics)
            if unset := stamps_unset(t_ns[dynamic]):  # the log times stand in
                t_ns = logged
            _, first = np.unique(t_ns[dynamic], return_index=True)
            keep = dynamic[first]
        t_ns, logged, pose = t_ns[keep], logged[keep], pose[keep]
        pose[:, 3:] = rs.continuous_quaternions(rs.normalize(pose[:, 3:]))
        edges.setdefault(child, []).append(Edge(parent, child, static, t_ns, logged, pose, unset))
    return edges


def _listing(frames: set[str]) -> str:
    names = sorted(frames)
    more = f", ... ({len(names)} in all)" if len(names) > LISTED_FRAMES else ""
    return ", ".join(names[:LISTED_FRAMES]) + more


def chain(edges: dict[str, list[Edge]], parent: str, child: str, path: Path) -> list[Edge]:
    """The edges from `child` up to `parent`, child's own first."""
    frames = tree_frames(edges)
    for frame in (child, parent):
        if frame not in frames:
            raise ConversionError(
                f"{OPTION}: frame {frame} is not in the bag's tf tree (frames: {_listing(frames)})",
                path=path,
            )
    out: list[Edge] = []
    frame = child
    while frame != parent:
        if frame not in edges:
            raise ConversionError(
                f"{OPTION}: {parent} is not above {child} in the tf tree: {child}'s chain "
                f"reaches the root {frame}; give PARENT:CHILD with PARENT on that chain",
                path=path,
            )
        if len(found := edges[frame]) > 1:
            parents = ", ".join(sorted(e.parent for e in found))
            raise ConversionError(
                f"{OPTION}: frame {frame} has {len(found)} parents in tf ({parents}); a tf "
                "tree gives each frame one",
                path=path,
            )
        out.append(found[0])
        frame = found[0].parent
        if len(out) > len(edges):  # a loop never reaches a root
            raise ConversionError(f"{OPTION}: the tf tree loops at {frame}", path=path)
    return out


def _fixed_above(edges: dict[str, list[Edge]], frame: str) -> dict[str, np.ndarray]:
    """`frame` and each frame above it that fixed links alone reach, with `frame`'s pose
    (1, 7) in it, nearest first."""
    pose = np.array([IDENTITY])
    out = {frame: pose}
    while len(found := edges.get(frame, [])) == 1 and found[0].static:
        pose, frame = _compose(found[0].values[-1:], pose), found[0].parent
        if frame in out:  # a loop: `chain` names it where it matters
            break
        out[frame] = pose
    return out


def sensor_mount(edges: dict[str, list[Edge]], child: str, frame: str) -> SensorMount | None:
    """Where `frame` (a wrench's header frame) sits in `child` (the gripper's frame), if the
    tf tree fixes it there: both hang by fixed links from one frame (a sensor on the
    gripper's flange, above, below or beside its tool frame). None if `frame` is not in
    the tree, a moving link parts them, or it is no mount at all (the sensor's origin
    and axes the gripper's)."""
    over_child, over_frame = _fixed_above(edges, child), _fixed_above(edges, frame)
    common = next((f for f in over_frame if f in over_child), None)
    if common is None:
        return None
    child_pose, turn_back = over_child[common], rs.conjugate(over_child[common][:, 3:])
    inverse = np.concatenate([-rs.rotate_by_orientation(child_pose[:, :3], turn_back),
                              turn_back], axis=1)  # fmt: skip
    mount = _compose(inverse, over_frame[common])[0]
    mount[3:] = rs.normalize(mount[3:])
    if np.allclose(mount, IDENTITY, atol=1e-9, rtol=0):
        return None
    x, y, z, qx, qy, qz, qw = (float(v) for v in mount)
    return SensorMount(frame, child, (x, y, z), (qx, qy, qz, qw))


def _compose(outer: np.ndarray, inner: np.ndarray) -> np.ndarray:
    """Poses (T, 7) of `inner`'s frame through `outer`'s: where inner's child sits."""
    position = outer[:, :3] + rs.rotate_by_orientation(inner[:, :3], outer[:, 3:])
    return np.concatenate([position, rs.multiply(outer[:, 3:], inner[:, 3:])], axis=1)


def pose_stream(
    edges: dict[str, list[Edge]],
    parent: str,
    child: str,
    path: Path,
    clock: str = "header",
    notes: list[str] | None = None,
) -> SourceStream:
    """CHILD's pose in PARENT, timed by the chain's dynamic edges' stamps (or, with
    `clock="log"`, by the receive times of the messages that carried those stamps).
    `notes`, where given, gets one for each moving link whose stamps were unset."""
    links = chain(edges, parent, child, path)
    dynamic = [e for e in links if not e.static]
    name = f"/tf {parent}->{child}"
    if clock == "header" and notes is not None:
        notes += [unset_note(f"/tf {e.parent}->{e.child}") for e in dynamic if e.unset]
    if not dynamic:
        raise ConversionError(
            f"{OPTION}: every transform from {child} up to {parent} is static, so the pose "
            "never moves and gives no velocity; choose a CHILD on the moving arm",
            path=path,
        )
    timing = max(dynamic, key=lambda e: rs.median_rate(e.t_ns) if len(e.t_ns) > 1 else 0.0)
    t_ns, log_ns = timing.t_ns, timing.log_ns
    if any(not np.array_equal(e.t_ns, t_ns) for e in dynamic):
        start, stop = max(int(e.t_ns[0]) for e in dynamic), min(int(e.t_ns[-1]) for e in dynamic)
        inside = (t_ns >= start) & (t_ns <= stop)
        if not inside.any():
            spans = ", ".join(
                f"{e.parent}->{e.child} {e.t_ns[0] / 1e9:.3f}-{e.t_ns[-1] / 1e9:.3f} s"
                for e in dynamic
            )
            raise ConversionError(
                f"{OPTION}: the moving transforms from {child} up to {parent} share no time "
                f"({spans})",
                path=path,
            )
        t_ns, log_ns = t_ns[inside], log_ns[inside]
    pose: np.ndarray | None = None
    for edge in reversed(links):  # from PARENT down to CHILD
        if edge.static:
            values = np.repeat(edge.values, len(t_ns), axis=0)
        elif np.array_equal(edge.t_ns, t_ns):
            values = edge.values
        else:
            values = rs.interpolate_pose(edge.t_ns, edge.values, t_ns)
        pose = values if pose is None else _compose(pose, values)
    assert pose is not None  # the chain holds a dynamic edge
    pose[:, 3:] = rs.normalize(pose[:, 3:])
    stamps = log_ns if clock == "log" else t_ns
    on = "log" if timing.unset else clock  # the times are log times either way
    return SourceStream("pose", name, stamps, pose, parent, on, log_ns, msgtype=TF_TYPE)
