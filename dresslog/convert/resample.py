"""Bring irregular, high- or low-rate sensor streams onto the model's 100 Hz grid (pure numpy).

A force/torque sensor at 500-1000 Hz carries content above the grid's 50 Hz
Nyquist limit (motor and contact vibration), so picking every tenth sample
would alias it into the band the model sees; averaging all samples within
each 10 ms bin (a box filter centred on the grid point, so no delay) removes
most of it. Any stream above 150 Hz (`AVERAGE_ABOVE_HZ`), velocity included, is
averaged so; slower ones, where a bin would hold one sample or none, are
interpolated, and the pose always is. Velocity from pose is differentiated on the
source samples (second-order central differences, so it describes each sample's own
time, where a simulated trial's backward difference describes the half step before)
before it is resampled, because the derivative of an interpolated pose would be
piecewise constant.

Times are integer nanoseconds; arithmetic is done relative to the grid start
in float64, exact to the nanosecond for spans up to about 100 days.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from dresslog.trial import STEP_HZ as RATE_HZ
from dresslog.trial import median_rate

PERIOD_NS = 1_000_000_000 // RATE_HZ
#: Above this source rate (Hz) a stream is bin-averaged rather than interpolated.
AVERAGE_ABOVE_HZ = 1.5 * RATE_HZ


def grid(start_ns: int, stop_ns: int) -> np.ndarray:
    """Grid times from `start_ns` up to and including `stop_ns`, every `PERIOD_NS`."""
    if stop_ns < start_ns:
        return np.zeros(0, dtype=np.int64)
    return start_ns + PERIOD_NS * np.arange((stop_ns - start_ns) // PERIOD_NS + 1, dtype=np.int64)


def grid_start(wrench_t_ns: np.ndarray, other_first_ns: list[int]) -> int:
    """The first grid time over a wrench with these times and streams that begin at
    `other_first_ns`: `convert`'s over a whole log, `live`'s over a stream's first samples.

    An averaged wrench needs half a bin spare before it, and its bin edges fall midway
    between its samples: on a sample, a few microseconds of clock jitter would move it
    between bins and let vibration above 50 Hz leak into the means.
    """
    averaged = averages(wrench_t_ns)
    half = PERIOD_NS // 2 if averaged else 0
    start = max([int(wrench_t_ns[0]) + half, *(int(t) for t in other_first_ns)])
    if averaged:
        phase = int(wrench_t_ns[0]) + half + int(np.median(np.diff(wrench_t_ns))) // 2
        start += (phase - start) % PERIOD_NS
    return start


def interpolate(t_ns: np.ndarray, values: np.ndarray, grid_ns: np.ndarray) -> np.ndarray:
    """Linear interpolation of each column of `values` (T, D) at `grid_ns`."""
    origin = grid_ns[0] if len(grid_ns) else 0
    x = (t_ns - origin).astype(np.float64)
    g = (grid_ns - origin).astype(np.float64)
    values = np.asarray(values, dtype=np.float64).reshape(len(t_ns), -1)
    return np.stack([np.interp(g, x, values[:, d]) for d in range(values.shape[1])], axis=1)


def bin_average(t_ns: np.ndarray, values: np.ndarray, grid_ns: np.ndarray) -> np.ndarray:
    """Box-filter a fast stream: the mean of each 10 ms bin around a grid time, placed on the grid.

    The mean of the samples in [g - period/2, g + period/2) belongs to their
    mean time, which sits up to half a source sample off g; interpolating
    the bin means from their mean times onto the grid removes that skew.
    Empty bins (a dropout, a sensor slower than the grid) are skipped, so
    they are bridged by interpolation and the result never holds NaN.
    """
    values = np.asarray(values, dtype=np.float64).reshape(len(t_ns), -1)
    half = PERIOD_NS // 2
    # one bin beyond each end, so the first and last grid times lie between bin mean times
    centres = np.concatenate([[grid_ns[0] - PERIOD_NS], grid_ns, [grid_ns[-1] + PERIOD_NS]])
    edges = np.append(centres - half, centres[-1] + PERIOD_NS - half)
    index = np.searchsorted(t_ns, edges, side="left")
    counts = np.diff(index)
    full = counts > 0
    if not full.any():
        return interpolate(t_ns, values, grid_ns)
    origin = grid_ns[0]
    rel_ns = (t_ns - origin).astype(np.float64)
    lo, hi, n = index[:-1][full], index[1:][full], counts[full]
    sums = np.concatenate([np.zeros((1, values.shape[1])), np.cumsum(values, axis=0)])
    time_sums = np.concatenate([[0.0], np.cumsum(rel_ns)])
    means = (sums[hi] - sums[lo]) / n[:, None]
    mean_t = (time_sums[hi] - time_sums[lo]) / n
    g = (grid_ns - origin).astype(np.float64)
    return np.stack([np.interp(g, mean_t, means[:, d]) for d in range(means.shape[1])], axis=1)


def averages(t_ns: np.ndarray) -> bool:
    """Whether `resample` bin-averages a stream with these times (else it interpolates)."""
    return median_rate(t_ns) > AVERAGE_ABOVE_HZ


def resample(t_ns: np.ndarray, values: np.ndarray, grid_ns: np.ndarray) -> np.ndarray:
    """Bin-average a stream faster than the grid, interpolate anything slower."""
    if averages(t_ns):
        return bin_average(t_ns, values, grid_ns)
    return interpolate(t_ns, values, grid_ns)


def continuous_quaternions(quat: np.ndarray) -> np.ndarray:
    """Flip signs so consecutive quaternions (x y z w) lie in one hemisphere.

    q and -q are the same rotation; a sign flip between samples would make
    interpolation and differentiation swing through the long way round.
    """
    quat = np.asarray(quat, dtype=np.float64).copy()
    if len(quat) < 2:
        return quat
    flips = np.einsum("ij,ij->i", quat[1:], quat[:-1]) < 0
    sign = np.concatenate([[1.0], np.where(np.cumsum(flips) % 2, -1.0, 1.0)])
    return quat * sign[:, None]


def normalize(quat: np.ndarray) -> np.ndarray:
    """Unit quaternions; an all-zero row (an unset orientation) becomes identity."""
    norm = np.linalg.norm(quat, axis=-1, keepdims=True)
    out = np.divide(quat, norm, out=np.zeros_like(quat), where=norm > 0)
    out[norm[..., 0] == 0, 3] = 1.0
    return out


def interpolate_pose(t_ns: np.ndarray, pose: np.ndarray, grid_ns: np.ndarray) -> np.ndarray:
    """Position (linear) and orientation (normalised linear, i.e. nlerp) at `grid_ns`."""
    position = interpolate(t_ns, pose[:, :3], grid_ns)
    quat = interpolate(t_ns, continuous_quaternions(normalize(pose[:, 3:7])), grid_ns)
    return np.concatenate([position, normalize(quat)], axis=1)


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions (x y z w), row by row."""
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def conjugate(q: np.ndarray) -> np.ndarray:
    """The inverse rotation of unit quaternions (x y z w)."""
    return q * np.array([-1.0, -1.0, -1.0, 1.0])


