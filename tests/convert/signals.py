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

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if ros1:  # Noetic's store lacks tf2_msgs; a ROS 1 bag carries its definition
        from rosbags.typesys import get_types_from_msg

        text = "geometry_msgs/TransformStamped[] transforms"
        store.register(get_types_from_msg(text, "tf2_msgs/msg/TFMessage"))
    return store


def _header(store, ros1: bool, t_ns: int, frame: str):
    types = store.types
    stamp = types["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
    if ros1:
        return types["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)
    return types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)


def message(store, ros1: bool, kind: str, t_ns: int, values: Iterable[float], frame: str = "ft"):
    """A rosbags message object of `kind` (wrench, twist, pose, string, tf) for one sample;
    a tf sample's values are its transforms, each (parent, child, x y z qx qy qz qw)."""
    types = store.types
    if kind == "tf":
        return types["tf2_msgs/msg/TFMessage"](
            transforms=[transform(store, ros1, t_ns, *edge) for edge in values]
        )
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


def transform(store, ros1: bool, t_ns: int, parent: str, child: str, values: Iterable[float]):
    """A TransformStamped placing `child` in `parent` at x y z, quaternion qx qy qz qw."""
    types, v = store.types, [float(x) for x in values]
    move = types["geometry_msgs/msg/Transform"](
        translation=types["geometry_msgs/msg/Vector3"](*v[:3]),
        rotation=types["geometry_msgs/msg/Quaternion"](*v[3:]),
    )
    return types["geometry_msgs/msg/TransformStamped"](
        header=_header(store, ros1, t_ns, parent), child_frame_id=child, transform=move
    )


TYPES = {
    "wrench": "geometry_msgs/msg/WrenchStamped",
    "twist": "geometry_msgs/msg/TwistStamped",
    "pose": "geometry_msgs/msg/PoseStamped",
    "string": "std_msgs/msg/String",
    "tf": "tf2_msgs/msg/TFMessage",
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


# -- a tf tree ------------------------------------------------------------------------------

#: world -> base (static): the robot's base 0.5 m along x, 0.8 m up, turned a quarter about z
BASE_IN_WORLD = (0.5, -0.2, 0.8, 0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4))
#: link1 -> tool (static): the tool 0.1 m along link1's z, turned a quarter about x
TOOL_IN_LINK1 = (0.0, 0.0, 0.1, np.sin(np.pi / 4), 0.0, 0.0, np.cos(np.pi / 4))


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    (ax, ay, az, aw), (bx, by, bz, bw) = np.moveaxis(a, -1, 0), np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz],
                    axis=-1)  # fmt: skip


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """v (.., 3) turned by q (.., 4): the vector part of q v q*."""
    q, v = np.broadcast_arrays(np.asarray(q, float), np.asarray(v, float)[..., [0, 1, 2, 2]])
    pure = v * np.array([1.0, 1.0, 1.0, 0.0])
    return quat_multiply(quat_multiply(q, pure), q * np.array([-1.0, -1.0, -1.0, 1.0]))[..., :3]


def tool_in_world(t: np.ndarray) -> np.ndarray:
    """(T, 7) the tool's pose in world: `pose` (the tool in base) seen through the base."""
    base, tool = np.asarray(BASE_IN_WORLD), pose(t)
    position = base[:3] + quat_rotate(base[3:], tool[:, :3])
    return np.concatenate([position, quat_multiply(base[3:], tool[:, 3:])], axis=1)


def tool_twist_in_world(t: np.ndarray) -> np.ndarray:
    """(T, 6) `twist` seen through the base's turn."""
    vel = twist(t)
    turn = np.asarray(BASE_IN_WORLD)[3:]
    return np.concatenate([quat_rotate(turn, vel[:, :3]), quat_rotate(turn, vel[:, 3:])], axis=1)


def tf_topics(seconds: float = 3.0, base_on_tf_hz: float | None = None) -> Topics:
    """1 kHz wrench and a robot_state_publisher's tf: 100 Hz /tf (base -> link1, moving so
    that the tool in base follows `pose`, and base -> elbow) and /tf_static (world -> base,
    link1 -> tool, world -> camera). `base_on_tf_hz`: world -> base on a tf topic of its
    own at that rate instead, as a localisation node publishes it."""
    tw, tf = times(1000, seconds), times(100, seconds, 0.002)
    tool, fixed = pose(seconds_of(tf)), np.asarray(TOOL_IN_LINK1)
    turn = quat_multiply(tool[:, 3:], fixed[3:] * np.array([-1.0, -1.0, -1.0, 1.0]))
    link1 = np.concatenate([tool[:, :3] - quat_rotate(turn, fixed[:3]), turn], axis=1)
    elbow = np.zeros((len(tf), 7))
    elbow[:, 6] = 1.0
    moving = [
        (("base", "link1", row), ("base", "elbow", other))
        for row, other in zip(link1, elbow, strict=True)
    ]
    static = [("world", "camera", (1.0, 0, 2.0, 0, 0, 0, 1.0)), ("link1", "tool", TOOL_IN_LINK1)]
    if base_on_tf_hz is None:
        static.append(("world", "base", BASE_IN_WORLD))
    ts = times(1, 1.0, -0.5)  # latched: published once, before the rest
    topics: Topics = {
        "/ft_sensor/wrench": ("wrench", tw, wrench(seconds_of(tw))),
        "/tf": ("tf", tf, moving),
        "/tf_static": ("tf", ts, [static]),
    }
    if base_on_tf_hz is not None:
        tb = times(base_on_tf_hz, seconds + 1.0, -0.5)
        base = [[("world", "base", BASE_IN_WORLD)]] * len(tb)
        topics["/localisation/tf"] = ("tf", tb, base)
    return topics
