"""How much of a garment's load pybullet's deformable world reports (docs/experiments.md).

Three probes with dresslog's cloth parameters (`SimParams` defaults, 300 Hz physics):

1. a flat 30 cm cloth resting on a box: the summed vertical contact force that
   `getContactPoints` reports (what the force map is made of), against its weight;
2. each garment hanging from the gripper, the limb 5 m away: the vertical force on
   the gripper's constraint less the gripper's own weight (what the tare takes, and the
   share of the garment's forces the wrench can carry), against the garment's weight;
3. every node of the resting cloth lifted by its own weight with `applyExternalForce`
   (the way to add a contact model of one's own): how far the cloth still falls in 0.2 s.

    python scripts/reported_load.py
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from dresslog.limb import build_limb
from dresslog.sim._pybullet import pb
from dresslog.sim.garments import garment_for
from dresslog.sim.scene import EE_MASS, Scene, load_cloth
from dresslog.spec import SimParams, Task

G = 9.81


def _grid_obj(directory: Path, side: float = 0.3, n: int = 11) -> Path:
    """A flat square cloth of n x n nodes, two triangles per cell."""
    xs = np.linspace(-side / 2, side / 2, n)
    lines = [f"v {x:.6f} {y:.6f} 0" for y in xs for x in xs]
    for r in range(n - 1):
        for c in range(n - 1):
            a = r * n + c + 1
            lines += [f"f {a} {a + 1} {a + n}", f"f {a + 1} {a + n + 1} {a + n}"]
    path = directory / "cloth.obj"
    path.write_text("\n".join(lines) + "\n")
    return path


def _world(p: SimParams) -> int:
    c = pb.connect(pb.DIRECT)
    pb.resetSimulation(pb.RESET_USE_DEFORMABLE_WORLD, physicsClientId=c)
    pb.setTimeStep(1.0 / p.physics_hz, physicsClientId=c)
    pb.setGravity(0, 0, -G, physicsClientId=c)
    return c


def _cloth_on_box(p: SimParams) -> float:
    """Reported vertical contact force / weight, over the last of 3 s at rest on a box."""
    c = _world(p)
    try:
        box = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[1, 1, 0.1], physicsClientId=c)
        pb.createMultiBody(0, box, basePosition=[0, 0, -0.1], physicsClientId=c)
        with tempfile.TemporaryDirectory() as tmp:
            cloth = load_cloth(c, _grid_obj(Path(tmp)), np.array([0, 0, 0.02]), p, 40.0, 0.5)
        reported = []
        for k in range(3 * p.physics_hz):
            pb.stepSimulation(physicsClientId=c)
            if k >= 2 * p.physics_hz:
                rows = pb.getContactPoints(bodyA=cloth, physicsClientId=c)
                reported.append(
                    sum(r[9] * r[7][2] + r[10] * r[11][2] + r[12] * r[13][2] for r in rows)
                )
        return float(np.mean(reported)) / (p.garment_mass * G)
    finally:
        pb.disconnect(c)


def _lifted_drop(p: SimParams) -> float:
    """How far (m) a free cloth falls in 0.2 s with each node pushed up by its weight."""
    c = _world(p)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            cloth = load_cloth(c, _grid_obj(Path(tmp)), np.array([0, 0, 0.02]), p, 40.0, 0.5)

        def com_z() -> float:
            _, v = pb.getMeshData(cloth, flags=pb.MESH_DATA_SIMULATION_MESH, physicsClientId=c)
            return float(np.mean(np.asarray(v)[:, 2]))

        n = len(pb.getMeshData(cloth, flags=pb.MESH_DATA_SIMULATION_MESH, physicsClientId=c)[1])
        up = [0.0, 0.0, p.garment_mass / n * G]
        z0 = com_z()
        for _ in range(p.physics_hz // 5):
            for i in range(n):
                pb.applyExternalForce(cloth, i, up, [0, 0, 0], pb.WORLD_FRAME, physicsClientId=c)
            pb.stepSimulation(physicsClientId=c)
        return z0 - com_z()
    finally:
        pb.disconnect(c)


def _hanging(task: Task, p: SimParams) -> list[float]:
    """The garment's weight share that the gripper's constraint carries, hanging from it,
    averaged over each of the first 4 s."""
    limb = build_limb(task, (5.0, 0.0, 0.0))
    scene = Scene.build(limb, garment_for(task, 8), np.array([0.6, 0.0, 0.1]), p)
    try:
        fz = []
        for _ in range(4 * p.physics_hz):
            scene.step()
            fz.append(scene.constraint_wrench()[2])
        per_second = np.reshape(fz, (4, p.physics_hz)).mean(axis=1)
        return [float(f - EE_MASS * G) / (p.garment_mass * G) for f in per_second]
    finally:
        scene.close()


def main() -> None:
    p = SimParams(simulator=8, wrench_from="constraint")  # the v7 world it measured
    print(f"cloth resting on a box: contacts report {_cloth_on_box(p):.1%} of its weight")
    for task in Task:
        shares = ", ".join(f"{round(share, 2) + 0.0:.0%}" for share in _hanging(task, p))
        print(
            f"{task.value} hanging from the gripper: the constraint carries {shares} of its "
            "weight in the first four seconds"
        )
    drop = _lifted_drop(p)
    print(
        f"cloth in free fall, every node lifted by its weight (applyExternalForce): it "
        f"falls {drop * 100:.1f} cm in 0.2 s (free fall: {G / 2 * 0.04 * 100:.1f} cm)"
    )


if __name__ == "__main__":
    main()
