"""Analytic end-effector signals and the ROS bags built from them, for the converter tests.

Bags are written with rosbags' own serialisers (per message), so the
converter's bulk numpy decoding is checked against an independent encoder.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

T0_NS = 1_700_000_000_123_456_789  # an absolute ROS time, not on any 10 ms boundary
VIBRATION_HZ = 200.0  # above the grid's Nyquist limit; 10 ms bins hold whole periods of it


def wrench(t: np.ndarray, vibration: bool = True) -> np.ndarray:
    """(T, 6) force and torque at seconds `t` since T0; the slow part is what survives 100 Hz."""
    shake = 0.5 * np.sin(2 * np.pi * VIBRATION_HZ * t + 0.7) if vibration else 0.0
    return np.stack(
        [
            2.0 * np.sin(2 * np.pi * 0.5 * t),
            np.cos(2 * np.pi * 0.3 * t),
            5.0 + 0.5 * t + shake,
            0.1 * np.sin(2 * np.pi * 0.2 * t),
            0.05 * t,
            np.full_like(t, -0.2),
        ],
        axis=1,
    )


W = 2 * np.pi * 0.25  # rad/s of the circular part of the path
YAW_RATE = 0.3  # rad/s about z


def pose(t: np.ndarray) -> np.ndarray:
    """(T, 7) position and quaternion (x y z w): a helix-like path, yawing steadily."""
    yaw = YAW_RATE * t
    zeros = np.zeros_like(t)
    return np.stack(
        [0.1 * np.sin(W * t), 0.2 * t, 0.05 * np.cos(W * t),
         zeros, zeros, np.sin(yaw / 2), np.cos(yaw / 2)],
        axis=1,
    )  # fmt: skip


def twist(t: np.ndarray) -> np.ndarray:
    """(T, 6) the exact derivative of `pose`: linear and angular (world frame) velocity."""
    zeros = np.zeros_like(t)
    return np.stack(
        [0.1 * W * np.cos(W * t), np.full_like(t, 0.2), -0.05 * W * np.sin(W * t),
         zeros, zeros, np.full_like(t, YAW_RATE)],
        axis=1,
    )  # fmt: skip


def times(rate_hz: float, seconds: float, offset_s: float = 0.0) -> np.ndarray:
    """Integer ns stamps from T0 + offset at `rate_hz`."""
    n = round(seconds * rate_hz)
    return T0_NS + round(offset_s * 1e9) + np.round(np.arange(n) * 1e9 / rate_hz).astype(np.int64)


def seconds_of(t_ns: np.ndarray) -> np.ndarray:
    return (np.asarray(t_ns) - T0_NS) / 1e9


# -- rosbags messages ------------------------------------------------------------------------


def typestore(ros1: bool):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)


def _header(store, ros1: bool, t_ns: int, frame: str):
    types = store.types
    stamp = types["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
    if ros1:
        return types["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)
    return types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)


def message(store, ros1: bool, kind: str, t_ns: int, values: Iterable[float], frame: str = "ft"):
    """A rosbags message object of `kind` (wrench, twist, pose, string) for one sample."""
    types = store.types
    v = [float(x) for x in values]
    if kind == "string":
        return types["std_msgs/msg/String"](data="unrelated")
    header = _header(store, ros1, t_ns, frame)
    vec = types["geometry_msgs/msg/Vector3"]
    if kind == "wrench":
        body = types["geometry_msgs/msg/Wrench"](force=vec(*v[:3]), torque=vec(*v[3:]))
        return types["geometry_msgs/msg/WrenchStamped"](header=header, wrench=body)
    if kind == "twist":
        body = types["geometry_msgs/msg/Twist"](linear=vec(*v[:3]), angular=vec(*v[3:]))
        return types["geometry_msgs/msg/TwistStamped"](header=header, twist=body)
    point = types["geometry_msgs/msg/Point"](*v[:3])
    quat = types["geometry_msgs/msg/Quaternion"](*v[3:])
    body = types["geometry_msgs/msg/Pose"](position=point, orientation=quat)
    return types["geometry_msgs/msg/PoseStamped"](header=header, pose=body)


TYPES = {
    "wrench": "geometry_msgs/msg/WrenchStamped",
    "twist": "geometry_msgs/msg/TwistStamped",
    "pose": "geometry_msgs/msg/PoseStamped",
    "string": "std_msgs/msg/String",
}

#: topic -> (kind, header stamps ns, values (T, D)); log times are the stamps, sorted.
Topics = dict[str, tuple[str, np.ndarray, np.ndarray]]


def standard_topics(seconds: float = 3.0) -> Topics:
    """1 kHz wrench, 50 Hz pose starting 3 ms later, and two unrelated topics."""
    tw, tp, ts = times(1000, seconds), times(50, seconds, 0.003), times(10, seconds)
    return {
        "/ft_sensor/wrench": ("wrench", tw, wrench(seconds_of(tw))),
        "/arm/ee_pose": ("pose", tp, pose(seconds_of(tp))),
        "/rosout_text": ("string", ts, np.zeros((len(ts), 0))),
        "/diagnostics_text": ("string", ts + 1, np.zeros((len(ts), 0))),
    }


def write_bag(
    path: Path,
    topics: Topics,
    layout: str,
    unstamped: Iterable[str] = (),
    stamp_lead_ns: Mapping[str, int] | None = None,
    frames: Mapping[str, str] | None = None,
) -> Path:
    """Write `topics` as `ros1` (.bag), `sqlite3` or `mcap` (ROS 2 folder); returns the input.

    The `unstamped` topics' header stamps are left 0, as a driver that never fills
    them does; their messages are still logged at their times. `stamp_lead_ns` moves
    a topic's header stamps ahead of its log times, as a sensor on its own clock does;
    `frames` names a topic's header frame (else `ft`).
    """
    lead = stamp_lead_ns or {}
    unstamped = set(unstamped)
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    ros1 = layout == "ros1"
    store = typestore(ros1)
    if ros1:
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.MCAP if layout == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(path, version=9, storage_plugin=plugin)
    serialize = store.serialize_ros1 if ros1 else store.serialize_cdr
    with writer:
        for topic, (kind, stamps, values) in topics.items():
            connection = writer.add_connection(topic, TYPES[kind], typestore=store)
            # a recorder logs in arrival order: log times increase even when stamps do not
            log_times = np.sort(stamps).tolist()
            for t_ns, log_ns, row in zip(stamps.tolist(), log_times, values, strict=True):
                stamp = 0 if topic in unstamped else t_ns + lead.get(topic, 0)
                frame = (frames or {}).get(topic, "ft")
                raw = serialize(message(store, ros1, kind, stamp, row, frame), TYPES[kind])
                writer.write(connection, log_ns, raw)
    return path
