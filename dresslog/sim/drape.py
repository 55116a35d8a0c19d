"""Hang a garment from its grip with no limb near: does it drape like cloth?

The first thing to look at in a cloth simulation. v8's cloth, damped in every direction
at 1.0 and held along its whole top seam, kept its sleeve a rigid 20 cm tube: over 10 s
hanging free its width only fell from 0.195 to 0.176 m. `hang` measures the width of the
opening the limb leaves through (cuff, leg opening) over time, and how fast the cloth
still moves at the end, so a test and docs/simulator.md can say whether it drapes and
comes to rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dresslog.limb import build_limb
from dresslog.sim.garments import garment_for
from dresslog.sim.scene import Scene
from dresslog.spec import SimParams, Task

#: Where the gripper holds the garment: a metre above the limb's origin, and the limb
#: moved 5 m away, so nothing but gravity acts on the cloth.
_GRIP = np.array([0.0, 0.0, 1.0])
_AWAY = (5.0, 5.0, 5.0)


def minor_width(ring: np.ndarray) -> float:
    """The narrow extent (m) of a ring of points across its own plane: a circle's
    diameter, near 0 for a ring collapsed flat."""
    centred = ring - ring.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False)
    across = centred @ axes[:2].T  # in the ring's best-fit plane
    _, _, within = np.linalg.svd(across, full_matrices=False)
    return float(np.ptp(across @ within[1]))


@dataclass(frozen=True)
class Hang:
    """Widths (m) of the openings at `times` (s): the one held by the gripper (armhole,
    waist) and the free one the limb leaves through (cuff, leg opening); and at the end
    the fastest node's speed (m/s) and acceleration (m/s^2) over the last physics steps:
    a slow swing from the grip has a small acceleration, jitter a large one."""

    times: np.ndarray
    held: np.ndarray
    free: np.ndarray
    end_speed: float
    end_accel: float

    def shrunk(self, t: float, *, free: bool = False) -> float:
        """The opening's width at `t` as a fraction of its width at the start."""
        widths = self.free if free else self.held
        return float(np.interp(t, self.times, widths) / widths[0])


def hang(task: Task, params: SimParams | None = None, seconds: float = 4.0) -> Hang:
    """Hang `task`'s garment from its grip for `seconds`, with no wind and no limb."""
    p = params or SimParams()
    garment = garment_for(task, p.simulator)
    scene = Scene.build(build_limb(task, _AWAY), garment, _GRIP, p)
    try:
        every = max(1, p.physics_hz // 20)  # 20 widths a second
        times, held, free, last = [], [], [], []
        steps = round(seconds * p.physics_hz)
        for k in range(steps + 1):
            now = scene.vertices()
            if k % every == 0:
                times.append(k / p.physics_hz)
                held.append(minor_width(now[garment.entry_rim]))
                free.append(minor_width(now[garment.exit_rim]))
            if k >= steps - 2:
                last.append(now)
            if k < steps:
                scene.move_ee(_GRIP)
                scene.step()
    finally:
        scene.close()
    a, b, c = last
    hz = p.physics_hz
    speed = float(np.linalg.norm(c - b, axis=1).max() * hz)
    accel = float(np.linalg.norm(c - 2 * b + a, axis=1).max() * hz * hz)
    return Hang(np.array(times), np.array(held), np.array(free), speed, accel)
