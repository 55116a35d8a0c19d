"""How a robot's measured wrench and motion become the model's input, once on the 100 Hz grid.

`SignalOptions` holds what places a signal: the wrench's frame (the world's axes, or the
gripper's, turned by the pose), the sensor's mount on the gripper, the tare, the rotation
into the model's axes and the translation of the pose, and the gap to report. `convert`
(a whole log at once) and `live` (a ROS 2 stream, a step at a time) both take one and
both call `place` on the grid's rows, so a live session and a converted log of the same
signal give the model the same numbers.
"""

from __future__ import annotations

from functools import cached_property
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, model_validator

from dresslog.convert import resample as rs
from dresslog.convert.source import SensorMount
from dresslog.errors import ConversionError

Quaternion = tuple[float, float, float, float]
Vector = tuple[float, float, float]

#: Gaps in a stream longer than this (s) are bridged by interpolation and reported.
MAX_GAP_S = 0.1
#: Farthest a wrist sensor's origin sits from the gripper centre, m: it is on the gripper.
MAX_SENSOR_OFFSET = 2.0
#: Farthest --translate moves a pose, m: a robot's base is not kilometres from the limb,
#: and a pose stored as float32 keeps millimetres only this near.
MAX_TRANSLATE = 1000.0


class OptionError(ConversionError):
    """Options that contradict each other, refused before any log or topic is read; the
    commands show it as a usage error (exit 2)."""


def finite(value: object, count: int | None) -> bool:
    """`value` is `count` finite numbers (one number if `count` is None)."""
    try:
        numbers = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    shape = () if count is None else (count,)
    return numbers.shape == shape and bool(np.isfinite(numbers).all())


def _refuse(given: dict[str, Any]) -> None:
    """The library's one check of a signal's options, on the values as given (before
    pydantic coerces them), so that each mistake reads as the option it is."""
    frame = given.get("wrench_frame", "world")
    sensor_rotation, sensor_offset = given.get("sensor_rotation"), given.get("sensor_offset")
    for option, quat in (("--rotate", given.get("rotate")), ("--sensor-rotation", sensor_rotation)):
        if quat is not None and not (finite(quat, 4) and np.abs(quat).max() > 0):
            raise ConversionError(
                f"{option}: a rotation quaternion is 4 finite numbers, x y z w, not all 0"
            )
    mount = [
        n for n, v in (("rotation", sensor_rotation), ("offset", sensor_offset)) if v is not None
    ]
    if mount and frame != "pose":
        raise OptionError(
            f"--sensor-{mount[0]} places a sensor on the gripper: use it with --wrench-frame "
            "pose (a sensor fixed in the world is turned with --rotate)"
        )
    if sensor_offset is not None and not (
        finite(sensor_offset, 3) and np.abs(sensor_offset).max() <= MAX_SENSOR_OFFSET
    ):
        raise ConversionError(
            f"sensor offset must be 3 finite numbers, x y z (metres), each within "
            f"+-{MAX_SENSOR_OFFSET:g}: the sensor is on the gripper"
        )
    translate = given.get("translate")
    if translate is not None and not (
        finite(translate, 3) and np.abs(translate).max() <= MAX_TRANSLATE
    ):
        raise ConversionError(
            f"--translate: a translation is 3 finite numbers, x y z (metres), each within "
            f"+-{MAX_TRANSLATE:g}"
        )
    tare_s = given.get("tare_s", 0.0)
    if not (finite(tare_s, None) and tare_s >= 0):
        raise ConversionError(f"tare of {tare_s} s: give a duration of 0 s or more")
    max_gap_s = given.get("max_gap_s", MAX_GAP_S)
    if not (finite(max_gap_s, None) and max_gap_s > 0):
        raise ConversionError(f"max_gap_s {max_gap_s}: give a duration above 0 s")
    if frame not in ("world", "pose"):
        raise ConversionError(f"wrench frame {frame!r}: use world or pose")


