"""The garment's load on the gripper, read by its constraint or from Newton's second law.

pybullet's deformable world holds anchored and touching cloth nodes partly by
projecting their velocities, a support it applies to no body and reports nowhere, so
the gripper's constraint reads a changing share of the garment's load
(docs/experiments.md, "What pybullet reports"). The garment's momentum balance has no
such gap: the gripper takes what the garment's change of momentum leaves of gravity
and the limb's reported contact forces, so it feels the forces the force map holds,
plus the garment's own inertia.

Each reading is the garment's wrench on the gripper over one physics step, untared,
about the gripper's centre, in the world frame.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from dresslog.sim.scene import Scene


class WrenchReading(Protocol):
    def __call__(
        self, scene: Scene, verts: np.ndarray, contacts: np.ndarray, ee: np.ndarray
    ) -> np.ndarray: ...


def constraint_reading(
    scene: Scene, verts: np.ndarray, contacts: np.ndarray, ee: np.ndarray
) -> np.ndarray:
    """What the gripper's constraint reports: the garment's load and the gripper's own."""
    return -scene.constraint_wrench()


class MomentumBalance:
    """The garment's wrench on the gripper as the rest of its momentum balance.

    Node i obeys m a_i = m g + (springs) + (limb) + (gripper); the springs act in equal
    and opposite pairs, so over the garment they cancel in force (and in moment but for
    their damping, which acts across the links as well as along them), and the
    gripper's share is sum_i m (g - a_i) + sum_c f_c, each about the gripper. Every
    physics step must be shown (the accelerations are central differences of the
    positions), starting from the garment at rest as it is loaded.
    """

    def __init__(self, rest: np.ndarray, mass: float, physics_hz: int) -> None:
        self.node_mass = mass / len(rest)  # pybullet shares a cloth's mass evenly
        self.hz = physics_hz
        self._before, self._last = rest, rest

    def __call__(
        self, scene: Scene, verts: np.ndarray, contacts: np.ndarray, ee: np.ndarray
    ) -> np.ndarray:
        return self.steps(scene.gravity, verts[None], [contacts], ee[None])[0]

    def steps(
        self, gravity: np.ndarray, verts: np.ndarray, contacts: list[np.ndarray], ee: np.ndarray
    ) -> np.ndarray:
        """The readings (S, 6) of S physics steps in a row: the garment then (S, V, 3),
        each step's contacts and gripper position (S, 3). Each reading is bit for bit the
        one step's alone: numpy sums (S, V, 3) over V as it sums each (V, 3)."""
        s = len(verts)
        # the step's velocity change comes from the forces where the nodes were
        seen = np.concatenate([self._before[None], self._last[None], verts])
        self._before, self._last = seen[-2], seen[-1]
        at = seen[1:-1]
        accel = (seen[2:] - 2.0 * at + seen[:-2]) * (self.hz * self.hz)
        pull = self.node_mass * (gravity - accel)
        wrench = np.empty((s, 6))
        wrench[:, :3] = pull.sum(axis=1)
        arm = (at - ee[:, None]).reshape(-1, 3)
        wrench[:, 3:] = cross_rows(arm, pull.reshape(-1, 3)).reshape(s, -1, 3).sum(axis=1)
        counts = np.array([len(c) for c in contacts])
        if counts.any():  # those that carry force, as the force map counts them
            c = np.concatenate(contacts)  # CONTACT_COLUMNS: limb point, normal, forces
            f = c[:, 6:9] * c[:, 9:10] + c[:, 10:11] * c[:, 11:14] + c[:, 14:15] * c[:, 15:18]
            moment = cross_rows(c[:, 3:6] - np.repeat(ee, counts, axis=0), f)
            # each step's rows summed in order from its first, as sum(axis=0) adds them
            # (np.add.reduceat does not): laid out (S, most, 6) after -0.0, which adds
            # nothing to any sum
            first = np.cumsum(counts) - counts
            step = np.repeat(np.arange(s), counts)
            laid = np.full((s, counts.max(), 6), -0.0)
            laid[step, np.arange(len(c)) - first[step], :3] = f
            laid[step, np.arange(len(c)) - first[step], 3:] = moment
            touched = counts > 0
            wrench[touched] += laid.sum(axis=1)[touched]
        return wrench


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`np.cross(a, b)` of two (N, 3) arrays, bit for bit (the same products and
    differences, each rounded once), without its axis handling, which costs more
    than the arithmetic on a garment's few hundred nodes at every physics step."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    out = np.empty((len(a), 3))
    np.subtract(a1 * b2, a2 * b1, out=out[:, 0])
    np.subtract(a2 * b0, a0 * b2, out=out[:, 1])
    np.subtract(a0 * b1, a1 * b0, out=out[:, 2])
    return out
