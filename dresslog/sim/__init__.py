"""The pybullet dressing simulator (the only package that imports pybullet).

pybullet itself loads when the first scene is built (`dresslog.sim._pybullet`), so
drawing specs (`random_spec`) or importing this package costs no pybullet.
"""

from dresslog.sim.record import FanOut, WriterSink, record_trial
from dresslog.sim.simulate import SimResult, SimStart, SimStep, StepSink, simulate
from dresslog.sim.specs import random_spec

__all__ = [
    "FanOut",
    "SimResult",
    "SimStart",
    "SimStep",
    "StepSink",
    "WriterSink",
    "random_spec",
    "record_trial",
    "simulate",
]
