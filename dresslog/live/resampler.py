"""The 100 Hz grid, built as samples arrive: `convert`'s resampling rules, made causal.

`convert` resamples a whole log at once (`dresslog.convert.resample`); a robot's stream
has no end to wait for. `StreamResampler` takes samples one at a time, in stamp order per
stream, and hands out a grid step as soon as every stream holds what `convert` would have
used for it: for a bin-averaged stream, the bin after the step closed (a sample stamped
past it); for an interpolated one, a sample at or after the step; for a velocity
differentiated from a pose, the pose sample after that. Each value is computed by the
very functions `convert` calls, on the few samples around the step, so a step equals
`convert`'s for the same samples (bar the rounding of a mean over fewer numbers). Its
first step is `resample.grid_start`'s, decided once `DECIDE_SAMPLES` wrench samples tell
the wrench's rate.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dresslog.convert import resample as rs
from dresslog.convert.source import WIDTHS

#: Wrench samples whose intervals decide the rate (hence bin averaging) and the grid's phase.
DECIDE_SAMPLES = 21
#: Samples a stream keeps: enough for a bin of a 5 kHz sensor and its neighbours.
KEEP = 256


@dataclass
class _Stream:
    """The recent samples of one stream and how it is brought onto the grid."""

    kind: str
    t: list[int] = field(default_factory=list)
    v: list[np.ndarray] = field(default_factory=list)
    averaged: bool = False
    #: whether `t[0]` is the stream's first sample (a gradient's edge formula uses it)
    whole: bool = True

    def add(self, t_ns: int, values: np.ndarray) -> None:
        self.t.append(t_ns)
        self.v.append(values)
        if len(self.t) > 2 * KEEP:
            del self.t[:KEEP], self.v[:KEEP]
            self.whole = False

    def ready(self, g: int) -> bool:
        """Whether every sample `convert` would use for grid time `g` has arrived."""
        if not self.t:
            return False
        if self.averaged:  # the next bin closed: its mean time brackets g
            return self.t[-1] >= g + rs.PERIOD_NS + rs.PERIOD_NS // 2
        return self.t[-1] >= g

    def window(self, g: int) -> tuple[np.ndarray, np.ndarray]:
        """The samples around `g` that its value is computed from."""
        lo = g - (rs.PERIOD_NS + rs.PERIOD_NS // 2 if self.averaged else 0)
        i = len(self.t) - 1
        while i > 0 and self.t[i] >= lo:  # from the last sample before the window on
            i -= 1
        return np.asarray(self.t[i:], dtype=np.int64), np.asarray(self.v[i:])

    def value(self, g: int) -> np.ndarray:
        t, v = self.window(g)
        at = np.array([g], dtype=np.int64)
        if self.kind == "pose":
            return rs.interpolate_pose(t, v, at)[0]
        if self.averaged:
            return rs.bin_average(t, v, at)[0]
        return rs.interpolate(t, v, at)[0]

    def drop_before(self, g: int) -> None:
        """Forget samples no later step can use (all but a few before `g`)."""
        i = 0
        while i + 3 < len(self.t) and self.t[i + 3] < g - 2 * rs.PERIOD_NS:
            i += 1
        if i:
            del self.t[:i], self.v[:i]
            self.whole = False


@dataclass(frozen=True)
class GridStep:
    """One 100 Hz step as measured (before the signal's options place it)."""

    index: int
    t_ns: int
    wrench: np.ndarray
    twist: np.ndarray
    pose: np.ndarray | None


class StreamResampler:
    """Samples of a wrench and a twist or a pose in, 100 Hz steps out, causally.

    `motion` is "twist" (a TwistStamped stream) or "pose" (a pose, whose velocity is
    differentiated on its own samples as `convert` does); `has_pose` says a pose arrives
    beside a twist too.
    """

    def __init__(self, motion: str, *, has_pose: bool = False) -> None:
        self.motion = motion
        self.streams: dict[str, _Stream] = {"wrench": _Stream("wrench")}
        if motion == "twist":
            self.streams["twist"] = _Stream("twist")
        if motion == "pose" or has_pose:
            self.streams["pose"] = _Stream("pose")
        #: the twist differentiated from the pose, one sample behind it
        self._velocity = _Stream("twist") if motion == "pose" else None
        self._early_wrench: list[int] = []
        self.start_ns: int | None = None
        self.next_index = 0
        #: rates (Hz) of the streams, once the grid is decided
        self.rates: dict[str, float] = {}

    @property
    def first_ns(self) -> int | None:
        """The earliest sample received, on any stream."""
        firsts = [s.t[0] for s in self.streams.values() if s.t and s.whole]
        return min(firsts) if firsts else None

    def add(self, kind: str, t_ns: int, values: np.ndarray) -> list[GridStep]:
        """One sample (stamped later than the stream's previous one); the steps it completes."""
        stream = self.streams[kind]
        stream.add(t_ns, np.asarray(values, dtype=np.float64).reshape(WIDTHS[kind]))
        if kind == "wrench" and len(self._early_wrench) < DECIDE_SAMPLES:
            self._early_wrench.append(t_ns)
        if kind == "pose" and self._velocity is not None:
            self._differentiate(stream)
        if self.start_ns is None and not self._decide():
            return []
        return self._steps()

    def how(self, kind: str) -> str:
        """How a stream ("velocity": the pose's) is brought onto the grid, as `convert`
        records it."""
        stream = self._velocity if kind == "velocity" else self.streams[kind]
        averaged = stream is not None and stream.averaged
        return "mean over 10 ms bins" if averaged else "linear interpolation"

    def _differentiate(self, pose: _Stream) -> None:
        """The velocity at the pose sample before the newest (at the first one too, once
        there are three: the edge formula `convert` uses there)."""
        assert self._velocity is not None
        n = len(pose.t)
        if n < 3:
            return
        lo = n - 3
        t, v = np.asarray(pose.t[lo:], dtype=np.int64), np.asarray(pose.v[lo:])
        velocity = rs.twist_from_pose(t, v)
        if pose.whole and n == 3:  # the stream's first sample, by the edge formula
            self._velocity.add(int(t[0]), velocity[0])
        self._velocity.add(int(t[1]), velocity[1])

    def _motion_streams(self) -> list[_Stream]:
        streams = [s for k, s in self.streams.items() if k != "wrench"]
        return streams + ([self._velocity] if self._velocity is not None else [])

    def _decide(self) -> bool:
        """Set the grid's first step once the wrench's rate is known and every stream has
        begun: `convert`'s rule over the samples so far."""
        if len(self._early_wrench) < DECIDE_SAMPLES:
            return False
        if not all(s.t for s in self.streams.values()):
            return False
        if self._velocity is not None and not self._velocity.t:
            return False
        wrench = np.asarray(self._early_wrench, dtype=np.int64)
        self.streams["wrench"].averaged = rs.averages(wrench)
        self.rates = {"wrench": rs.median_rate(wrench)}
        for kind, stream in self.streams.items():
            if kind != "wrench":
                t = np.asarray(stream.t, dtype=np.int64)
                stream.averaged = kind != "pose" and rs.averages(t)
                self.rates[kind] = rs.median_rate(t)
        if self._velocity is not None:
            pose_t = np.asarray(self.streams["pose"].t, dtype=np.int64)
            self._velocity.averaged = rs.averages(pose_t)
        firsts = [s.t[0] for k, s in self.streams.items() if k != "wrench"]
        self.start_ns = rs.grid_start(wrench, firsts)
        return True

    def _steps(self) -> list[GridStep]:
        assert self.start_ns is not None
        out: list[GridStep] = []
        wrench = self.streams["wrench"]
        motion = self._velocity if self._velocity is not None else self.streams["twist"]
        pose = self.streams.get("pose")
        while True:
            g = self.start_ns + self.next_index * rs.PERIOD_NS
            if not (wrench.ready(g) and all(s.ready(g) for s in self._motion_streams())):
                return out
            out.append(
                GridStep(
                    self.next_index,
                    g,
                    wrench.value(g),
                    motion.value(g),
                    None if pose is None else pose.value(g),
                )
            )
            self.next_index += 1
            for stream in (*self.streams.values(), motion):
                stream.drop_before(g)
