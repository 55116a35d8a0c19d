"""The pybullet world of one trial: static limb, anchored garment, force-sensing end effector.

Each scene owns its own DIRECT physics client, so trials can run side by side
in one process or a pool. The end effector is a small dynamic body held on its
path by a fixed constraint; the garment's gripped vertices are anchored to it,
so the constraint's force is what a force/torque sensor at the gripper reads
(plus the gripper's own weight and inertia, which the caller removes).
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, field
from itertools import chain
from pathlib import Path

import numpy as np

from dresslog.limb import Limb
from dresslog.sim._pybullet import pb
from dresslog.sim.garments import Garment
from dresslog.spec import SimParams

#: Mass of the gripper body between the sensor and the garment, kg.
EE_MASS = 0.1
_FRUSTUM_SIDES = 16


def _quat_z_to(u: np.ndarray) -> list[float]:
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, u)
    s = float(np.linalg.norm(axis))
    if s < 1e-9:
        return [0.0, 0.0, 0.0, 1.0] if u[2] > 0 else [1.0, 0.0, 0.0, 0.0]
    ang = np.arctan2(s, float(z @ u))
    return [*(axis / s * np.sin(ang / 2)), float(np.cos(ang / 2))]


def load_cloth(
    client: int,
    obj: Path,
    position: np.ndarray,
    params: SimParams,
    stiffness: float,
    friction: float,
) -> int:
    """A mass-spring cloth from a Wavefront .obj with the spec's cloth parameters (its
    stretch `stiffness` and `friction` the spec's, or where it leaves them, the
    garment's own)."""
    return pb.loadSoftBody(
        str(obj),
        basePosition=list(map(float, position)),
        mass=params.garment_mass,
        useNeoHookean=0,
        useMassSpring=1,
        useBendingSprings=int(params.bending_stiffness > 0),
        springElasticStiffness=params.elastic_stiffness or stiffness,
        springDampingStiffness=params.damping_stiffness,
        springDampingAllDirections=1,
        springBendingStiffness=params.bending_stiffness,
        useSelfCollision=0,
        frictionCoeff=friction if params.friction is None else params.friction,
        useFaceContact=1,
        collisionMargin=params.collision_margin,
        physicsClientId=client,
    )


#: The columns of `Scene.contacts`, each contact read once for all that use it: 0-2
#: positionOnA (the garment's node), 3-5 positionOnB (the limb), 6-8 the normal on B
#: towards the garment, 9 the normal force, 10 and 14 the two frictions, 11-13 and
#: 15-17 their directions.
CONTACT_COLUMNS = 18


def touching(raw: Iterable[tuple]) -> np.ndarray:
    """getContactPoints' tuples (garment = body A) as rows of `CONTACT_COLUMNS`, each that
    carries force: pybullet also lists garment nodes merely within the collision margin,
    with zero force; those are not contacts."""
    rows = [(*c[5], *c[6], *c[7], c[9], c[10], *c[11], c[12], *c[13]) for c in raw if c[9] > 0]
    flat = np.fromiter(chain.from_iterable(rows), np.float64, CONTACT_COLUMNS * len(rows))
    return flat.reshape(-1, CONTACT_COLUMNS)


@dataclass
class Scene:
    """Handles into one pybullet world."""

    client: int
    cloth: int
    ee: int
    constraint: int
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))

    # -- construction -------------------------------------------------------
    @classmethod
    def build(cls, limb: Limb, garment: Garment, ee_start: np.ndarray, params: SimParams) -> Scene:
        client = pb.connect(pb.DIRECT)
        try:
            return cls._build(client, limb, garment, ee_start, params)
        except Exception:
            pb.disconnect(client)
            raise

    @classmethod
    def _build(
        cls, client: int, limb: Limb, garment: Garment, ee_start: np.ndarray, params: SimParams
    ) -> Scene:
        c = client
        pb.resetSimulation(pb.RESET_USE_DEFORMABLE_WORLD, physicsClientId=c)
        pb.setTimeStep(1.0 / params.physics_hz, physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        for s in limb.spheres.values():
            shape = pb.createCollisionShape(pb.GEOM_SPHERE, radius=s.radius, physicsClientId=c)
            pb.createMultiBody(0, shape, basePosition=s.center.tolist(), physicsClientId=c)
        ang = 2 * np.pi * np.arange(_FRUSTUM_SIDES) / _FRUSTUM_SIDES
        for f in limb.frustums:
            a, ra, b, rb = limb.frustum_ends(f)
            length = float(np.linalg.norm(b - a))
            circle = np.stack([np.cos(ang), np.sin(ang)], axis=1)
            lo = np.column_stack([ra * circle, np.full(len(ang), -length / 2)])
            hi = np.column_stack([rb * circle, np.full(len(ang), length / 2)])
            shape = pb.createCollisionShape(
                pb.GEOM_MESH, vertices=np.concatenate([lo, hi]).tolist(), physicsClientId=c
            )
            pb.createMultiBody(
                0,
                shape,
                basePosition=((a + b) / 2).tolist(),
                baseOrientation=_quat_z_to((b - a) / length),
                physicsClientId=c,
            )
        with tempfile.TemporaryDirectory(prefix="dresslog-") as tmp:
            obj = garment.write_obj(Path(tmp))
            cloth = load_cloth(
                c, obj, ee_start, params, garment.elastic_stiffness, garment.friction
            )
        box = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.01] * 3, physicsClientId=c)
        ee = pb.createMultiBody(EE_MASS, box, basePosition=ee_start.tolist(), physicsClientId=c)
        pb.setCollisionFilterGroupMask(ee, -1, 0, 0, physicsClientId=c)
        pb.changeDynamics(ee, -1, linearDamping=0, angularDamping=0, physicsClientId=c)
        con = pb.createConstraint(
            ee, -1, -1, -1, pb.JOINT_FIXED, [0, 0, 0], [0, 0, 0], ee_start.tolist(),
            physicsClientId=c,
        )  # fmt: skip
        scene = cls(c, cloth, ee, con)
        scene.move_ee(ee_start)  # the constraint's force limit, as every step sets it
        for i in garment.gripped:
            pb.createSoftBodyAnchor(cloth, int(i), ee, -1, physicsClientId=c)
        return scene

    # -- per step -------------------------------------------------------------
    def move_ee(self, position: np.ndarray) -> None:
        pb.changeConstraint(
            self.constraint, position.tolist(), maxForce=2000, physicsClientId=self.client
        )

    def step(self) -> None:
        pb.stepSimulation(physicsClientId=self.client)

    def set_gravity(self, g: np.ndarray) -> None:
        self.gravity = g
        pb.setGravity(*g.tolist(), physicsClientId=self.client)

    def constraint_wrench(self) -> np.ndarray:
        """Force (3) and torque (3) the constraint applies to the end effector."""
        return np.asarray(pb.getConstraintState(self.constraint, physicsClientId=self.client))

    def vertices(self) -> np.ndarray:
        _, v = pb.getMeshData(
            self.cloth, flags=pb.MESH_DATA_SIMULATION_MESH, physicsClientId=self.client
        )
        return np.fromiter(chain.from_iterable(v), np.float64, 3 * len(v)).reshape(-1, 3)

    def contacts(self) -> np.ndarray:
        """The garment-limb contacts that carry force, (C, `CONTACT_COLUMNS`)."""
        return touching(pb.getContactPoints(bodyA=self.cloth, physicsClientId=self.client))

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)
