"""Benchmark: convert a 10-minute log (1 kHz WrenchStamped + 100 Hz PoseStamped) to a trial.

`dresslog.convert` end to end (read, bulk numpy decode, resample, write the
trial) against reading the same topics with rosbags' own per-message
deserialisation (no resampling, no writing), measured in the same run. The same
signals as a force/torque CSV beside a pose CSV (`csv`) are measured against
`np.loadtxt` reading the two files alone (the parse dresslog's reader starts with;
no checks, no resampling, no writing), so their ratio is what the rest costs.
Target: >= 100,000 messages (CSV lines) /s end to end.

    python tests/benchmarks/bench_convert.py [--minutes 10] [--layouts ros1 sqlite3 mcap csv]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from dresslog.convert import convert
from dresslog.convert.rosbag import FIELDS, ros1_dtype
from dresslog.convert.source import MESSAGE_TYPES
from dresslog.io import cdr

T0_NS = 1_700_000_000_000_000_000
FRAME = "ft_sensor"


def signals(minutes: float) -> dict[str, tuple[str, np.ndarray, np.ndarray]]:
    """topic -> (kind, stamps, values): a noisy 1 kHz wrench and a smooth 100 Hz pose."""
    rng = np.random.default_rng(0)
    tw = T0_NS + np.arange(round(minutes * 60_000), dtype=np.int64) * 1_000_000
    tp = T0_NS + 3_000_000 + np.arange(round(minutes * 6_000), dtype=np.int64) * 10_000_000
    s = (tp - T0_NS) / 1e9
    position = np.stack([0.1 * np.sin(s), 0.1 * np.cos(s), 0.01 * s], axis=1)
    quat = np.tile([0.0, 0.0, 0.0, 1.0], (len(tp), 1))
    return {
        "/ft/wrench": ("wrench", tw, rng.normal(size=(len(tw), 6))),
        "/arm/pose": ("pose", tp, np.concatenate([position, quat], axis=1)),
    }


def payloads(kind: str, stamps: np.ndarray, values: np.ndarray, ros1: bool) -> list[bytes]:
    """Serialised messages built in bulk (rosbags' per-message serialiser would take minutes)."""
    if ros1:
        msgs = np.zeros(len(stamps), dtype=ros1_dtype(len(FRAME), values.shape[1]))
        msgs["seq"] = np.arange(len(stamps))
        msgs["sec"], msgs["nsec"] = stamps // 10**9, stamps % 10**9
        msgs["frame_len"] = len(FRAME)
        msgs["values"] = values
        buf, size = bytearray(msgs.tobytes()), msgs.dtype.itemsize
        for i in range(len(FRAME)):
            buf[16 + i :: size] = FRAME[i].encode() * len(stamps)
        buf = bytes(buf)
    else:
        msgtype = MESSAGE_TYPES[kind]
        msgs = cdr.new_messages(msgtype, {"header.frame_id": len(FRAME)}, len(stamps))
        cdr.set_stamp(msgs, stamps, FRAME)
        a, b = FIELDS[kind]
        width = msgs[a].shape[1]
        msgs[a], msgs[b] = values[:, :width], values[:, width:]
        buf, size = msgs.tobytes(), msgs.dtype.itemsize
    return [buf[i : i + size] for i in range(0, len(buf), size)]


def write_csv(folder: Path, minutes: float) -> tuple[Path, Path]:
    """The signals as a logger writes them: seconds from its start, units in the header."""
    (_, tw, wrench), (_, tp, pose) = signals(minutes).values()
    paths = folder / "ft.csv", folder / "pose.csv"
    for path, t, values, header in (
        (paths[0], tw, wrench, "time (s),Fx (N),Fy (N),Fz (N),Tx (N m),Ty (N m),Tz (N m)"),
        (paths[1], tp, pose, "time (s),x (m),y (m),z (m),qx,qy,qz,qw"),
    ):
        rows = np.column_stack([(t - T0_NS) / 1e9, values])
        np.savetxt(path, rows, fmt="%.6f", delimiter=",", header=header, comments="")
    return paths


def loadtxt_baseline(paths: tuple[Path, Path]) -> tuple[int, float]:
    """Parse the two CSVs with `np.loadtxt` alone."""
    started = time.perf_counter()
    count = sum(len(np.loadtxt(path, delimiter=",", skiprows=1)) for path in paths)
    return count, time.perf_counter() - started


def write_log(folder: Path, layout: str, minutes: float) -> Path:
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ros1 = layout == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    path = folder / ("log.bag" if ros1 else f"log_{layout}")
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if layout == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    with writer:
        for topic, (kind, stamps, values) in signals(minutes).items():
            connection = writer.add_connection(topic, MESSAGE_TYPES[kind], typestore=store)
            for t_ns, raw in zip(
                stamps.tolist(), payloads(kind, stamps, values, ros1), strict=True
            ):
                writer.write(connection, t_ns, raw)
    return path


def rosbags_baseline(path: Path) -> tuple[int, float]:
    """Read the two topics with AnyReader and deserialise every message into numpy arrays."""
    from rosbags.highlevel import AnyReader

    started = time.perf_counter()
    rows: dict[str, list] = {"/ft/wrench": [], "/arm/pose": []}
    with AnyReader([path]) as reader:
        connections = [c for c in reader.connections if c.topic in rows]
        for connection, _, raw in reader.messages(connections=connections):
            msg = reader.deserialize(raw, connection.msgtype)
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            if connection.topic == "/ft/wrench":
                f, m = msg.wrench.force, msg.wrench.torque
                rows["/ft/wrench"].append((stamp, f.x, f.y, f.z, m.x, m.y, m.z))
            else:
                p, q = msg.pose.position, msg.pose.orientation
                rows["/arm/pose"].append((stamp, p.x, p.y, p.z, q.x, q.y, q.z, q.w))
    arrays = {topic: np.array(r) for topic, r in rows.items()}
    return sum(map(len, arrays.values())), time.perf_counter() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--layouts", nargs="+", default=["ros1", "sqlite3", "mcap", "csv"])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        print(f"{args.minutes:g}-minute log: 1 kHz WrenchStamped + 100 Hz PoseStamped")
        print(f"{'layout':<8} {'messages':>9} {'peer msg/s':>14} {'dresslog msg/s':>15} "
              f"{'ratio':>6} {'convert s':>10}")  # fmt: skip
        for layout in args.layouts:
            if layout == "csv":
                path, motion = write_csv(folder, args.minutes)
                count, base_s = loadtxt_baseline((path, motion))
            else:
                path, motion = write_log(folder, layout, args.minutes), None
                count, base_s = rosbags_baseline(path)
            started = time.perf_counter()
            report = convert(path, folder / f"{layout}.mcap", "gown", motion=motion)
            ours_s = time.perf_counter() - started
            assert report.messages_in == count
            base, ours = count / base_s, count / ours_s
            print(f"{layout:<8} {count:>9} {base:>14,.0f} {ours:>15,.0f} "
                  f"{ours / base:>5.1f}x {ours_s:>10.2f}")  # fmt: skip
        print("peer: rosbags' deserialisation (bags), np.loadtxt's parse alone (csv)")
        print("target: >= 100,000 messages/s end to end")


if __name__ == "__main__":
    main()