def twist_from_pose(t_ns: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Linear (m/s) and angular (rad/s, world frame) velocity (T, 6) on the pose's own times.

    Second-order differences on the (possibly irregular) source times (first-order for
    a pose of two samples); the angular velocity is the vector part of 2 dq/dt q^-1.
    """
    if len(t_ns) < 2:
        return np.zeros((len(t_ns), 6))
    order: Literal[1, 2] = 2 if len(t_ns) > 2 else 1
    seconds = (t_ns - t_ns[0]).astype(np.float64) * 1e-9
    linear = np.gradient(pose[:, :3], seconds, axis=0, edge_order=order)
    quat = continuous_quaternions(normalize(pose[:, 3:7]))
    dquat = np.gradient(quat, seconds, axis=0, edge_order=order)
    angular = 2.0 * multiply(dquat, conjugate(quat))[:, :3]
    return np.concatenate([linear, angular], axis=1)


def tare(t_ns: np.ndarray, values: np.ndarray, seconds: float) -> np.ndarray:
    """Subtract the mean of the first `seconds` (the sensor's offset with nothing attached)."""
    window = t_ns < t_ns[0] + round(seconds * 1e9)
    return values - values[window].mean(axis=0)


def _scaled(quats: ArrayLike) -> np.ndarray:
    """Quaternions over their largest component: the same rotations, whose norm cannot
    overflow (a component past 1e154 squares to inf, and q / inf is no turn at all)."""
    q = np.asarray(quats, dtype=np.float64)
    largest = np.abs(q).max(axis=-1, keepdims=True)
    return np.divide(q, largest, out=np.full_like(q, np.nan), where=largest > 0)


def rotation_matrices(quats: ArrayLike) -> np.ndarray:
    """The 3x3 matrices (..., 3, 3) of quaternions (..., 4) (x y z w), normalised first: one
    matrix (3, 3) of one quaternion (4,)."""
    q = _scaled(quats)
    x, y, z, w = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


def rotate_by_orientation(values: np.ndarray, quats: np.ndarray) -> np.ndarray:
    """Rotate each row's 3-vector blocks (T, 3k) by that row's orientation (T, 4): a
    wrench measured in the gripper's own axes, expressed in the world's."""
    blocks = values.reshape(len(values), -1, 3)
    return np.einsum("tij,tkj->tki", rotation_matrices(quats), blocks).reshape(values.shape)


def rotate_vectors(values: np.ndarray, quat: tuple[float, float, float, float]) -> np.ndarray:
    """Rotate every 3-vector block of (T, 3k) rows (force and torque, linear and angular)."""
    return rotate_by_matrix(values, rotation_matrices(quat))


def rotate_by_matrix(values: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """`rotate_vectors` by the rotation's matrix (3, 3), for a caller that turns a row at a
    time by one rotation (`live`) and makes its matrix once."""
    blocks = values.reshape(len(values), -1, 3)
    return (blocks @ matrix.T).reshape(values.shape)


def unit_rotation(quat: tuple[float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    """A rotation's unit quaternion (4,) and its matrix (3, 3), as `rotate_pose` uses them."""
    q = _scaled(quat)
    q /= np.linalg.norm(q)
    return q, rotation_matrices(q)


def rotate_pose(pose: np.ndarray, quat: tuple[float, float, float, float]) -> np.ndarray:
    """Express poses (T, 7) in the rotated frame: position rotated, orientation pre-multiplied."""
    return rotate_pose_by(pose, *unit_rotation(quat))


def rotate_pose_by(pose: np.ndarray, unit: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """`rotate_pose` by a rotation's unit quaternion and matrix (`unit_rotation`'s)."""
    position = pose[:, :3] @ matrix.T
    orientation = multiply(np.broadcast_to(unit, (len(pose), 4)), pose[:, 3:7])
    return np.concatenate([position, orientation], axis=1)


def translate_pose(pose: np.ndarray, offset: tuple[float, float, float]) -> np.ndarray:
    """Poses (T, 7) moved by `offset` (m): positions shifted, orientations as they were."""
    moved = np.array(pose, dtype=np.float64)
    moved[:, :3] += np.asarray(offset, dtype=np.float64)
    return moved


def gaps(t_ns: np.ndarray, limit_ns: int) -> list[tuple[int, int]]:
    """(start time, length) of each interval between samples longer than `limit_ns`."""
    steps = np.diff(t_ns)
    where = np.flatnonzero(steps > limit_ns)
    return [(int(t_ns[i]), int(steps[i])) for i in where]


def first_disorder(t_ns: np.ndarray) -> int | None:
    """Index of the first sample not later than its predecessor, or None."""
    bad = np.flatnonzero(np.diff(t_ns) <= 0)
    return int(bad[0]) + 1 if len(bad) else None
