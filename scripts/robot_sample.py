"""Make samples/robot/: the sample gown trial as a robot would log it, for `convert` to read.

A new user has no robot log at hand, so the README's "Your robot's data" example runs on
this one: `samples/gown.mcap`'s wrench and pose, re-expressed the way a wrist
force/torque sensor and a robot's kinematics log them (a simulated trial, not a real
robot's):

- ft.csv: 500 Hz force (N) and torque (N m) in the sensor's own axes (the tool turned
  180 degrees about x, its z pointing down), with the hanging gown's weight not tared
  away and a little sensor noise; each sample reads the 10 ms step it falls in, so
  `convert`'s 10 ms bin average gives each step back but for the noise;
- both begin with the gown hanging still for 1 s before the gripper moves (what `--tare`
  takes as zero), as a robot's log does;
- pose.csv: 100 Hz gripper position (m) and orientation in the robot's base frame,
  whose +y runs along the limb from shoulder to hand (the world turned +90 degrees
  about z, placed 0.6 m from the limb), and no velocity: `convert` differentiates it;
- bag/: the same log as a ROS 2 bag (MCAP storage, zstd chunks), as a ROS robot records
  it: the samples on /ft_sensor/wrench (WrenchStamped in frame ft_sensor), header
  stamps on the robot's clock (epoch time), and the gripper's pose only in the tf tree,
  as robot_state_publisher puts it: base_link -> shoulder_link -> wrist_link on /tf at
  100 Hz (one TFMessage a step, both moving links alike), the tool's fixed mount
  wrist_link -> tool0 and the sensor's frame tool0 -> ft_sensor (the tool's axes and
  centre) on /tf_static, so that tool0 in base_link is pose.csv's pose.

The output is deterministic (seeded noise), so running the script
again rewrites the same files (the bag needs `rosbags`, `pip install -e ".[ros]"`):

    python scripts/robot_sample.py [samples/gown.mcap] [-o samples/robot]
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.convert.resample import multiply, rotate_by_orientation, rotate_pose, rotate_vectors
from dresslog.io import TrialReader

#: The README's `convert --rotate`: -90 degrees about z turns the robot's base axes
#: (+y along the limb, shoulder to hand) into the world's (+x); the log is made by its inverse.
ROTATE = (0.0, 0.0, -np.sqrt(0.5), np.sqrt(0.5))
#: Where the world's origin (the elbow) lies in the base frame, m; the README's `convert
#: --translate` (0.1 0.6 -0.25) is this turned by ROTATE, negated.
ELBOW_IN_BASE = np.array([0.6, -0.1, 0.25])
#: The tool's orientation in the world: turned 180 degrees about x (z down).
TOOL_IN_WORLD = (1.0, 0.0, 0.0, 0.0)
#: The pose log's first time, s: the sensor's starts 6 ms earlier. Times count from the
#: logger's start (epoch seconds in a CSV's float64 lose the nanoseconds a grid is set by).
START_S = 0.01
SENSOR_HZ = 500
NOISE = (0.02, 0.001)  # N, N m: one standard deviation per sample
#: The gown hangs still this long before the gripper moves, as a robot's log begins, s.
HOLD_S = 1.0
#: The bag's clock: the logger's start as epoch time (2024-06-03 09:00 UTC), ns.
EPOCH_NS = 1_717_405_200 * 10**9
#: A recorder receives a message after its header stamp: the sensor's, the tf's, ns.
LATENCY_NS = {"/ft_sensor/wrench": 700_000, "/tf": 1_300_000, "/tf_static": 0}
#: The shoulder link's origin above base_link, m; it turns about z to face the wrist.
SHOULDER_IN_BASE = np.array([0.0, 0.0, 0.16])
#: tool0 on wrist_link (x y z, qx qy qz qw): 12 cm out along the flange's z, turned 90
#: degrees about it, as a gripper is mounted.
TOOL_IN_WRIST = (0.0, 0.0, 0.12, 0.0, 0.0, np.sqrt(0.5), np.sqrt(0.5))
#: ft_sensor on tool0: the sensor reads in the tool's axes about its centre.
SENSOR_IN_TOOL = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def _inverse(quat: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    return (-quat[0], -quat[1], -quat[2], quat[3])


def robot_log(trial: Path) -> tuple[np.ndarray, np.ndarray]:
    """(ft rows: time, fx..tz at 500 Hz; pose rows: time, x y z, qx qy qz qw at 100 Hz)."""
    with TrialReader(trial) as reader:
        wrench, pose = reader.wrench, reader.pose
        weight = reader.metadata.spec.sim.garment_mass * 9.81
    hold = round(HOLD_S * 100)
    seconds = START_S + np.arange(hold + len(wrench.t_ns)) / 100  # the trial's 100 Hz steps
    hanging = np.zeros((hold, 6))  # what the simulator tared away
    world = np.concatenate([hanging, wrench.values]) + np.array([0, 0, -weight, 0, 0, 0])
    sensor = rotate_vectors(world, _inverse(TOOL_IN_WORLD))  # in the tool's axes
    # the sensor's own clock, from a sample before the first step to one after the last:
    # each sample reads the step whose 10 ms it falls in (centred on the step's time)
    reach = (len(seconds) - 1) * SENSOR_HZ // 100 + 6
    ft_t = seconds[0] + (np.arange(reach + 1) - 3) / SENSOR_HZ
    step = np.clip(np.floor((ft_t - seconds[0]) * 100 + 0.5).astype(int), 0, len(seconds) - 1)
    noise = np.random.default_rng(0).normal(size=(len(ft_t), 6)) * np.repeat(NOISE, 3)
    ft = np.column_stack([ft_t, sensor[step] + noise])

    held = np.concatenate([np.repeat(pose.values[:1, :3], hold, axis=0), pose.values[:, :3]])
    tool = np.tile(TOOL_IN_WORLD, (len(held), 1))
    in_base = rotate_pose(np.column_stack([held, tool]), _inverse(ROTATE))
    in_base[:, :3] += ELBOW_IN_BASE
    pose_rows = np.column_stack([seconds, in_base])
    return ft, pose_rows


def _between(outer: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Poses (T, 7) of `pose` (given in the frame `outer` is given in) in `outer`'s frame."""
    turn_back = outer[:, 3:] * np.array([-1.0, -1.0, -1.0, 1.0])
    position = rotate_by_orientation(pose[:, :3] - outer[:, :3], turn_back)
    return np.column_stack([position, multiply(turn_back, pose[:, 3:])])


