"""The standard channels a 3D viewer draws, encoded beside dresslog's own.

dresslog's own messages (`ForceMap`, `LimbPoints`, `GarmentState`) decode in any ROS 2
tool, but no viewer knows how to draw them. So `TrialWriter` adds, from the same data,
the standard types Foxglove's 3D panel and Rerun's MCAP importer draw:

- the force maps as `sensor_msgs/msg/PointCloud2` on the limb's points, float32 fields
  x, y, z and `force` (N), at 20 Hz (the first map of every 50 ms): a viewer colours the
  cloud by `force`. At the maps' 100 Hz the clouds added 13% to a trial, at 20 Hz 3%;
  the 100 Hz maps stay on `/limb/force_map` for analysis;
- the limb (once, latched), the garment's mesh (at its 10 Hz) and the gripper's path
  (once, latched, written at the end) as `visualization_msgs/msg/MarkerArray`;
- the frames: `/tf_static` (world -> limb, once) and `/tf` (world -> gripper, the pose,
  and world -> ee, the sensor frame the wrench is given in: the gripper's centre with
  world-aligned axes) at every pose, 100 Hz: a program that places the wrench by tf
  finds its frame at every step (3 ms of writing and 14 KB a 7 s trial).

Every function returns encoded messages (a structured array from `cdr.new_messages`);
the writer names the topics and writes them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from dresslog.io import cdr

POINT_CLOUD = "sensor_msgs/msg/PointCloud2"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"

WORLD = "world"
LIMB = "limb"
GRIPPER = "gripper"
SENSOR = "ee"

#: The 100 Hz force maps are drawn once per this period (ns): 20 Hz, as smooth as a
#: viewer plays, and a fifth of the bytes.
PERIOD_NS = 50_000_000
#: The cloud's point fields: name, byte offset; each one float32 (PointField.FLOAT32 = 7).
CLOUD_FIELDS = (("x", 0), ("y", 4), ("z", 8), ("force", 12))
_FLOAT32 = 7
_POINT_STEP = 16

#: Marker types and action (visualization_msgs/msg/Marker's constants).
LINE_STRIP, SPHERE_LIST, TRIANGLE_LIST = 4, 7, 11
_ADD = 0


class Look(NamedTuple):
    """What a marker looks like: its type, scale (m; a line's width is x), colour r g b a."""

    kind: int
    scale: tuple[float, float, float]
    color: tuple[float, float, float, float]


LIMB_LOOK = Look(SPHERE_LIST, (0.012, 0.012, 0.012), (0.93, 0.78, 0.66, 0.35))
GARMENT_LOOK = Look(TRIANGLE_LIST, (1.0, 1.0, 1.0), (0.30, 0.50, 0.85, 0.75))
PATH_LOOK = Look(LINE_STRIP, (0.004, 0.0, 0.0), (0.95, 0.60, 0.10, 1.0))

#: The strings a marker holds besides its frame and namespace: all empty.
_MARKER_STRINGS = ("texture_resource", "texture.header.frame_id", "texture.format", "text",
                   "mesh_resource", "mesh_file.filename")  # fmt: skip
_MARKER_SEQUENCES = ("colors", "texture.data", "uv_coordinates", "mesh_file.data")


def point_clouds(t_ns: np.ndarray, points: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """One PointCloud2 per force map: the limb's (N, 3) points with forces (T, N), in frame
    `limb`, stamped `t_ns` (T,)."""
    count, n = forces.shape
    sizes: dict[str, int | tuple[int, ...]] = {
        "header.frame_id": len(LIMB),
        "fields": len(CLOUD_FIELDS),
        "data": n * _POINT_STEP,
    }
    sizes |= {f"fields.{i}.name": len(name) for i, (name, _) in enumerate(CLOUD_FIELDS)}
    msgs = cdr.new_messages(POINT_CLOUD, sizes, count)
    cdr.set_stamp(msgs, t_ns, LIMB)
    for i, (name, offset) in enumerate(CLOUD_FIELDS):
        msgs[f"fields.{i}.name"] = name.encode()
        msgs[f"fields.{i}.offset"] = offset
        msgs[f"fields.{i}.datatype"] = _FLOAT32
        msgs[f"fields.{i}.count"] = 1
    msgs["height"], msgs["width"] = 1, n
    msgs["point_step"], msgs["row_step"] = _POINT_STEP, n * _POINT_STEP
    msgs["is_dense"] = 1
    data = np.empty((count, n, 4), "<f4")
    data[:, :, :3] = np.asarray(points, np.float32)
    data[:, :, 3] = forces
    msgs["data"] = data.reshape(count, -1).view("u1")
    return msgs


def marker_array(t_ns: int, frame: str, ns: str, look: Look, points: np.ndarray) -> np.ndarray:
    """A MarkerArray of one marker (ADD, lives until replaced) drawing `points` (P, 3)."""
    kind, scale, color = look
    sizes: dict[str, int | tuple[int, ...]] = {
        "markers": 1,
        "markers.0.header.frame_id": len(frame),
        "markers.0.ns": len(ns),
        "markers.0.points": len(points),
    }
    sizes |= {f"markers.0.{name}": 0 for name in (*_MARKER_STRINGS, *_MARKER_SEQUENCES)}
    msgs = cdr.new_messages(MARKER_ARRAY, sizes, 1)
    msgs["markers.0.header.stamp.sec"], msgs["markers.0.header.stamp.nanosec"] = divmod(
        int(t_ns), 1_000_000_000
    )
    msgs["markers.0.header.frame_id"] = frame.encode()
    msgs["markers.0.ns"] = ns.encode()
    msgs["markers.0.type"], msgs["markers.0.action"] = kind, _ADD
    msgs["markers.0.pose.orientation"] = (0.0, 0.0, 0.0, 1.0)
    msgs["markers.0.scale"], msgs["markers.0.color"] = scale, color
    msgs["markers.0.points"] = np.asarray(points, np.float64)
    return msgs


def transforms(t_ns: np.ndarray, links: list[tuple[str, str, np.ndarray]]) -> np.ndarray:
    """One TFMessage per stamp holding every link (parent, child, (T, 7) position and
    quaternion x y z w), each transform stamped as its message."""
    sizes: dict[str, int | tuple[int, ...]] = {"transforms": len(links)}
    for i, (parent, child, _) in enumerate(links):
        sizes[f"transforms.{i}.header.frame_id"] = len(parent)
        sizes[f"transforms.{i}.child_frame_id"] = len(child)
    t_ns = np.asarray(t_ns, np.int64)
    msgs = cdr.new_messages(TF_MESSAGE, sizes, len(t_ns))
    for i, (parent, child, pose) in enumerate(links):
        head = f"transforms.{i}."
        msgs[head + "header.stamp.sec"] = t_ns // 1_000_000_000
        msgs[head + "header.stamp.nanosec"] = t_ns % 1_000_000_000
        msgs[head + "header.frame_id"] = parent.encode()
        msgs[head + "child_frame_id"] = child.encode()
        msgs[head + "transform.translation"] = pose[:, :3]
        msgs[head + "transform.rotation"] = pose[:, 3:]
    return msgs


def moving_frames(t_ns: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """`/tf` at each pose: world -> gripper (the pose) and world -> ee (its position,
    world-aligned axes: the frame of `/ee/wrench`)."""
    level = np.zeros_like(pose)
    level[:, :3], level[:, 6] = pose[:, :3], 1.0
    return transforms(t_ns, [(WORLD, GRIPPER, pose), (WORLD, SENSOR, level)])


def static_frames(t_ns: int) -> np.ndarray:
    """`/tf_static`, once: world -> limb, where the limb's points and shape are given."""
    identity = np.array([[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]])
    return transforms(np.array([t_ns]), [(WORLD, LIMB, identity)])
