"""End-effector paths: a nominal polyline per task, randomised control points, a cubic
Hermite (Catmull-Rom) spline through them, sampled at constant speed.

The nominal path runs from a fixed start beyond the hand or foot along the limb
(world -x) to a fixed end; the end effector holds still at the end if the trial
lasts longer than the path.
"""

from __future__ import annotations

import numpy as np

from dresslog.spec import Task

#: Nominal waypoints (world frame, m) of the end effector (the gripper, at the
#: garment's leading opening, top). Gown: along the forearm 0.1 m above its axis
#: until the armhole nears the upper arm. Shorts: over the foot (dipping towards
#: the leg after it, as in the paper) and along the shin to the thigh.
NOMINAL = {
    Task.GOWN: np.array([[0.62, 0.0, 0.10], [0.08, 0.0, 0.10]]),
    Task.SHORTS: np.array(
        [[1.12, 0.0, 0.19], [0.95, 0.0, 0.19], [0.78, 0.0, 0.15], [0.22, 0.0, 0.15]]
    ),
}
#: Control-point counts and deviations from the nominal path (paper, Sec. IV-A).
CONTROL_POINTS = {Task.GOWN: (7, 10), Task.SHORTS: (9, 11)}
DEVIATION = np.array([0.03, 0.02, 0.05])


def _resample(poly: np.ndarray, n: int) -> np.ndarray:
    """n points evenly spaced by arc length along a polyline."""
    seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    t = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(t, s, poly[:, k]) for k in range(3)], axis=1)


def random_control_points(task: Task, rng: np.random.Generator) -> np.ndarray:
    """7-10 (gown) or 9-11 (shorts) points along the nominal path; interior ones perturbed."""
    lo, hi = CONTROL_POINTS[task]
    n = int(rng.integers(lo, hi + 1))
    pts = _resample(NOMINAL[task], n)
    pts[1:-1] += rng.uniform(-1.0, 1.0, size=(n - 2, 3)) * DEVIATION
    return pts


def hermite(points: np.ndarray, samples_per_segment: int = 64) -> np.ndarray:
    """Dense samples of the cubic Hermite spline through `points` (Catmull-Rom tangents)."""
    p = np.asarray(points, dtype=float)
    if len(p) < 2:
        raise ValueError("a path needs at least two control points")
    tangents = np.empty_like(p)
    tangents[1:-1] = 0.5 * (p[2:] - p[:-2])
    tangents[0] = p[1] - p[0]
    tangents[-1] = p[-1] - p[-2]
    u = np.linspace(0.0, 1.0, samples_per_segment, endpoint=False)[:, None]
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    out = [
        h00 * p[i] + h10 * tangents[i] + h01 * p[i + 1] + h11 * tangents[i + 1]
        for i in range(len(p) - 1)
    ]
    return np.concatenate([*out, p[-1:]])


def constant_speed(points: np.ndarray, speed: float, times: np.ndarray) -> np.ndarray:
    """Positions (T, 3) at `times` (s) moving at `speed` along the spline, then holding."""
    dense = hermite(points)
    seg = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    arc = np.clip(np.asarray(times) * speed, 0.0, s[-1])
    return np.stack([np.interp(arc, s, dense[:, k]) for k in range(3)], axis=1)


def path_length(points: np.ndarray) -> float:
    dense = hermite(points)
    return float(np.linalg.norm(np.diff(dense, axis=0), axis=1).sum())