def tf_chain(pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The moving links of the gripper's pose rows (time, x y z, qx qy qz qw) in the base
    frame: (shoulder_link in base_link, wrist_link in shoulder_link), each (T, 7), such
    that composing them with TOOL_IN_WRIST gives the pose again."""
    tool = pose[:, 1:]
    mount = np.asarray(TOOL_IN_WRIST)
    unmount = np.tile(mount[3:] * np.array([-1.0, -1.0, -1.0, 1.0]), (len(tool), 1))
    wrist_q = multiply(tool[:, 3:], unmount)
    offset = rotate_by_orientation(np.tile(mount[:3], (len(tool), 1)), wrist_q)
    wrist = np.column_stack([tool[:, :3] - offset, wrist_q])
    reach = wrist[:, :2] - SHOULDER_IN_BASE[:2]
    half_yaw = np.arctan2(reach[:, 1], reach[:, 0]) / 2
    yaw = np.column_stack([np.zeros((len(tool), 2)), np.sin(half_yaw), np.cos(half_yaw)])
    shoulder = np.column_stack([np.tile(SHOULDER_IN_BASE, (len(tool), 1)), yaw])
    return shoulder, _between(shoulder, wrist)


def write_bag(ft: np.ndarray, pose: np.ndarray, path: Path) -> None:
    """`ft` and `pose` (robot_log's rows) as the ROS 2 bag folder `path`, replaced if there."""
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    vector, quaternion = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Quaternion"]

    def header(t_ns: int, frame: str) -> Any:
        stamp = types["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
        return types["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def transform(t_ns: int, parent: str, child: str, v: np.ndarray) -> Any:
        move = types["geometry_msgs/msg/Transform"](
            translation=vector(*v[:3]), rotation=quaternion(*v[3:])
        )
        return types["geometry_msgs/msg/TransformStamped"](
            header=header(t_ns, parent), child_frame_id=child, transform=move
        )

    def stamps(seconds: np.ndarray) -> list[int]:
        return (EPOCH_NS + np.round(seconds * 1e9).astype(np.int64)).tolist()

    wrench, tf, tf_static = "/ft_sensor/wrench", "/tf", "/tf_static"
    messages = []  # (topic, header stamp, message)
    for t_ns, row in zip(stamps(ft[:, 0]), ft[:, 1:].tolist(), strict=True):
        body = types["geometry_msgs/msg/Wrench"](force=vector(*row[:3]), torque=vector(*row[3:]))
        message = types["geometry_msgs/msg/WrenchStamped"](
            header=header(t_ns, "ft_sensor"), wrench=body
        )
        messages.append((wrench, t_ns, message))
    shoulder, wrist = tf_chain(pose)
    for t_ns, up, down in zip(stamps(pose[:, 0]), shoulder, wrist, strict=True):
        links = [transform(t_ns, "base_link", "shoulder_link", up),
                 transform(t_ns, "shoulder_link", "wrist_link", down)]  # fmt: skip
        messages.append((tf, t_ns, types["tf2_msgs/msg/TFMessage"](transforms=links)))
    fixed = [transform(EPOCH_NS, "wrist_link", "tool0", np.asarray(TOOL_IN_WRIST)),
             transform(EPOCH_NS, "tool0", "ft_sensor", np.asarray(SENSOR_IN_TOOL))]  # fmt: skip
    messages.append((tf_static, EPOCH_NS, types["tf2_msgs/msg/TFMessage"](transforms=fixed)))
    messages.sort(key=lambda m: m[1] + LATENCY_NS[m[0]])  # as received (stable: ties in order)

    kinds = {wrench: "geometry_msgs/msg/WrenchStamped", tf: "tf2_msgs/msg/TFMessage",
             tf_static: "tf2_msgs/msg/TFMessage"}  # fmt: skip
    writing = path.parent / f".{path.name}.writing"  # the bag made whole, then moved
    shutil.rmtree(writing, ignore_errors=True)
    writer = Writer(writing / path.name, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    with writer:
        connections = {
            topic: writer.add_connection(topic, kind, typestore=store)
            for topic, kind in kinds.items()
        }
        for topic, t_ns, message in messages:
            raw = store.serialize_cdr(message, kinds[topic])
            writer.write(connections[topic], t_ns + LATENCY_NS[topic], raw)
    shutil.rmtree(path, ignore_errors=True)
    (writing / path.name).rename(path)
    writing.rmdir()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trial", nargs="?", default="samples/gown.mcap", type=Path)
    parser.add_argument("-o", "--output", default="samples/robot", type=Path)
    args = parser.parse_args()
    ft, pose = robot_log(args.trial)
    args.output.mkdir(parents=True, exist_ok=True)
    np.savetxt(
        args.output / "ft.csv", ft, fmt=["%.4f"] + ["%.5f"] * 6, delimiter=",", comments="",
        header="time (s),Fx (N),Fy (N),Fz (N),Tx (N m),Ty (N m),Tz (N m)",
    )  # fmt: skip
    np.savetxt(
        args.output / "pose.csv", pose, fmt=["%.4f"] + ["%.6f"] * 7, delimiter=",",
        comments="", header="time (s),x (m),y (m),z (m),qx,qy,qz,qw",
    )  # fmt: skip
    write_bag(ft, pose, args.output / "bag")
    print(
        f"{args.output}: ft.csv ({len(ft)} rows at {SENSOR_HZ} Hz), pose.csv ({len(pose)}), "
        f"bag/ (/ft_sensor/wrench, /tf, /tf_static)"
    )


if __name__ == "__main__":
    main()
