"""Random trial specs drawn from the paper's ranges: what a seed stands for, apart from the physics.

numpy only: `generate` and `sweep` draw their trials' specs in a process that never
simulates.
"""

from __future__ import annotations

import numpy as np
from pydantic import ValidationError

from dresslog.errors import SimulationError, first_problem
from dresslog.sim.trajectory import random_control_points
from dresslog.spec import (
    OFFSET_RANGES,
    SIMULATOR,
    SPEED_RANGE,
    SimParams,
    Task,
    TrialSpec,
    task_of,
)


def _simulator(sim: object) -> int:
    """The simulator version `sim` overrides ask for (SimParams or its fields), else the
    current one: offsets and paths are drawn as that version draws them."""
    if isinstance(sim, SimParams):
        return sim.simulator
    if isinstance(sim, dict) and sim.get("simulator") in OFFSET_RANGES:
        return int(sim["simulator"])
    return SIMULATOR


def random_spec(task: Task | str, seed: int, **overrides: object) -> TrialSpec:
    """A spec with offset, speed and path drawn from the paper's ranges by `seed`, as
    the simulator version its `sim` override names (default: the current one) draws them.

    `overrides` set spec fields (a None value leaves the drawn or default one); one out
    of range, like an unknown task or a negative seed, is a `SimulationError` naming it.
    """
    task = task_of(task, SimulationError)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise SimulationError(f"seed must be an integer 0 or more, not {seed!r}")
    version = _simulator(overrides.get("sim"))
    rng = np.random.default_rng(seed)
    offset = tuple(float(v) for v in rng.uniform(-1, 1, 3) * OFFSET_RANGES[version][task])
    speed = float(rng.uniform(*SPEED_RANGE[task]))
    points = [tuple(map(float, p)) for p in random_control_points(task, rng, version)]
    fields: dict[str, object] = {
        "task": task,
        "seed": seed,
        "speed": speed,
        "limb_offset": offset,
        "control_points": points,
    }
    fields.update({k: v for k, v in overrides.items() if v is not None})
    try:
        return TrialSpec.model_validate(fields)
    except ValidationError as err:  # an override out of range, named in one line
        raise SimulationError(f"invalid {first_problem(err)}") from None
