"""Run one trial: settle the garment, move the end effector, stream 100 Hz steps to a sink.

`simulate(spec, sink)` is the one code path for recording a file, for tests and
for live inference: the sink sees every recorded step, `BATCH` steps (0.1 s) at a time,
as they are computed.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from dresslog.errors import SimulationError
from dresslog.force_map import ClothSpreader, ForceDistributor
from dresslog.limb import (
    Limb,
    build_limb,
    limb_points,
    segment_of,
    sum_xyz,
    surface_points,
)
from dresslog.sim.balance import MomentumBalance, WrenchReading, constraint_reading
from dresslog.sim.garments import Garment, garment_for
from dresslog.sim.outcome import CatchWatch, decide_outcome_v8, judge
from dresslog.sim.scene import CONTACT_COLUMNS, EE_MASS, Scene
from dresslog.sim.trajectory import constant_speed, keep_clear, random_control_points
from dresslog.spec import Outcome, SimParams, TrialSpec
from dresslog.trial import CONTACT_DTYPE, LimbPoints, contact_magnitudes

GARMENT_HZ = 10
#: Instability guard: a vertex this far from the gripper means the cloth exploded.
MAX_VERTEX_DISTANCE = 1.5


@dataclass(frozen=True)
class SimStart:
    """What a sink needs before the first step."""

    spec: TrialSpec
    limb_points: LimbPoints
    triangles: np.ndarray


@dataclass(frozen=True)
class SimStep:
    """One recorded 100 Hz step. `garment` is (V, 3) at 10 Hz, else None."""

    index: int
    t_ns: int
    wrench: np.ndarray  # (6,) fx fy fz tx ty tz the garment applies at the gripper, tared
    twist: np.ndarray  # (6,) vx vy vz wx wy wz
    pose: np.ndarray  # (7,) x y z qx qy qz qw
    contacts: np.ndarray  # CONTACT_DTYPE (C,)
    force_map: np.ndarray  # (N,) float32
    garment: np.ndarray | None


class StepSink(Protocol):
    def start(self, info: SimStart) -> None: ...
    def step(self, step: SimStep) -> None: ...


@dataclass
class SimResult:
    """How the trial went; `outcome` is never FAILED (failures raise SimulationError)."""

    outcome: Outcome
    steps: int
    sim_seconds: float
    wall_seconds: float
    peak_limb_force: float  # peak over steps of the total contact force on the limb, N
    timings: dict[str, float] = field(default_factory=dict)
    caught_on: str | None = None  # the part a caught garment was held on (v9)

    @property
    def real_time_factor(self) -> float:
        return self.sim_seconds / self.wall_seconds if self.wall_seconds > 0 else float("inf")

    def summary(self) -> str:
        return (
            f"outcome={self.outcome.value}"
            + (f" on the {self.caught_on}" if self.caught_on else "")
            + f" steps={self.steps} "
            f"peak_limb_force={self.peak_limb_force:.2f}N wall={self.wall_seconds:.1f}s "
            f"rtf={self.real_time_factor:.2f}"
        )


def _contacts_of_steps(
    steps: list[np.ndarray], limb: Limb, verts: np.ndarray, substeps: int
) -> tuple[np.ndarray, np.ndarray]:
    """CONTACT_DTYPE array of the contacts that carry force at B steps, and their counts (B,).

    `steps[j]` holds the contacts (rows of `CONTACT_COLUMNS`, as `Scene.contacts` reads
    them) of step j's `substeps` physics steps, `verts[j]` the garment then (B, V, 3).
    Each garment vertex becomes one contact whose forces are the mean over those steps
    and whose place is its latest. The garment-side point is projected onto the limb
    surface, the normal there points from the limb to the garment. The contacts come
    out step after step, each step's as alone.
    """
    n_steps, n = verts.shape[:2]
    rows = [len(s) for s in steps]
    if not any(rows):
        return np.zeros(0, dtype=CONTACT_DTYPE), np.zeros(n_steps, np.int64)
    flat = np.concatenate(steps)
    sq = sum_xyz(verts * verts)
    vertex = np.empty(len(flat), np.int64)
    end = 0
    for j, count in enumerate(rows):
        if count:
            lo, end = end, end + count
            # nearest vertex by |v|^2 - 2 p.v (|p|^2 is the same for every vertex): one
            # small matmul per step (BLAS rounds a row by where it falls in the matrix)
            # instead of a (rows, vertices, 3) difference; garment nodes are centimetres
            # apart, so rounding cannot change which vertex is nearest
            near = (sq[j] - 2.0 * (flat[lo:end, 0:3] @ verts[j].T)).argmin(axis=1)
            vertex[lo:end] = near + j * n
    latest = np.full(n_steps * n, -1)
    np.maximum.at(latest, vertex, np.arange(len(vertex)))  # each vertex's last row
    ids = np.flatnonzero(latest >= 0)  # by step, then vertex
    forces = np.empty((len(flat), 4))
    forces[:, 0] = flat[:, 9]
    forces[:, 1:] = flat[:, 10:11] * flat[:, 11:14] + flat[:, 14:15] * flat[:, 15:18]
    # per-vertex sums over the rows in order, as the substeps' impulses add up
    sums = np.bincount(
        (vertex[:, None] * 4 + np.arange(4)).ravel(), forces.ravel(), 4 * len(latest)
    )
    mean = sums.reshape(-1, 4)[ids] / substeps
    pos, normal = surface_points(limb, flat[latest[ids], 0:3])
    out = np.zeros(len(ids), dtype=CONTACT_DTYPE)
    out["position"] = pos
    out["normal"] = normal
    out["normal_force"] = mean[:, 0]
    out["friction"] = mean[:, 1:]
    out["segment"] = segment_of(limb, pos)
    step_of, out["vertex"] = np.divmod(ids, n)
    return out, np.bincount(step_of, minlength=n_steps)


#: Per-axis offset below which a vertex is surely within MAX_VERTEX_DISTANCE: the
#: rounded squares then sum to at most 3 * 0.866**2 (1 + 1e-15) < 1.5**2.
_SURELY_NEAR = 0.866


def _guard(verts: np.ndarray, ee: np.ndarray, t: float) -> None:
    d = verts - ee
    if np.abs(d).max() <= _SURELY_NEAR:  # False for NaN: then the full check decides
        return
    far = math.sqrt(sum_xyz(d * d).max())  # the largest vertex norm, NaN if non-finite
    if far <= MAX_VERTEX_DISTANCE:
        return
    if not np.isfinite(verts).all():
        raise SimulationError(f"garment exploded at t={t:.2f}s (non-finite vertices)")
    raise SimulationError(f"garment exploded at t={t:.2f}s (a vertex {far:.1f} m away)")


#: Recorded steps whose contacts and force maps are computed together: numpy's cost
#: per call, not the few contacts of a step, dominates that work, so a batch costs
#: little more than one step (larger batches lose it again to page faults). A live
#: sink sees the steps this many at a time.
BATCH = 10
#: The garment handed to a wrench reading that does not look at it.
_NONE = np.empty((0, 3))
#: The contacts handed to a wrench reading that does not look at them.
_NO_CONTACTS = np.empty((0, CONTACT_COLUMNS))


@dataclass(frozen=True)
class _Motion:
    """The gripper's recorded trajectory and what the wrench is corrected by, per step."""

    t: np.ndarray  # (T,) s
    twist: np.ndarray  # (T, 6)
    pose: np.ndarray  # (T, 7)
    inertia: np.ndarray  # (T, 3) gripper mass x acceleration, N
    tare: np.ndarray  # (6,) the constraint's wrench with the garment settled


