"""The pybullet dressing simulator (the only package that imports pybullet)."""

from dresslog.sim.record import FanOut, WriterSink, record_trial
from dresslog.sim.simulate import (
    SimResult,
    SimStart,
    SimStep,
    StepSink,
    random_spec,
    simulate,
)

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
