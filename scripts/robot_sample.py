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
  about z, placed 0.6 m from the limb), and no velocity: `convert` differentiates it.

The output is deterministic (seeded noise), so running the script
again rewrites the same files:

    python scripts/robot_sample.py [samples/gown.mcap] [-o samples/robot]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from dresslog.convert.resample import rotate_pose, rotate_vectors
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
    print(f"{args.output}: ft.csv ({len(ft)} rows at {SENSOR_HZ} Hz), pose.csv ({len(pose)})")


if __name__ == "__main__":
    main()