class _StepBatch:
    """Turns the physics' raw readings into recorded steps, BATCH steps at a time.

    For each held step it checks the garment, places the contacts on the limb, makes
    the force map and the tared wrench, checks the forces and hands the step to the
    sink, in step order; every step comes out as it would alone.
    """

    def __init__(
        self,
        spec: TrialSpec,
        limb: Limb,
        motion: _Motion,
        force_map: ForceDistributor,
        spread: ClothSpreader | None,
        sink: StepSink | None,
        timings: dict[str, float],
        watch: CatchWatch | None = None,
    ) -> None:
        self.spec, self.limb, self.motion, self.watch = spec, limb, motion, watch
        self.force_map, self.spread, self.sink, self.timings = force_map, spread, sink, timings
        self.substeps = spec.sim.physics_hz // spec.sim.record_hz
        self.garment_every = max(1, spec.sim.record_hz // GARMENT_HZ)
        self._held: list[tuple[int, list[np.ndarray], np.ndarray, np.ndarray]] = []
        self.peak_limb = 0.0
        self.ee_forces: list[float] = []  # |force| at the gripper of each step handed on

    def add(
        self, index: int, contacts: list[np.ndarray], wrench: np.ndarray, verts: np.ndarray
    ) -> None:
        """Hold step `index`: its substeps' contacts, summed wrench reading, garment."""
        self._held.append((index, contacts, wrench, verts))
        if len(self._held) >= BATCH:
            self.flush()

    def flush(self) -> None:
        if not self._held:
            return
        held, self._held = self._held, []
        t0 = time.thread_time()
        index = np.array([h[0] for h in held])
        verts = np.stack([h[3] for h in held])
        exploded = self._exploded(index, verts)
        if exploded is not None:  # the steps before it go first, as they happened first
            held, index, verts = held[: exploded[0]], index[: exploded[0]], verts[: exploded[0]]
        every, counts = _contacts_of_steps(
            [np.concatenate(h[1]) for h in held], self.limb, verts, self.substeps
        )
        mags = contact_magnitudes(every)
        maps = self._force_maps(verts, every, counts, mags)
        m = self.motion
        # the garment's load on the gripper, minus the tare, plus (read by the constraint,
        # which carries the gripper too) the gripper's weight and inertia
        wrench = np.array([h[2] for h in held]).reshape(-1, 6) / self.substeps - m.tare
        wrench[:, :3] += m.inertia[index]
        last = len(m.t) - 1
        self.timings["contacts"] += time.thread_time() - t0
        ends = np.cumsum(counts)
        for j, (i, lo, hi) in enumerate(zip(index, ends - counts, ends, strict=True)):
            t1 = time.thread_time()
            self._check(i, mags[lo:hi], wrench[j])
            if self.watch is not None:
                c = every[lo:hi]
                speed = float(np.linalg.norm(m.twist[i, :3]))
                self.watch.step(speed, self.ee_forces[-1], c["position"], c["segment"], mags[lo:hi])
            step = SimStep(
                index=int(i),
                t_ns=round(m.t[i] * 1e9),
                wrench=wrench[j],
                twist=m.twist[i],
                pose=m.pose[i],
                contacts=every[lo:hi],
                force_map=maps[j],
                garment=verts[j].astype(np.float32)
                if i % self.garment_every == 0 or i == last
                else None,
            )
            t2 = time.thread_time()
            if self.sink is not None:
                self.sink.step(step)
            self.timings["sensors"] += t2 - t1
            self.timings["sink"] += time.thread_time() - t2
        if exploded is not None:
            raise exploded[1]

    def _force_maps(
        self, verts: np.ndarray, contacts: np.ndarray, counts: np.ndarray, mags: np.ndarray
    ) -> np.ndarray:
        """The force map (B, N) of each step, its contacts first spread over the cloth."""
        if self.spread is None or not len(contacts):
            return self.force_map.maps(contacts["position"], mags, counts)
        step = np.repeat(np.arange(len(verts)), counts)
        nodes = contacts["vertex"].astype(np.int64)
        at, pos, f = self.spread.spread(self.limb, verts, step, nodes, mags)
        return self.force_map.maps(pos, f, np.bincount(at, minlength=len(verts)))

    def _exploded(self, index: np.ndarray, verts: np.ndarray) -> tuple[int, SimulationError] | None:
        """The first held step whose garment flew apart, with its error; None if none did."""
        ee = self.motion.pose[index, None, :3]
        calm = np.abs(verts - ee).max(axis=(1, 2)) <= _SURELY_NEAR  # False for NaN
        for j in np.flatnonzero(~calm):
            try:
                _guard(verts[j], ee[j, 0], self.motion.t[index[j]])
            except SimulationError as e:
                return int(j), e
        return None

    def _check(self, i: int, mags: np.ndarray, wrench: np.ndarray) -> None:
        """Raise if the limb or the gripper feels more than physics allows; track the peaks."""
        p, t = self.spec.sim, self.motion.t[i]
        if len(mags):
            self.peak_limb = max(self.peak_limb, float(mags.sum()))
            if mags.max() > p.max_limb_force:
                raise SimulationError(
                    f"limb contact force {mags.max():.0f} N exceeds the physical bound "
                    f"{p.max_limb_force:.0f} N at t={t:.2f}s"
                )
        f = wrench[:3]
        fmag = math.sqrt(f.dot(f))  # as np.linalg.norm computes it
        if not math.isfinite(fmag) or fmag > p.max_limb_force:
            raise SimulationError(
                f"end-effector force {fmag:.0f} N exceeds the physical bound at t={t:.2f}s"
            )
        self.ee_forces.append(fmag)


def _gripper_path(
    spec: TrialSpec, ctrl: np.ndarray, limb: Limb, garment: Garment, sub: int
) -> tuple[np.ndarray, np.ndarray]:
    """The gripper's positions at the physics rate and at the recorded rate.

    Constant speed along the spline, lifted where its held edge would touch the limb.
    """
    p = spec.sim
    n_rec = round(spec.duration * p.record_hz)
    path = constant_speed(ctrl, spec.speed, np.arange(n_rec) / p.record_hz)
    path_phys = constant_speed(ctrl, spec.speed, np.arange(n_rec * sub) / p.physics_hz)
    held = garment.vertices[garment.gripped]
    rise = spec.speed / p.physics_hz  # the lift moves no faster than the path
    smoothing = round(p.lift_smoothing * p.physics_hz)
    cleared = keep_clear(path_phys, limb, held, p.grip_clearance, p.max_grip_lift, rise, smoothing)
    if cleared is not path_phys:  # a path left alone keeps its own 100 Hz samples
        path_phys, path = cleared, cleared[::sub]
    return path_phys, path


def _motion(path: np.ndarray, record_hz: int, tare: np.ndarray, *, gripper: bool) -> _Motion:
    """Twist, pose and the end effector's inertial force along the recorded path.

    `gripper`: the wrench is read by the constraint, which carries the gripper's
    inertia too; the garment's momentum balance does not, so it gets none back.
    """
    n_rec = len(path)  # at least 2: a spec covers two recorded steps
    vel = np.zeros_like(path)
    vel[1:] = np.diff(path, axis=0) * record_hz
    vel[0] = vel[1]
    accel = np.gradient(vel, axis=0) * record_hz if n_rec > 2 else np.zeros_like(vel)
    twist = np.concatenate([vel, np.zeros_like(vel)], axis=1)
    pose = np.concatenate([path, np.tile([0.0, 0.0, 0.0, 1.0], (n_rec, 1))], axis=1)
    inertia = EE_MASS * accel if gripper else np.zeros_like(accel)
    return _Motion(np.arange(n_rec) / record_hz, twist, pose, inertia, tare)


def _settle(
    scene: Scene, p: SimParams, rng: np.random.Generator, read: WrenchReading, ee: np.ndarray
) -> np.ndarray:
    """Let the garment hang, after a brief uniform "wind" (a tilted gravity); the tare wrench."""
    g = np.array([0.0, 0.0, -9.81])
    wind = rng.normal(size=3)
    wind *= p.wind_accel / np.linalg.norm(wind)
    n_settle, n_wind, n_tare = p.settle_steps()  # the spec leaves the tare after the wind
    tare = np.zeros(6)
    if isinstance(read, MomentumBalance):  # which must see every step: read them at the end
        seen, contacts = [], []
        for k in range(n_settle):
            scene.set_gravity(g + wind if k < n_wind else g)
            scene.step()
            seen.append(scene.vertices())
            contacts.append(scene.contacts())
        windy = min(n_wind, n_settle)
        for lo, hi, gravity in ((0, windy, g + wind), (windy, n_settle, g)):
            if hi > lo:
                readings = read.steps(
                    gravity, np.stack(seen[lo:hi]), contacts[lo:hi], np.tile(ee, (hi - lo, 1))
                )
                for k in range(max(lo, n_settle - n_tare), hi):
                    tare += readings[k - lo]
        return tare / n_tare
    for k in range(n_settle):
        scene.set_gravity(g + wind if k < n_wind else g)
        scene.step()
        if k >= n_settle - n_tare:
            tare += read(scene, _NONE, _NO_CONTACTS, ee)
    return tare / n_tare


def _record(
    scene: Scene,
    path_phys: np.ndarray,
    sub: int,
    steps: _StepBatch,
    read: WrenchReading,
    timings: dict[str, float],
) -> None:
    """Move the gripper along the path; each recorded step averages its physics substeps.

    Contacts and wrench are averaged over the substeps: a recorded step carries the
    impulse of its whole interval, not the chatter of its last substep. The garment's
    momentum balance, which must see every physics step, reads BATCH steps' at once.
    """
    balance = read if isinstance(read, MomentumBalance) else None
    n_rec = len(path_phys) // sub
    held: list[tuple[int, list[np.ndarray], list[np.ndarray]]] = []
    for i in range(n_rec):
        contacts: list[np.ndarray] = []
        seen: list[np.ndarray] = []
        wrench = np.zeros(6)
        for k in range(sub):
            t0 = time.thread_time()
            ee = path_phys[i * sub + k]
            scene.move_ee(ee)
            scene.step()
            t1 = time.thread_time()
            contacts.append(scene.contacts())
            if balance is not None:
                seen.append(scene.vertices())
            else:
                verts = scene.vertices() if k == sub - 1 else _NONE
                wrench += read(scene, verts, contacts[-1], ee)
            timings["physics"] += t1 - t0
            timings["queries"] += time.thread_time() - t1
        if balance is None:
            steps.add(i, contacts, wrench, verts)
            continue
        held.append((i, contacts, seen))
        if len(held) == BATCH or i == n_rec - 1:
            t0 = time.thread_time()
            lo, hi = held[0][0] * sub, (held[-1][0] + 1) * sub
            readings = balance.steps(
                scene.gravity,
                np.stack([v for h in held for v in h[2]]),
                [c for h in held for c in h[1]],
                path_phys[lo:hi],
            )
            wrenches = np.zeros((len(held), 6))
            for k in range(sub):  # added up substep after substep, as one step adds them
                wrenches += readings[k::sub]
            timings["queries"] += time.thread_time() - t0
            for (j, contacts, seen), wrench in zip(held, wrenches, strict=True):
                steps.add(j, contacts, wrench, seen[-1])
            held = []
    steps.flush()


def simulate(spec: TrialSpec, sink: StepSink | None = None) -> SimResult:
    """Run `spec`, streaming each recorded step to `sink`; raise SimulationError if unstable."""
    wall0 = time.perf_counter()
    p = spec.sim
    if p.physics_hz % p.record_hz:
        raise SimulationError("physics_hz must be a multiple of record_hz")
    sub = p.physics_hz // p.record_hz
    rng = np.random.default_rng(spec.seed)  # draws the path (if not given), then the wind
    task = spec.task
    if spec.control_points:
        ctrl = np.asarray(spec.control_points, dtype=float)
    else:
        ctrl = random_control_points(task, rng, p.simulator)
    limb = build_limb(task, spec.limb_offset, spec.limb_rotation)
    points = limb_points(limb)
    garment = garment_for(task, p.simulator)
    path_phys, path = _gripper_path(spec, ctrl, limb, garment, sub)
    n_rec, start = len(path), path[0]
    force_map = ForceDistributor(points.points)
    spread = (
        ClothSpreader(garment.triangles, len(garment.vertices), p.contact_spread, p.contact_reach)
        if p.contact_spread
        else None
    )

    scene = Scene.build(limb, garment, start, p)
    # CPU seconds of this thread per stage: a fair split even on a busy machine
    # ("queries": reading contacts, constraint and garment back from pybullet)
    timings = {"physics": 0.0, "queries": 0.0, "contacts": 0.0, "sensors": 0.0, "sink": 0.0}
    try:
        if sink is not None:
            sink.start(SimStart(spec, points, garment.triangles))
        read: WrenchReading = (
            MomentumBalance(scene.vertices(), p.garment_mass, p.physics_hz)
            if p.wrench_from == "momentum"
            else constraint_reading
        )
        tare = _settle(scene, p, rng, read, start)
        _guard(scene.vertices(), start, 0.0)
        motion = _motion(path, p.record_hz, tare, gripper=read is constraint_reading)
        watch = CatchWatch(task, limb, p.record_hz) if p.simulator >= 9 else None
        steps = _StepBatch(spec, limb, motion, force_map, spread, sink, timings, watch)
        _record(scene, path_phys, sub, steps, read, timings)
        peak_limb = steps.peak_limb
        final_force = max(steps.ee_forces[-max(1, p.record_hz // 5) :], default=0.0)
        verts = scene.vertices()
        if watch is None:
            caught_on = None
            outcome = decide_outcome_v8(task, limb, garment, verts, final_force)
        else:
            caught_on = watch.finish()
            outcome = judge(task, limb, garment, verts, final_force, caught_on)
            caught_on = caught_on if outcome is Outcome.CAUGHT else None
    finally:
        scene.close()
    wall = time.perf_counter() - wall0
    return SimResult(
        outcome=outcome,
        steps=n_rec,
        sim_seconds=n_rec / p.record_hz,
        wall_seconds=wall,
        peak_limb_force=peak_limb,
        timings=timings,
        caught_on=caught_on,
    )


__all__ = [
    "SimResult",
    "SimStart",
    "SimStep",
    "StepSink",
    "simulate",
]
