"""Can pybullet's older soft-body world host a simulator whose forces are the loads?

docs/experiments.md ("For the next simulator version") named it the candidate: there a
body put back on its path every step and read by its change of velocity carries a
hanging garment's whole weight, and `applyExternalForce` moves cloth nodes, so the limb
can be a penalty contact of dresslog's own whose node forces are the map. This probe
builds that world for the gown, on the paths of `random_spec` seeds, beside the
deformable world that records today (v7):

- the limb is no pybullet body: each node within the collision margin of the limb
  gets a normal spring-damper force on the limb's signed distance and regularised
  Coulomb friction, so the limb's load is known node by node;
- each gripped node hangs from a small holder body reset onto the gripper's path every
  physics step; the holders' changes of momentum are the garment's pull;
- the cloth's own damping, which this world ignores, is edge-relative damping of ours.

It prints, per spec and world, the outcome, the gripper's and the limb's peak force and
how deep any node went into the limb; then how far the hanging gown stretches at two
spring stiffnesses 100 times apart (this world does not read them).

    python scripts/softbody_world.py [--seeds 2000-2007] [--stiffness 1000]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from dresslog.limb import Limb, build_limb, limb_sdf, surface_points
from dresslog.sim._pybullet import pb
from dresslog.sim.garments import Garment, garment_for
from dresslog.sim.outcome import decide_outcome_v8 as decide_outcome
from dresslog.sim.simulate import SimStart, SimStep, _gripper_path, simulate
from dresslog.sim.specs import random_spec
from dresslog.spec import SimParams, Task, TrialSpec

G = np.array([0.0, 0.0, -9.81])
HZ = 600  # physics steps per second: the explicit penalty needs more than v7's 300
HOLDER_MASS = 0.01  # kg
EDGE_DAMPING = 0.5  # N s/m along each cloth edge


class SoftBodyWorld:
    """The gown in the soft-body world: holders on the gripper, a penalty limb of ours."""

    def __init__(
        self, limb: Limb, garment: Garment, start: np.ndarray, p: SimParams, stiffness: float
    ) -> None:
        self.c = c = pb.connect(pb.DIRECT)  # no RESET_USE_DEFORMABLE_WORLD: the older world
        pb.setTimeStep(1.0 / HZ, physicsClientId=c)
        pb.setGravity(*G, physicsClientId=c)
        with tempfile.TemporaryDirectory() as tmp:
            self.cloth = pb.loadSoftBody(
                str(garment.write_obj(Path(tmp))),
                basePosition=start.tolist(),
                mass=p.garment_mass,
                useMassSpring=1,
                useBendingSprings=1,
                springElasticStiffness=p.elastic_stiffness,
                springDampingStiffness=p.damping_stiffness,
                springBendingStiffness=p.bending_stiffness,
                frictionCoeff=p.friction,
                collisionMargin=p.collision_margin,
                physicsClientId=c,
            )
        self.limb, self.p, self.k = limb, p, stiffness
        tri = np.asarray(garment.triangles)
        edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        self.edges = np.unique(np.sort(edges, axis=1), axis=0)
        self.offsets = garment.vertices[garment.gripped]
        ball = pb.createCollisionShape(pb.GEOM_SPHERE, radius=0.002, physicsClientId=c)
        self.holders = []
        for node, offset in zip(garment.gripped, self.offsets, strict=True):
            h = pb.createMultiBody(
                HOLDER_MASS, ball, basePosition=(start + offset).tolist(),
                useMaximalCoordinates=True, physicsClientId=c,
            )  # fmt: skip
            pb.setCollisionFilterGroupMask(h, -1, 0, 0, physicsClientId=c)
            pb.changeDynamics(h, -1, linearDamping=0, angularDamping=0, physicsClientId=c)
            pb.createSoftBodyAnchor(self.cloth, int(node), h, -1, physicsClientId=c)
            self.holders.append(h)
        self.x = self.vertices()
        self.v = np.zeros_like(self.x)

    def vertices(self) -> np.ndarray:
        _, v = pb.getMeshData(
            self.cloth, flags=pb.MESH_DATA_SIMULATION_MESH, physicsClientId=self.c
        )
        return np.array(v, dtype=np.float64)

    def _contact(self) -> np.ndarray:
        """Each node's force from the limb now (V, 3): the load the limb carries, negated."""
        x, v, p = self.x, self.v, self.p
        f = np.zeros_like(x)
        d = limb_sdf(self.limb, x)
        near = np.flatnonzero(d < p.collision_margin)
        if len(near):
            _, n = surface_points(self.limb, x[near], d[near])
            vn = (v[near] * n).sum(axis=1)
            fn = np.maximum(0.0, self.k * (p.collision_margin - d[near]) - 0.5 * vn)
            vt = v[near] - vn[:, None] * n
            speed = np.linalg.norm(vt, axis=1)
            ft = np.minimum(p.friction * fn, 2.0 * speed) / np.maximum(speed, 1e-12)
            f[near] = fn[:, None] * n - ft[:, None] * vt
        return f

    def step(self, ee: np.ndarray, ee_velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One physics step: the garment's pull on the gripper (3,) and the limb's load (V, 3)."""
        c = self.c
        contact = self._contact()
        force = contact.copy()
        a, b = self.edges.T
        e = self.x[b] - self.x[a]
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        damping = EDGE_DAMPING * ((self.v[b] - self.v[a]) * e).sum(axis=1)[:, None] * e
        np.add.at(force, a, damping)
        np.add.at(force, b, -damping)
        for i, f in enumerate(force.tolist()):
            pb.applyExternalForce(self.cloth, i, f, [0, 0, 0], pb.WORLD_FRAME, physicsClientId=c)
        for h, offset in zip(self.holders, self.offsets, strict=True):
            pb.resetBasePositionAndOrientation(
                h, (ee + offset).tolist(), [0, 0, 0, 1], physicsClientId=c
            )
            pb.resetBaseVelocity(h, ee_velocity.tolist(), [0, 0, 0], physicsClientId=c)
        pb.stepSimulation(physicsClientId=c)
        velocities = [pb.getBaseVelocity(h, physicsClientId=c)[0] for h in self.holders]
        pull = HOLDER_MASS * ((np.array(velocities) - ee_velocity) * HZ - G).sum(axis=0)
        x = self.vertices()
        self.v, self.x = (x - self.x) * HZ, x
        return pull, -contact

    def close(self) -> None:
        pb.disconnect(self.c)


def soft_body_trial(spec: TrialSpec, stiffness: float) -> dict[str, object]:
    """The spec in the soft-body world: outcome and peak forces, as `deformable_trial`."""
    p = spec.sim.model_copy(update={"physics_hz": HZ})
    spec = spec.model_copy(update={"sim": p})
    limb = build_limb(spec.task, spec.limb_offset, spec.limb_rotation)
    garment = garment_for(spec.task, 8)
    sub = HZ // p.record_hz
    path, _ = _gripper_path(spec, np.asarray(spec.control_points), limb, garment, sub)
    velocity = np.zeros_like(path)
    velocity[1:] = np.diff(path, axis=0) * HZ
    world = SoftBodyWorld(limb, garment, path[0], p, stiffness)
    try:
        settle = round(p.settle_s * HZ)
        hanging = [world.step(path[0], np.zeros(3))[0] for _ in range(settle)]
        tare = np.mean(hanging[-HZ // 10 :], axis=0)  # the last 0.1 s, as v7's tare
        pulls, loads, depth = [], [], 0.0
        for i in range(0, len(path), sub):  # each recorded step: the mean of its substeps
            steps = [world.step(path[j], velocity[j]) for j in range(i, i + sub)]
            pulls.append(np.mean([s[0] for s in steps], axis=0) - tare)
            loads.append(np.mean([np.linalg.norm(s[1], axis=1).sum() for s in steps]))
            depth = min(depth, float(limb_sdf(limb, world.x).min()))
        final = float(np.linalg.norm(pulls[-1]))
        outcome = decide_outcome(spec.task, limb, garment, world.x, final)
    finally:
        world.close()
    return _summary(outcome.value, pulls, loads, depth)


class _Peaks:
    """A `simulate()` sink keeping each step's wrench, map total and deepest garment node."""

    def __init__(self, limb: Limb) -> None:
        self.limb, self.depth = limb, 0.0
        self.pulls: list[np.ndarray] = []
        self.loads: list[float] = []

    def start(self, info: SimStart) -> None:
        pass

    def step(self, step: SimStep) -> None:
        self.pulls.append(step.wrench[:3])
        self.loads.append(float(step.force_map.sum()))
        if step.garment is not None:
            self.depth = min(
                self.depth, float(limb_sdf(self.limb, step.garment.astype(float)).min())
            )


def deformable_trial(spec: TrialSpec) -> dict[str, object]:
    """The spec as dresslog records it today (v7, the deformable world)."""
    sink = _Peaks(build_limb(spec.task, spec.limb_offset, spec.limb_rotation))
    result = simulate(spec, sink)
    return _summary(result.outcome.value, sink.pulls, sink.loads, sink.depth)


def _summary(outcome: str, pulls: list, loads: list, depth: float) -> dict[str, object]:
    return {
        "outcome": outcome,
        "gripper": float(np.linalg.norm(pulls, axis=1).max()),
        "limb": float(max(loads)),
        "depth_cm": (0.0 - depth) * 100,  # 0.0, not -0.0, when no node went in
    }


def stretch(stiffness: float) -> float:
    """The hanging gown's height (m) after 2 s in the soft-body world at this stiffness."""
    garment = garment_for(Task.GOWN, 8)
    p = SimParams(simulator=8, wrench_from="constraint", elastic_stiffness=stiffness)
    world = SoftBodyWorld(build_limb(Task.GOWN, (5.0, 0.0, 0.0)), garment, np.zeros(3), p, 0.0)
    try:
        for _ in range(2 * HZ):
            world.step(np.zeros(3), np.zeros(3))
        return float(np.ptp(world.x[:, 2]))
    finally:
        world.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", default="2000-2007", help="random_spec seeds, first-last")
    parser.add_argument("--stiffness", type=float, default=1000.0, help="penalty, N/m per node")
    args = parser.parse_args()
    first, last = map(int, args.seeds.split("-"))
    print("seed  world       outcome  gripper N  limb N  deepest node in limb cm")
    for seed in range(first, last + 1):
        spec = random_spec(Task.GOWN, seed, sim={"simulator": 8, "wrench_from": "constraint"})
        for name, row in (
            ("deformable", deformable_trial(spec)),
            ("soft-body", soft_body_trial(spec, args.stiffness)),
        ):
            print(
                f"{seed}  {name:10s}  {row['outcome']:7s}  {row['gripper']:9.2f}  "
                f"{row['limb']:6.2f}  {row['depth_cm']:.1f}"
            )
    soft, stiff = stretch(4.0), stretch(400.0)
    print(f"hanging gown's height: {soft:.4f} m at stiffness 4, {stiff:.4f} m at 400")


if __name__ == "__main__":
    main()
