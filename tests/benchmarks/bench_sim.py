"""Simulator speed: real-time factor per task and dresslog's own per-step work vs bare stepping.

Run as a script (not collected by pytest): `python tests/benchmarks/bench_sim.py [--seeds N]
[--simulator v10|v9|v8|v7]` (N trials per task, 3 by default; the simulator `record` uses by
default, whose wrench, the garment's momentum balance, queries the garment at every
physics step). The peer is the bare physics: the same scene stepped with nothing read.
Both figures come from one run per task: the simulator times its physics
stepping and its own work (pybullet queries, contacts, force map, sensors, sink)
separately; a second, bare run steps the same scene with no queries at all.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from dresslog.limb import build_limb
from dresslog.sim import WriterSink, random_spec, simulate
from dresslog.sim.garments import garment_for
from dresslog.sim.scene import Scene
from dresslog.sim.trajectory import constant_speed
from dresslog.spec import SIMULATOR_NAME, SIMULATORS, Task, TrialMetadata, simulator_fields


def bare_physics_seconds(spec) -> float:
    """CPU time (this thread) of stepping the same scene along the same path with nothing else."""
    p = spec.sim
    limb = build_limb(spec.task, spec.limb_offset, spec.limb_rotation)
    n = round(spec.duration * p.physics_hz)
    path = constant_speed(np.asarray(spec.control_points), spec.speed, np.arange(n) / p.physics_hz)
    scene = Scene.build(limb, garment_for(spec.task, p.simulator), path[0], p)
    try:
        for _ in range(round(p.settle_s * p.physics_hz)):
            scene.step()
        t0 = time.thread_time()
        for k in range(n):
            scene.move_ee(path[k])
            scene.step()
        return time.thread_time() - t0
    finally:
        scene.close()


def main(seeds: int = 3, simulator: str = SIMULATOR_NAME) -> None:
    from dresslog.io.writer import TrialWriter

    for task in Task:
        rtf, own, queries, phys, bare = [], [], [], [], []
        for seed in range(seeds):
            spec = random_spec(task, seed, sim=simulator_fields(simulator))
            with tempfile.TemporaryDirectory() as tmp:
                meta = TrialMetadata(task=task, spec=spec)
                with TrialWriter(Path(tmp) / "t.mcap", meta) as w:
                    sink = WriterSink(w)
                    r = simulate(spec, sink)
                    t0 = time.thread_time()
                    sink.flush()
                    flush = time.thread_time() - t0
            rtf.append(r.real_time_factor)
            t = r.timings
            own.append(t["queries"] + t["contacts"] + t["sensors"] + t["sink"] + flush)
            queries.append(t["queries"])
            phys.append(r.timings["physics"])
            bare.append(bare_physics_seconds(spec))
        print(
            f"{task.value:7s} rtf={np.mean(rtf):.2f} (min {np.min(rtf):.2f}) "
            f"own/physics={np.sum(own) / np.sum(phys):.1%} "
            f"(pybullet queries {np.sum(queries) / np.sum(phys):.1%}) "
            f"own/bare={np.sum(own) / np.sum(bare):.1%} "
            f"physics={np.sum(phys):.1f}s bare={np.sum(bare):.1f}s over {seeds} x 7 s trials, "
            f"simulator {simulator}"
        )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, choices=range(1, 101), default=3, metavar="N")
    parser.add_argument("--simulator", choices=SIMULATORS, default=SIMULATOR_NAME)
    args = parser.parse_args()
    main(args.seeds, args.simulator)
