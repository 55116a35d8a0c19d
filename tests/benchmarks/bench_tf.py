"""Benchmark: convert a 10-minute log (1 kHz WrenchStamped + 100 Hz /tf of 8 links) with
`--pose-tf base_link:tool0`.

The /tf is a robot_state_publisher's for a six-joint arm with a two-finger gripper: one
TFMessage of 8 transforms per 100 Hz step, all stamped alike, plus /tf_static (world ->
base_link, wrist_3_link -> tool0). Measured: `convert` end to end, and apart from it the
part that is the tf's own: every TFMessage decoded and the edges collected
(`tf.collect_edges`), and the chain composed (`tf.pose_stream`).

    python tests/benchmarks/bench_tf.py [--minutes 10] [--layouts ros1 mcap]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from dresslog.convert import convert, tf

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository, for tests/

from tests.benchmarks.bench_convert import T0_NS, payloads

ARM = ["base_link", "shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
       "wrist_2_link", "wrist_3_link"]  # fmt: skip
FINGERS = [("wrist_3_link", "left_finger"), ("wrist_3_link", "right_finger")]


def store(ros1: bool):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    types = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:
        text = "geometry_msgs/TransformStamped[] transforms"
        types.register(get_types_from_msg(text, tf.TF_TYPE))
    return types


def tf_message(types, t_ns: int, edges: list[tuple[str, str, np.ndarray]], ros1: bool):
    t = types.types
    stamp = t["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
    out = []
    for parent, child, v in edges:
        header = (t["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=parent) if ros1
                  else t["std_msgs/msg/Header"](stamp=stamp, frame_id=parent))  # fmt: skip
        move = t["geometry_msgs/msg/Transform"](
            translation=t["geometry_msgs/msg/Vector3"](*v[:3]),
            rotation=t["geometry_msgs/msg/Quaternion"](*v[3:]),
        )
        out.append(t["geometry_msgs/msg/TransformStamped"](
            header=header, child_frame_id=child, transform=move))  # fmt: skip
    return t[tf.TF_TYPE](transforms=out)


def write_log(folder: Path, layout: str, minutes: float) -> Path:
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    ros1 = layout == "ros1"
    types = store(ros1)
    serialize = types.serialize_ros1 if ros1 else types.serialize_cdr
    path = folder / ("log.bag" if ros1 else f"log_{layout}")
    writer = Writer1(path) if ros1 else Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP)
    rng = np.random.default_rng(0)
    tw = T0_NS + np.arange(round(minutes * 60_000), dtype=np.int64) * 1_000_000
    tt = T0_NS + 3_000_000 + np.arange(round(minutes * 6_000), dtype=np.int64) * 10_000_000
    with writer:
        wrench = writer.add_connection("/ft/wrench", "geometry_msgs/msg/WrenchStamped",
                                       typestore=types)  # fmt: skip
        for t_ns, raw in zip(tw.tolist(), payloads("wrench", tw, rng.normal(size=(len(tw), 6)),
                                                   ros1), strict=True):  # fmt: skip
            writer.write(wrench, t_ns, raw)
        static = writer.add_connection("/tf_static", tf.TF_TYPE, typestore=types)
        fixed = [("world", "base_link", np.array([0, 0, 0.8, 0, 0, 0, 1.0])),
                 ("wrist_3_link", "tool0", np.array([0, 0, 0.1, 0, 0, 0, 1.0]))]  # fmt: skip
        writer.write(static, int(tt[0]), serialize(tf_message(types, int(tt[0]), fixed, ros1),
                                                   tf.TF_TYPE))  # fmt: skip
        moving = writer.add_connection("/tf", tf.TF_TYPE, typestore=types)
        for t_ns in tt.tolist():
            angle = (t_ns - T0_NS) / 1e9 * 0.3
            v = np.array([0.0, 0.0, 0.1, 0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)])
            edges = [(p, c, v) for p, c in itertools.pairwise(ARM)]
            edges += [(p, c, v) for p, c in FINGERS]
            writer.write(moving, t_ns, serialize(tf_message(types, t_ns, edges, ros1), tf.TF_TYPE))
    return path


def tf_part(path: Path) -> tuple[int, float, float]:
    """TFMessages, seconds to deserialise them and collect the edges, seconds to compose."""
    from rosbags.highlevel import AnyReader

    with AnyReader([path]) as reader:
        connections = [c for c in reader.connections if c.msgtype == tf.TF_TYPE]
        topics: dict[str, tuple[list[int], list[bytes]]] = {}
        for connection, t_ns, raw in reader.messages(connections):
            times, payloads = topics.setdefault(connection.topic, ([], []))
            times.append(t_ns)
            payloads.append(raw)
        count = sum(len(times) for times, _ in topics.values())
        started = time.perf_counter()
        edges = tf.collect_edges(
            [(topic == "/tf_static", *found) for topic, found in sorted(topics.items())],
            lambda r: reader.deserialize(r, tf.TF_TYPE),
            ros1=not reader.is2,
        )
        collected = time.perf_counter()
        tf.pose_stream(edges, "base_link", "tool0", path)
    return count, collected - started, time.perf_counter() - collected


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--layouts", nargs="+", default=["ros1", "mcap"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        print(f"{args.minutes:g}-minute log: 1 kHz WrenchStamped + 100 Hz /tf of 8 links")
        print(f"{'layout':<7} {'convert s':>9} {'tf msgs':>8} {'decode+collect s':>16} "
              f"{'us/msg':>7} {'compose s':>9}")  # fmt: skip
        for layout in args.layouts:
            path = write_log(folder, layout, args.minutes)
            started = time.perf_counter()
            with warnings.catch_warnings():  # the wrench's frame differs from base_link's
                warnings.simplefilter("ignore")
                convert(path, folder / f"{layout}.mcap", "gown", pose_tf="base_link:tool0")
            total = time.perf_counter() - started
            count, collect_s, compose_s = tf_part(path)
            print(f"{layout:<7} {total:>9.2f} {count:>8} {collect_s:>16.3f} "
                  f"{collect_s / count * 1e6:>7.1f} {compose_s:>9.3f}")  # fmt: skip


if __name__ == "__main__":
    main()
