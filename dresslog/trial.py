"""In-memory trial data: numpy arrays with integer-nanosecond timestamps.

These are what `TrialReader` returns and what the simulator, converters and
the replay engine pass around; no I/O happens here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dresslog.spec import TrialMetadata

#: The rate of the steps every model reads (Hz): trials are simulated and converted at it.
STEP_HZ = 100
#: A gripper slower than this (m/s) is still: the simulated trials draw the garment at
#: 10-20 cm/s, and a robot at rest reads its pose's jitter, differentiated, as a little speed.
#: `infer` counts the steps faster than it as moving, `convert` a log's still start by it.
MOVING_SPEED = 0.02


def median_rate(t_ns: np.ndarray) -> float:
    """Typical sample rate in Hz (0 for fewer than two samples)."""
    if len(t_ns) < 2:
        return 0.0
    return float(1e9 / np.median(np.diff(t_ns)))


#: One garment-limb contact; the memory layout equals the CDR layout of
#: `dresslog_msgs/msg/Contact`, so a contact array is encoded by a byte copy.
CONTACT_DTYPE = np.dtype(
    [
        ("position", "<f8", (3,)),
        ("normal", "<f8", (3,)),
        ("friction", "<f8", (3,)),
        ("normal_force", "<f8"),
        ("segment", "<u4"),
        ("vertex", "<u4"),
    ]
)


def padded(sequences: Sequence[np.ndarray], length: int | None = None) -> np.ndarray:
    """(n, length, D) float32: each (T_i, D) sequence from its start, zeros after it.

    `length` defaults to the longest; a longer sequence is cut there. Batches of trials
    of different lengths are stacked so (the LSTM is causal: the zeros never change a
    real step's output).
    """
    if not len(sequences):
        raise ValueError("no sequences to pad")
    if length is None:
        length = max(len(s) for s in sequences)
    out = np.zeros((len(sequences), length, sequences[0].shape[1]), np.float32)
    for row, seq in enumerate(sequences):
        out[row, : min(len(seq), length)] = seq[:length]
    return out


def contact_vectors(contacts: np.ndarray) -> np.ndarray:
    """Total force (C, 3) of each contact: normal force along the normal, plus friction."""
    return contacts["normal_force"][:, None] * contacts["normal"] + contacts["friction"]


def contact_magnitudes(contacts: np.ndarray) -> np.ndarray:
    """Total force magnitude of each contact: |normal force + friction|."""
    v = contact_vectors(contacts)
    # np.linalg.norm(v, axis=1) bit for bit: sqrt of the row sums (x + y) + z of v * v
    s = v * v
    return np.sqrt(s[:, 0] + s[:, 1] + s[:, 2])


@dataclass(frozen=True)
class Stream:
    """A sampled signal: `t_ns` (T,) int64 and `values` (T, D)."""

    t_ns: np.ndarray
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass(frozen=True)
class ForceMaps:
    """Force maps over time: `forces` (T, N) float32 in N; `contact` (T, N) or (T, 0)."""

    t_ns: np.ndarray
    forces: np.ndarray
    contact: np.ndarray

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass(frozen=True)
class LimbPoints:
    """The force-map sites: `points` (N, 3) m, `segment` (N,) index into `segment_names`."""

    limb: str
    points: np.ndarray
    segment: np.ndarray
    segment_names: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.points)


@dataclass(frozen=True)
class Contacts:
    """Contacts per step: `t_ns` (T,), and for step i `items[i]`, a CONTACT_DTYPE array."""

    t_ns: np.ndarray
    items: list[np.ndarray]

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass(frozen=True)
class GarmentStates:
    """Garment vertices over time: `vertices` (T, V, 3) float32, `triangles` (F, 3)."""

    t_ns: np.ndarray
    vertices: np.ndarray
    triangles: np.ndarray


@dataclass(frozen=True)
class Measurements:
    """The network input phi_t = [force, torque, linear velocity] (T, 9) at each step."""

    t_ns: np.ndarray
    phi: np.ndarray

    def __len__(self) -> int:
        return len(self.t_ns)


@dataclass
class Trial:
    """A whole recording in memory; any stream but `wrench` and `twist` may be absent."""

    metadata: TrialMetadata
    wrench: Stream
    twist: Stream
    pose: Stream | None = None
    force_map: ForceMaps | None = None
    estimate: ForceMaps | None = None
    contacts: Contacts | None = None
    limb_points: LimbPoints | None = None
    garment: GarmentStates | None = None

    @property
    def measurements(self) -> Measurements:
        """phi_t on the timestamps wrench and twist share (a step either lacks is dropped)."""
        return measurements(self.wrench, self.twist)


def measurements(wrench: Stream, twist: Stream) -> Measurements:
    """Join wrench (T, 6) and twist (T, 6) into phi (T, 9) on their common timestamps."""
    common, wi, ti = np.intersect1d(wrench.t_ns, twist.t_ns, return_indices=True)
    phi = np.concatenate([wrench.values[wi, :6], twist.values[ti, :3]], axis=1)
    return Measurements(t_ns=common, phi=phi.astype(np.float32))