class SignalOptions(BaseModel):
    """Where a wrench and a motion are measured, and how they are turned into the model's
    frame: `convert`'s and `live`'s options alike (the `--wrench-frame`, `--sensor-*`,
    `--rotate`, `--translate`, `--tare` options of both commands).

    `wrench_frame="pose"` says the sensor's axes turn with the gripper: each step's wrench
    is turned from the pose's orientation into world axes (after the tare, which belongs
    to the sensor's own axes), first by `sensor_rotation` (x y z w; the sensor's axes in the
    gripper's, as mounted) if given, its torque moved from the sensor's origin to the
    gripper centre by `sensor_offset` (m: tau + r x F). `rotate` then turns every vector
    (force, torque, velocities, pose) into the model's frame, and `translate` (m) moves every
    pose in it, so that the gripper's path lies where the viewer draws the limb (the
    signal holds no position: the estimate is the same). `tare_s` subtracts the mean wrench
    of the first seconds; gaps longer than `max_gap_s` are bridged and reported.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    wrench_frame: Literal["world", "pose"] = "world"
    sensor_rotation: Quaternion | None = None
    sensor_offset: Vector | None = None
    rotate: Quaternion | None = None
    translate: Vector | None = None
    tare_s: float = 0.0
    max_gap_s: float = MAX_GAP_S

    @model_validator(mode="before")
    @classmethod
    def _checked(cls, data: Any) -> Any:
        if isinstance(data, dict):
            _refuse(data)
        return data

    @classmethod
    def take(cls, options: dict[str, Any]) -> SignalOptions:
        """The signal's options among a command's flat keywords, taken out of `options`:
        the given `signal`, or one made of its fields there (not both)."""
        flat = {k: options.pop(k) for k in list(options) if k in cls.model_fields}
        signal = options.pop("signal", None)
        if signal is not None and flat:
            raise TypeError(f"give {', '.join(flat)} in signal, or leave signal out")
        return signal if signal is not None else cls(**flat)

    @cached_property
    def _matrices(self) -> dict[str, np.ndarray]:
        """The fixed rotations' matrices, made once: `live` places a row at a time."""
        out: dict[str, np.ndarray] = {}
        if self.sensor_rotation is not None:
            out["sensor"] = rs.rotation_matrices(self.sensor_rotation)
        if self.rotate is not None:
            out["rotate"] = rs.rotation_matrices(self.rotate)
            out["unit"], out["pose"] = rs.unit_rotation(self.rotate)
        return out

    def mounted(self, mount: SensorMount | None) -> SignalOptions:
        """These options with the tf tree's sensor mount where none is given (a wrench in
        the gripper's frame only), and whether it was taken."""
        if mount is None or self.wrench_frame != "pose":
            return self
        if self.sensor_rotation is not None or self.sensor_offset is not None:
            return self
        return self.model_copy(
            update={"sensor_rotation": mount.rotation, "sensor_offset": mount.offset}
        )

    def steps(self) -> dict[str, object]:
        """What `place` does, as a trial's metadata records it (its `processing`)."""
        done: dict[str, object] = {}
        if self.tare_s > 0:
            done["tare_s"] = self.tare_s
        if self.wrench_frame == "pose":
            via = ""
            if self.sensor_rotation is not None:
                via = f" (the sensor mounted at {[float(v) for v in self.sensor_rotation]})"
            if self.sensor_offset is not None:
                via += f" (torque moved by {[float(v) for v in self.sensor_offset]} m)"
            done["wrench_frame"] = f"from the gripper's axes{via} into world axes by the pose"
        if self.rotate is not None:
            done["rotation_xyzw"] = [float(v) for v in self.rotate]
        if self.translate is not None:
            done["translation_m"] = [float(v) for v in self.translate]
        return done

    def place(
        self,
        wrench: np.ndarray,
        twist: np.ndarray,
        pose: np.ndarray | None,
        bias: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Rows on the grid (T, 6), (T, 6), (T, 7) or None, in the model's frame: less the
        tare's `bias` (the wrench's mean over the tare, `tare_bias`), turned by the pose and
        the sensor mount, rotated and translated. Row by row, so a live stream placed a step
        at a time gets what a whole log does."""
        if bias is not None:
            wrench = wrench - bias
        if self.wrench_frame == "pose":
            assert pose is not None  # check_turnable, or live's own check
            if self.sensor_rotation is not None:  # the sensor's mount: its axes in the gripper's
                wrench = rs.rotate_by_matrix(wrench, self._matrices["sensor"])
            if self.sensor_offset is not None:  # torque about the gripper centre: tau + r x F
                offset = np.asarray(self.sensor_offset, dtype=np.float64)
                wrench = np.concatenate(
                    [wrench[:, :3], wrench[:, 3:] + np.cross(offset, wrench[:, :3])], 1
                )
            wrench = rs.rotate_by_orientation(wrench, pose[:, 3:7])
        if self.rotate is not None:
            matrices = self._matrices
            wrench = rs.rotate_by_matrix(wrench, matrices["rotate"])
            twist = rs.rotate_by_matrix(twist, matrices["rotate"])
            if pose is not None:
                pose = rs.rotate_pose_by(pose, matrices["unit"], matrices["pose"])
        if self.translate is not None and pose is not None:
            pose = rs.translate_pose(pose, self.translate)
        return wrench, twist, pose


def tare_bias(grid: np.ndarray, wrench: np.ndarray, seconds: float) -> np.ndarray:
    """The mean wrench (6,) over the first `seconds` of the grid: the sensor's reading with
    the garment hanging still, which `place` subtracts."""
    window = grid < grid[0] + round(seconds * 1e9)
    return np.asarray(wrench[window].mean(axis=0))


def tare_mistake_before(span_s: float, step_s: float, tare_s: float, what: str) -> str | None:
    """What is wrong with a tare of `tare_s` over `span_s` of `what` ("log", "window") of
    `step_s` steps, or None."""
    if span_s < tare_s:
        return (
            f"tare of {tare_s} s is longer than the {what} ({span_s:.2f} s); give a shorter "
            "--tare, the seconds the garment hangs still at its start"
        )
    if tare_s < step_s:  # its window would hold no sample to average
        return (
            f"tare of {tare_s:g} s is shorter than one {step_s:g} s step; give 0 for none or at "
            f"least {step_s:g} s"
        )
    return None
