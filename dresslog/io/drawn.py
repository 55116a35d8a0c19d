"""The standard channels a 3D viewer draws, encoded beside dresslog's own.

dresslog's own messages (`ForceMap`, `LimbPoints`, `GarmentState`) decode in any ROS 2
tool, but no viewer knows how to draw them. So `TrialWriter` adds, from the same data,
the standard types Foxglove's 3D panel and Rerun's MCAP importer draw. A view needs what
the eye sees, not every value to the last bit (dresslog's channels keep those for
analysis), so the drawn channels are thinned in time and their values put on grids of
powers of two, whose zeroed low bits compress: they add about 60 KB to a 7 s trial, 4%
of the sample trials, where drawing every value at its own rate added 24-30%
(docs/benchmarks.md).

- the force maps as `sensor_msgs/msg/PointCloud2` on the limb's points, float32 fields
  x, y, z and `force` (N), at 10 Hz (the first map of every 100 ms), the forces on a
  grid of `FORCE_STEP` (2**-12 N, an eighth of a colour step of the Foxglove layout's
  0-0.5 N scale), which halves the clouds' bytes: a viewer colours the cloud by `force`;
- the garment's mesh as `foxglove_msgs/msg/SceneUpdate` at 2 Hz (the first state of each
  500 ms): one entity, `garment`, holding a triangle list of the garment's vertices and
  their indices. A visualization_msgs `TRIANGLE_LIST` holds each triangle's three corners,
  every vertex six times as float64: 23 KB a message that zstd brought only to 3.8 KB,
  14% of a trial at the garment's 10 Hz. Foxglove draws both; Rerun 0.41's importer
  draws neither (it has no marker or scene type), so the same vertices go beside each
  mesh as a `PointCloud2` (`/garment/cloud`, float64 x y z), which it draws as points:
  their bytes are the mesh's, and written next to it they cost 1 KB a trial;
- the limb (once, latched) as a `visualization_msgs/msg/MarkerArray` of spheres, and the
  gripper's path (once, latched, written at the end) as a line strip through its pose
  at 10 Hz and its last pose;
- positions drawn (mesh, limb, path; not the clouds', which are the limb points' own
  float32) on a grid of `POSITION_STEP` (2**-10 m, about a millimetre);
- the frames: `/tf_static` (world -> limb, once) and `/tf` (world -> gripper, the pose,
  and world -> ee, the sensor frame the wrench is given in: the gripper's centre with
  world-aligned axes) at every pose, 100 Hz, each transform stamped as its pose: a
  program that places the wrench by tf finds its frame at every step. A message holds
  the poses of 100 ms (`moving_frames`): one message a pose cost a record and 16 bytes
  of index each, 26 KB of a 7 s trial, where the poses of 100 ms together take 9 KB.

Every function returns encoded messages (a structured array from `cdr.new_messages`),
or their payloads; the writer names the topics and writes them.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

from dresslog.io import cdr

POINT_CLOUD = "sensor_msgs/msg/PointCloud2"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
SCENE_UPDATE = "foxglove_msgs/msg/SceneUpdate"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"

WORLD = "world"
LIMB = "limb"
GRIPPER = "gripper"
SENSOR = "ee"

#: The 100 Hz force maps are drawn once per this period (ns): 10 Hz, a tenth of the bytes.
CLOUD_PERIOD_NS = 100_000_000
#: The garment's 10 Hz states are drawn once per this period (ns): 2 Hz shows the drape.
MESH_PERIOD_NS = 500_000_000
#: `/tf` holds every pose, the poses of each period (ns) in one message: a TFMessage per
#: pose cost 16 bytes of index and a record each, more than its compressed transforms.
TF_PERIOD_NS = 100_000_000
#: The gripper's path passes through its pose once per this period (ns), and its last.
PATH_PERIOD_NS = 100_000_000
#: The grids drawn values are rounded to (N, m): powers of two, so a rounded value's low
#: mantissa bits are zeros that compress, and within what a viewer shows.
FORCE_STEP = 2.0**-12
POSITION_STEP = 2.0**-10
#: A cloud's point fields by letter, and their datatypes (PointField's FLOAT32, FLOAT64).
_FIELD_NAMES = {"x": "x", "y": "y", "z": "z", "f": "force"}
_DATATYPES = {"<f4": 7, "<f8": 8}

#: Marker types and action (visualization_msgs/msg/Marker's constants).
LINE_STRIP, SPHERE_LIST = 4, 7
_ADD = 0


class Look(NamedTuple):
    """What a marker looks like: its type, scale (m; a line's width is x), colour r g b a."""

    kind: int
    scale: tuple[float, float, float]
    color: tuple[float, float, float, float]


LIMB_LOOK = Look(SPHERE_LIST, (0.012, 0.012, 0.012), (0.93, 0.78, 0.66, 0.35))
#: The garment's colour, r g b a.
GARMENT_COLOR = (0.30, 0.50, 0.85, 0.75)
PATH_LOOK = Look(LINE_STRIP, (0.004, 0.0, 0.0), (0.95, 0.60, 0.10, 1.0))

#: The strings a marker holds besides its frame and namespace: all empty.
_MARKER_STRINGS = ("texture_resource", "texture.header.frame_id", "texture.format", "text",
                   "mesh_resource", "mesh_file.filename")  # fmt: skip
_MARKER_SEQUENCES = ("colors", "texture.data", "uv_coordinates", "mesh_file.data")
#: A scene entity's sequences besides its triangle list: all empty.
_ENTITY_SEQUENCES = ("metadata", "arrows", "cubes", "spheres", "cylinders", "lines", "texts",
                     "models")  # fmt: skip


def on_grid(values: np.ndarray, step: float) -> np.ndarray:
    """`values` rounded to multiples of `step` (a power of two), in their own dtype."""
    values = np.asarray(values)
    return np.round(values / step) * values.dtype.type(step)


def drawn_steps(t_ns: np.ndarray, period_ns: int, last_bin: int = -1) -> np.ndarray:
    """Which of the increasing stamps `t_ns` are drawn: the first of each `period_ns`, after
    stamps up to the period `last_bin` already drawn."""
    return np.diff(np.asarray(t_ns, np.int64) // period_ns, prepend=last_bin) != 0


def _clouds(t_ns: np.ndarray, frame: str, fields: str, data: np.ndarray) -> np.ndarray:
    """PointCloud2s (one a row of `data` (T, N, F), a dtype of `_DATATYPES`) of N points
    whose F fields are named by the letters of `fields`, in `frame`, stamped `t_ns`."""
    count, n, width = data.shape
    size = data.dtype.itemsize
    sizes: dict[str, int | tuple[int, ...]] = {
        "header.frame_id": len(frame),
        "fields": width,
        "data": n * width * size,
    }
    sizes |= {f"fields.{i}.name": len(_FIELD_NAMES[c]) for i, c in enumerate(fields)}
    msgs = cdr.new_messages(POINT_CLOUD, sizes, count)
    cdr.set_stamp(msgs, np.asarray(t_ns, np.int64), frame)
    for i, c in enumerate(fields):
        msgs[f"fields.{i}.name"] = _FIELD_NAMES[c].encode()
        msgs[f"fields.{i}.offset"] = i * size
        msgs[f"fields.{i}.datatype"] = _DATATYPES[data.dtype.str]
        msgs[f"fields.{i}.count"] = 1
    msgs["height"], msgs["width"] = 1, n
    msgs["point_step"], msgs["row_step"] = width * size, n * width * size
    msgs["is_dense"] = 1
    msgs["data"] = data.reshape(count, -1).view("u1")
    return msgs


def point_clouds(t_ns: np.ndarray, points: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """One PointCloud2 per force map: the limb's (N, 3) points, float32, with forces (T, N)
    on the `FORCE_STEP` grid, in frame `limb`, stamped `t_ns` (T,)."""
    count, n = forces.shape
    data = np.empty((count, n, 4), "<f4")
    data[:, :, :3] = np.asarray(points, np.float32)
    data[:, :, 3] = on_grid(np.asarray(forces, np.float32), FORCE_STEP)
    return _clouds(t_ns, LIMB, "xyzf", data)


def vertex_cloud(t_ns: int, frame: str, vertices: np.ndarray) -> np.ndarray:
    """A PointCloud2 of `vertices` (V, 3) on the `POSITION_STEP` grid, float64 x y z: the
    points of a `scene_update` byte for byte, so written beside it the cloud compresses to
    almost nothing, and Rerun's importer, which draws no mesh, draws the garment's points."""
    data = on_grid(np.asarray(vertices, np.float64), POSITION_STEP).astype("<f8")
    return _clouds(np.array([t_ns]), frame, "xyz", data[None])


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
    msgs["markers.0.points"] = on_grid(np.asarray(points, np.float64), POSITION_STEP)
    return msgs


def scene_update(
    t_ns: int, frame: str, entity: str, vertices: np.ndarray, indices: np.ndarray
) -> np.ndarray:
    """A SceneUpdate of one entity `entity` (replacing the last one of that id, kept until
    replaced) in `frame`: a triangle list of `vertices` (V, 3) on the `POSITION_STEP` grid,
    triangles by `indices` (3F,), in `GARMENT_COLOR`."""
    tri = "entities.0.triangles.0."
    sizes: dict[str, int | tuple[int, ...]] = {
        "deletions": 0,
        "entities": 1,
        "entities.0.frame_id": len(frame),
        "entities.0.id": len(entity),
        "entities.0.triangles": 1,
        tri + "points": len(vertices),
        tri + "colors": 0,
        tri + "indices": len(indices),
    }
    sizes |= {f"entities.0.{name}": 0 for name in _ENTITY_SEQUENCES}
    msgs = cdr.new_messages(SCENE_UPDATE, sizes, 1)
    msgs["entities.0.timestamp.sec"], msgs["entities.0.timestamp.nanosec"] = divmod(
        int(t_ns), 1_000_000_000
    )
    msgs["entities.0.frame_id"] = frame.encode()
    msgs["entities.0.id"] = entity.encode()
    msgs[tri + "pose.orientation"] = (0.0, 0.0, 0.0, 1.0)
    msgs[tri + "points"] = on_grid(np.asarray(vertices, np.float64), POSITION_STEP)
    msgs[tri + "color"] = GARMENT_COLOR
    msgs[tri + "indices"] = indices
    return msgs


def transforms(t_ns: np.ndarray, links: list[tuple[str, str, np.ndarray]]) -> np.ndarray:
    """One TFMessage per row of stamps `t_ns` (M, K): each holds, for each of its K stamps
    in turn, every link (parent, child, (M, K, 7) position and quaternion x y z w), each
    transform stamped with its own stamp."""
    t_ns = np.asarray(t_ns, np.int64)
    count, per = t_ns.shape
    sizes: dict[str, int | tuple[int, ...]] = {"transforms": per * len(links)}
    for k, (i, (parent, child, _)) in itertools.product(range(per), enumerate(links)):
        sizes[f"transforms.{k * len(links) + i}.header.frame_id"] = len(parent)
        sizes[f"transforms.{k * len(links) + i}.child_frame_id"] = len(child)
    msgs = cdr.new_messages(TF_MESSAGE, sizes, count)
    for k, (i, (parent, child, pose)) in itertools.product(range(per), enumerate(links)):
        head = f"transforms.{k * len(links) + i}."
        msgs[head + "header.stamp.sec"] = t_ns[:, k] // 1_000_000_000
        msgs[head + "header.stamp.nanosec"] = t_ns[:, k] % 1_000_000_000
        msgs[head + "header.frame_id"] = parent.encode()
        msgs[head + "child_frame_id"] = child.encode()
        msgs[head + "transform.translation"] = pose[:, k, :3]
        msgs[head + "transform.rotation"] = pose[:, k, 3:]
    return msgs


def moving_frames(t_ns: np.ndarray, pose: np.ndarray) -> tuple[np.ndarray, list[bytes]]:
    """`/tf` at each pose: world -> gripper (the pose) and world -> ee (its position,
    world-aligned axes: the frame of `/ee/wrench`), each stamped as its pose, the poses of
    each `TF_PERIOD_NS` in one message logged at the first of them. Returns the messages'
    log times and payloads, in time order.

    A message lists its poses latest first: a tf buffer (ROS's tf2, Foxglove) files each
    transform by its stamp, whatever the order, while Rerun 0.41's importer ignores the
    stamps and places every transform at the message's log time, where the last one
    listed wins: so it is the pose of that time, and Rerun moves the frames at 10 Hz."""
    t_ns = np.asarray(t_ns, np.int64)
    level = np.zeros_like(pose)
    level[:, :3], level[:, 6] = pose[:, :3], 1.0
    starts = np.flatnonzero(drawn_steps(t_ns, TF_PERIOD_NS))
    lengths = np.diff(starts, append=len(t_ns))
    payloads: dict[int, bytes] = {}
    for length in np.unique(lengths).tolist():  # one layout per number of poses
        first = starts[lengths == length]
        rows = first[:, None] + np.arange(length)[::-1]  # latest first
        links = [(WORLD, GRIPPER, pose[rows]), (WORLD, SENSOR, level[rows])]
        encoded = cdr.to_payloads(transforms(t_ns[rows], links))
        payloads |= zip(first.tolist(), encoded, strict=True)
    return t_ns[starts], [payloads[i] for i in starts.tolist()]


def static_frames(t_ns: int) -> np.ndarray:
    """`/tf_static`, once: world -> limb, where the limb's points and shape are given."""
    identity = np.array([[[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]])
    return transforms(np.array([[t_ns]]), [(WORLD, LIMB, identity)])
