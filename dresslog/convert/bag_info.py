"""`dresslog info BAG`: what a ROS bag holds, to choose `convert`'s topics and frames.

A bag is not a trial, so `info` cannot describe it as one; but the options `convert` needs
(which wrench topic, which frame of the tf tree is the gripper's) are read off the bag,
so here are its topics, what `convert` would take by default, and its tf tree drawn
from the root down, each frame moving or static.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.convert import rosbag, tf
from dresslog.convert.rosbag import opened_bag
from dresslog.convert.source import MESSAGE_TYPES
from dresslog.errors import ConversionError
from dresslog.io import well_known as wk
from dresslog.io.reader import file_summary
from dresslog.trial import median_rate


def is_bag(path: Path) -> bool:
    """A ROS 1 bag file or a ROS 2 bag folder (a bare ROS 2 MCAP is told apart by
    the trial reader, which names `convert` for it)."""
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.suffix.lower() == ".bag" and path.is_file()


def is_ros2_log(path: Path) -> bool:
    """An MCAP file of profile ros2 that no dresslog wrote, nor holds our wrench channel: a
    robot's log (a bare bag), not a damaged trial, which the trial reader describes.
    `path` is a regular file (a pipe would block the read)."""
    found = file_summary(path)
    if found is None:
        return False
    profile, summary, ours = found
    return (
        profile == wk.PROFILE
        and not ours
        and all(c.topic != wk.WRENCH for c in summary.channels.values())
    )


def describe_bag(path: str | Path, *, as_json: bool = False) -> str:
    """Topics with their types and counts, `convert`'s default choice, and the tf tree
    (as JSON: the same, the tree as its edges)."""
    path = Path(path)
    with opened_bag(path) as reader:
        types, counts, empty = rosbag.topic_counts(reader)
        total = reader.message_count
        seconds = reader.duration / 1e9 if total else 0.0
        kind = "ros2" if reader.is2 else "ros1"
        tf_topics = rosbag.tf_topics_of(types, empty)
        buckets = rosbag.read_topics(reader, set(tf_topics)) if tf_topics else {}
        edges = rosbag.tf_edges(reader, tf_topics, buckets) if tf_topics else {}
        sensor = _wrench_frame(reader, types, empty)
    choice = (
        _default_choice(types, empty, path, bool(edges))
        if total
        else "has nothing to convert: the bag holds no messages"
    )
    if as_json:
        return json.dumps(
            {
                "path": str(path), "format": kind, "messages": total, "seconds": seconds,
                "topics": [{"topic": t, "type": types[t], "messages": counts[t]}
                           for t in sorted(types)],
                "convert": choice,
                "wrench_frame": sensor,
                "tf": [{"parent": e.parent, "child": e.child, "static": e.static,
                        "transforms": len(e.t_ns)} for found in edges.values() for e in found],
            },
            indent=1,
        )  # fmt: skip
    name = "ROS 2 bag" if kind == "ros2" else "ROS 1 bag"
    lines = [f"{path.name}: {name}, {total} messages over {seconds:.2f} s"]
    lines.append("  topics" if types else "  topics   none")
    width = max((len(t) for t in types), default=0)
    lines += [f"    {t:<{width}}  {counts[t]:>7}  {types[t]}" for t in sorted(types)]
    lines.append(f"  convert  {choice}")
    if sensor is not None:
        lines.append(f"  wrench   in frame {sensor or '(none named)'}{_placed(sensor, edges)}")
    if edges:
        lines.append("  tf tree")
        lines += [f"    {line}" for line in _tree(edges)]
    return "\n".join(lines)


def _wrench_frame(reader: Any, types: dict[str, str], empty: frozenset[str]) -> str | None:
    """The header frame of the first message of the bag's one wrench topic (None if it
    has none, or several): the sensor's axes, which `--wrench-frame` is chosen by."""
    wrenches = [t for t, m in types.items() if m == MESSAGE_TYPES["wrench"] and t not in empty]
    if len(wrenches) != 1:
        return None
    connections = [c for c in reader.connections if c.topic == wrenches[0]]
    for _, _, raw in reader.messages(connections=connections):
        try:
            return tf.frame_name(rosbag.decode("wrench", [raw], ros1=not reader.is2)[2])
        except ValueError:  # `convert` names it
            return None
    return None


def _placed(sensor: str, edges: dict[str, list[tf.Edge]]) -> str:
    """Whether the wrench's frame is in the tf tree, which then places the sensor on the
    gripper (`convert --wrench-frame pose` with `--pose-tf`)."""
    if not edges or not sensor:
        return ""
    return " (in the tf tree below)" if sensor in tf.tree_frames(edges) else " (not in the tf tree)"


def _default_choice(types: dict[str, str], empty: frozenset[str], path: Path, has_tf: bool) -> str:
    """The topics `convert` takes with no topic options, or why it needs some: a bag with
    a wrench and a tf tree but no pose topic needs only `--pose-tf`."""
    for pose_tf in (False, True) if has_tf else (False,):
        try:
            chosen, notes = rosbag.choose_topics(types, {}, path, empty, pose_tf=pose_tf)
        except ConversionError as err:
            problem = err.message
            continue
        taken = "takes " + ", ".join(f"{kind} {topic}" for kind, topic in chosen.items())
        if pose_tf:
            taken += "; the pose needs --pose-tf PARENT:CHILD (the tf tree below)"
        return taken + "".join(f"; {note}" for note in notes)
    return f"refuses it as it stands: {problem}"


def _tree(edges: dict[str, list[tf.Edge]]) -> list[str]:
    """The frames from each root down, indented, each with how its transform moves."""
    below: dict[str, list[tf.Edge]] = {}
    for found in edges.values():
        for edge in found:
            below.setdefault(edge.parent, []).append(edge)
    roots = sorted(set(below) - set(edges))  # parents that are no frame's child
    lines: list[str] = []

    def walk(frame: str, depth: int, seen: set[str]) -> None:
        for edge in sorted(below.get(frame, []), key=lambda e: e.child):
            if edge.child in seen:  # a loop: `convert` refuses it by name
                continue
            lines.append(f"{'  ' * depth}{edge.child}  ({_motion(edge)})")
            walk(edge.child, depth + 1, seen | {edge.child})

    for root in roots:
        lines.append(root)
        walk(root, 1, {root})
    return lines


def _motion(edge: tf.Edge) -> str:
    if edge.static:
        return "static"
    rate = f" at {median_rate(edge.t_ns):.0f} Hz" if len(edge.t_ns) > 1 else ""
    moved = np.ptp(edge.values, axis=0).max() if len(edge.values) else 0.0
    still = "" if moved > 0 else ", never moving"
    return f"/tf, {len(edge.t_ns)} transforms{rate}{still}"
