"""Limb geometry (spheres joined by conical frustums) and the force-map sites on it.

The simulator builds its collision shapes from `Limb` and the force map is
defined over `limb_points(limb)`, so both always agree. World frame, z up, SI.
Nominal poses (before offset): the arm lies with the forearm along +x from the
elbow at the origin and the upper arm straight up (a seated person holding the
forearm out); the leg lies along +x from the hip at the origin with the foot
tilted 45 degrees upward, as for a person seated with the leg stretched out.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from dresslog.errors import SimulationError
from dresslog.spec import LimbRotation, Task, Vec3, task_of
from dresslog.trial import LimbPoints

#: Force-map sites are pushed this far out from the surface (reference: 2.5 mm).
POINT_LIFT = 0.0025
#: Rings per frustum (reference).
RINGS_PER_FRUSTUM = 10


@dataclass(frozen=True)
class Sphere:
    name: str
    center: np.ndarray
    radius: float


@dataclass(frozen=True)
class Frustum:
    """A conical frustum between two spheres (by name), tangent-free: radii are the spheres'."""

    name: str
    a: str
    b: str


@dataclass(frozen=True)
class Limb:
    """Rigid limb: named spheres and the frustums joining them; `points_per_part` sums to N."""

    name: str
    spheres: dict[str, Sphere]
    frustums: tuple[Frustum, ...]
    points_per_part: dict[str, int] = field(default_factory=dict)
    #: spheres whose rotation follows the distal part (forearm / foot)
    distal: tuple[str, ...] = ()
    #: the joint the distal part rotates about
    pivot: str = ""
    #: spheres along the limb's axis in the order a garment is drawn on (hand or foot
    #: first), for `along_limb`
    chain: tuple[str, ...] = ()

    def frustum_ends(self, f: Frustum) -> tuple[np.ndarray, float, np.ndarray, float]:
        """(centre, radius) of the sphere at each end of `f`: the cone frustum between them."""
        sa, sb = self.spheres[f.a], self.spheres[f.b]
        return sa.center, sa.radius, sb.center, sb.radius

    @property
    def segment_names(self) -> tuple[str, ...]:
        """The limb's parts, in the order its limb points are counted out per part."""
        return tuple(self.points_per_part)

    @cached_property
    def geometry(self) -> LimbGeometry:
        """The parts as arrays, built on first use, for distance queries."""
        return LimbGeometry.of(self)


def _arm() -> Limb:
    elbow = np.array([0.0, 0.0, 0.0])
    fist = elbow + np.array([0.31, 0.0, 0.0])
    shoulder = elbow + np.array([0.0, 0.0, 0.32])
    spheres = {
        "fist": Sphere("fist", fist, 0.05),
        "wrist": Sphere("wrist", fist.copy(), 0.0365),
        "elbow": Sphere("elbow", elbow, 0.05),
        "shoulder": Sphere("shoulder", shoulder, 0.075),
    }
    frustums = (Frustum("forearm", "wrist", "elbow"), Frustum("upper_arm", "elbow", "shoulder"))
    counts = {"fist": 36, "elbow": 17, "forearm": 101, "upper_arm": 146}
    chain = ("fist", "elbow", "shoulder")
    return Limb("arm", spheres, frustums, counts, ("fist", "wrist"), "elbow", chain)


def _leg() -> Limb:
    hip = np.array([0.0, 0.0, 0.0])
    knee = hip + np.array([0.424, 0.0, 0.0])
    ankle = knee + np.array([0.422, 0.0, 0.0])
    s45 = np.sqrt(0.5)
    toe = ankle + 0.18 * np.array([s45, 0.0, s45])
    heel = ankle + np.array([0.035, 0.0, -0.03])
    spheres = {
        "hip": Sphere("hip", hip, 0.081),
        "knee": Sphere("knee", knee, 0.053),
        "ankle": Sphere("ankle", ankle, 0.048),
        "heel": Sphere("heel", heel, 0.048),
        "toe": Sphere("toe", toe, 0.04),
    }
    frustums = (
        Frustum("thigh", "hip", "knee"),
        Frustum("shin", "knee", "ankle"),
        Frustum("foot", "ankle", "toe"),
        Frustum("heel_link", "ankle", "heel"),
    )
    counts = {
        "knee": 15,
        "ankle": 10,
        "heel": 20,
        "toe": 20,
        "thigh": 150,
        "shin": 130,
        "foot": 45,
        "heel_link": 10,
    }
    chain = ("toe", "ankle", "knee", "hip")
    return Limb("leg", spheres, frustums, counts, ("heel", "toe"), "ankle", chain)


def _rotation_matrix(axis: str, degrees: float) -> np.ndarray:
    t = np.deg2rad(degrees)
    c, s = np.cos(t), np.sin(t)
    i = "xyz".index(axis)
    m = np.eye(3)
    j, k = [a for a in range(3) if a != i]
    m[j, j], m[j, k], m[k, j], m[k, k] = c, -s, s, c
    return m


def build_limb(
    task: Task | str,
    offset: Vec3 = (0.0, 0.0, 0.0),
    rotation: LimbRotation | None = None,
) -> Limb:
    """The task's limb, its distal part rotated about the pivot joint, then offset."""
    limb = _arm() if task_of(task, SimulationError) is Task.GOWN else _leg()
    rot = rotation or LimbRotation()
    pivot = limb.spheres[limb.pivot].center
    r = _rotation_matrix(rot.axis, rot.degrees)
    off = np.asarray(offset, dtype=float)
    spheres = {}
    for name, s in limb.spheres.items():
        c = s.center
        if name in limb.distal and rot.degrees != 0.0:
            c = pivot + r @ (c - pivot)
        spheres[name] = Sphere(name, c + off, s.radius)
    return replace(limb, spheres=spheres)


def along_limb(limb: Limb, points: np.ndarray) -> np.ndarray:
    """Each point's distance (m) along the limb from the tip of the hand or foot: how far
    a garment drawn on must go to reach it. A point is placed by its projection on the
    nearest segment of the `chain` of joint centres, the end segments extended past
    their joints (the fist, the toes, the shoulder's cap)."""
    start, step, lengths = _chain_segments(limb)
    t = np.einsum("psk,sk->ps", points[:, None] - start, step) / lengths**2  # (P, S)
    t[:, 1:] = np.maximum(t[:, 1:], 0.0)
    t[:, :-1] = np.minimum(t[:, :-1], 1.0)
    nearest = np.linalg.norm(points[:, None] - (start + t[..., None] * step), axis=2).argmin(1)
    joints = chain_joints(limb)
    return joints[nearest] + t[np.arange(len(points)), nearest] * lengths[nearest]


def chain_joints(limb: Limb) -> np.ndarray:
    """Where each sphere of `limb.chain` lies along the limb (m, as `along_limb` counts)."""
    tip = limb.spheres[limb.chain[0]].radius  # the fist's or toe's far side: 0
    return tip + np.concatenate([[0.0], np.cumsum(_chain_segments(limb)[2])])


def _chain_segments(limb: Limb) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chain's segments: start points (S, 3), steps (S, 3) and lengths (S,)."""
    centres = np.array([limb.spheres[name].center for name in limb.chain])
    step = np.diff(centres, axis=0)
    return centres[:-1], step, np.linalg.norm(step, axis=1)


# ---------------------------------------------------------------------------
# Signed distance: which limb points neighbouring parts hide, where a contact lies on
# the surface, which cloth lies on the limb (the spread), whether the gripper path clears
# it, and the outcome.


def sum_xyz(v: np.ndarray) -> np.ndarray:
    """`v.sum(axis=-1)` of (..., 3) bit for bit, (x + y) + z, minus numpy's slow short reduce.

    With it, `np.sqrt(sum_xyz(v * v))` equals `np.linalg.norm(v, axis=-1)` exactly.
    """
    return v[..., 0] + v[..., 1] + v[..., 2]


@dataclass(frozen=True)
class LimbGeometry:
    """A limb's parts as arrays: rows are the spheres, then the frustums, in limb order.

    A sphere is a frustum that stays at t = 0: its start is its centre, its radius
    constant. `part_distances` gives the approximate signed distance (linear radius
    along the axis) to all parts at once (the stacked matmul makes the same BLAS call
    per frustum), so each value is bit-identical to evaluating the parts one by one.
    """

    start: np.ndarray  # (K, 3) sphere centre or frustum start a
    ab: np.ndarray  # (K, 3) frustum start to end, 0 for a sphere
    r0: np.ndarray  # (K,) sphere radius or frustum ra
    dr: np.ndarray  # (K,) frustum rb - ra, 0 for a sphere
    u: np.ndarray  # (F, 3) frustum unit axis
    length: np.ndarray  # (F,) frustum length
    segment_rows: np.ndarray  # row of each of `limb.segment_names`
    part_names: tuple[str, ...]  # the part of each row

    @classmethod
    def of(cls, limb: Limb) -> LimbGeometry:
        """`limb`'s spheres, then its frustums, as arrays; `segment_rows` finds each part's
        row."""
        spheres = list(limb.spheres.values())
        ends = [limb.frustum_ends(f) for f in limb.frustums]
        ab = [b - a for a, _, b, _ in ends]
        length = [float(np.linalg.norm(v)) for v in ab]
        rows = [*limb.spheres, *(f.name for f in limb.frustums)]
        return cls(
            start=np.array([*(s.center for s in spheres), *(a for a, *_ in ends)]),
            ab=np.array([*(np.zeros(3) for _ in spheres), *ab]),
            r0=np.array([*(s.radius for s in spheres), *(ra for _, ra, _, _ in ends)]),
            dr=np.array([*(0.0 for _ in spheres), *(rb - ra for _, ra, _, rb in ends)]),
            u=np.array([v / n for v, n in zip(ab, length, strict=True)]),
            length=np.array(length)[:, None],
            segment_rows=np.array([rows.index(n) for n in limb.segment_names]),
            part_names=tuple(rows),
        )

    @cached_property
    def _views(self) -> tuple[np.ndarray, ...]:
        """The broadcast views `part_distances` uses, made once: spheres, then frustums."""
        f = len(self.u)
        s = len(self.r0) - f
        return (
            self.start[:s, None],
            self.r0[:s, None],
            self.start[s:, None],
            self.u[:, :, None],
            self.ab[s:, None],
            self.r0[s:, None],
            self.dr[s:, None],
        )

    def part_distances(self, p: np.ndarray) -> np.ndarray:
        """Signed distance (K, P) from each part to each point (P, 3).

        A sphere row is a frustum row with t = 0 and no length, so its distance is
        the same numbers without the axis terms: the spheres are done apart, cheaper.
        """
        p = np.asarray(p, dtype=np.float64)
        centre, radius, start, u_col, ab, r0, dr = self._views
        s = len(centre)
        out = np.empty((len(self.r0), len(p)))
        v = p - centre
        out[:s] = np.sqrt(sum_xyz(v * v)) - radius
        along = np.matmul(p - start, u_col)[..., 0]
        t = (along / self.length).clip(0.0, 1.0)
        v = p - (start + t[:, :, None] * ab)
        out[s:] = np.sqrt(sum_xyz(v * v)) - (r0 + t * dr)
        return out


def limb_sdf(limb: Limb, p: np.ndarray) -> np.ndarray:
    """Signed distance (m) from points (P, 3) to the limb surface; < 0 inside."""
    return limb.geometry.part_distances(p).min(axis=0)


#: Finite-difference steps of the surface normal, one per axis.
_PROBES = np.eye(3) * 1e-5


def surface_points(
    limb: Limb, p: np.ndarray, sdf: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Closest limb-surface points to `p` (C, 3) and the outward unit normals there.

    `sdf`: `limb_sdf(limb, p)` when the caller has it already (it is not computed again).
    """
    c = len(p)
    if sdf is None:
        d = limb_sdf(limb, np.concatenate([p[None], p + _PROBES[:, None]]).reshape(-1, 3))
        at, probed = d[:c], d[c:]
    else:
        at, probed = sdf, limb_sdf(limb, (p + _PROBES[:, None]).reshape(-1, 3))
    grad = (probed.reshape(3, c) - at).T
    n = grad / np.maximum(np.sqrt(sum_xyz(grad * grad))[:, None], 1e-12)
    return p - at[:, None] * n, n


# ---------------------------------------------------------------------------
# Point generation.


def _fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = np.pi * (1.0 + 5**0.5) * i
    rxy = np.sqrt(1.0 - z * z)
    return np.stack([rxy * np.cos(phi), rxy * np.sin(phi), z], axis=1)


def _sphere_points(s: Sphere, n: int) -> np.ndarray:
    return s.center + (s.radius + POINT_LIFT) * _fibonacci_sphere(n)


def _frustum_points(a: np.ndarray, ra: float, b: np.ndarray, rb: float, total: int) -> np.ndarray:
    """`total` points on RINGS_PER_FRUSTUM rings, per-ring counts proportional to the radius."""
    ab = b - a
    u = ab / np.linalg.norm(ab)
    helper = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    ts = (np.arange(RINGS_PER_FRUSTUM) + 0.5) / RINGS_PER_FRUSTUM
    radii = ra + ts * (rb - ra)
    counts = np.maximum(1, np.round(total * radii / radii.sum()).astype(int))
    while counts.sum() != total:
        i = int(np.argmax(counts)) if counts.sum() > total else int(np.argmin(counts))
        counts[i] += 1 if counts.sum() < total else -1
    pts = []
    for k, (t, r, c) in enumerate(zip(ts, radii, counts, strict=True)):
        ang = 2 * np.pi * (np.arange(c) + 0.5 * (k % 2)) / c
        ring = (r + POINT_LIFT) * (np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2)
        pts.append(a + t * ab + ring)
    return np.concatenate(pts)


def _visible(limb: Limb, pts: np.ndarray, own: set[str]) -> np.ndarray:
    """Which points lie outside every part but the `own` ones (by half the lift)."""
    others = [name not in own for name in limb.geometry.part_names]
    return limb.geometry.part_distances(pts)[others].min(axis=0) > 0.5 * POINT_LIFT


def _part_points(limb: Limb, part: str, target: int) -> np.ndarray:
    """Exactly `target` visible points on one part, growing the raw count until enough survive."""
    own = {part}
    if part in limb.spheres:
        # a sphere sharing its centre with another (fist/wrist) owns both
        own |= {
            n for n, s in limb.spheres.items() if np.allclose(s.center, limb.spheres[part].center)
        }
    raw = target
    for _ in range(400):
        if part in limb.spheres:
            pts = _sphere_points(limb.spheres[part], raw)
        else:
            f = next(f for f in limb.frustums if f.name == part)
            pts = _frustum_points(*limb.frustum_ends(f), raw)
        keep = pts[_visible(limb, pts, own)]
        if len(keep) >= target:
            if len(keep) > target:  # drop the extras evenly
                idx = np.round(np.linspace(0, len(keep) - 1, target)).astype(int)
                keep = keep[idx]
            return keep
        raw += max(1, (target - len(keep)) // 2)
    raise SimulationError(  # a forearm turned 86-90 deg about y lays the fist on the shoulder
        f"the {part} lies inside the rest of the {limb.name}, so no force map can be placed "
        "on it: the rotation folds the limb onto itself; rotate it less"
    )


def limb_points(limb: Limb) -> LimbPoints:
    """The force-map sites: 300 on the arm, 400 on the leg, each tagged with its part."""
    names = limb.segment_names
    pts, seg = [], []
    for i, name in enumerate(names):
        p = _part_points(limb, name, limb.points_per_part[name])
        pts.append(p)
        seg.append(np.full(len(p), i, dtype=np.uint32))
    return LimbPoints(
        limb=limb.name,
        points=np.concatenate(pts).astype(np.float64),
        segment=np.concatenate(seg),
        segment_names=names,
    )


def segment_of(limb: Limb, p: np.ndarray) -> np.ndarray:
    """Index into `limb.segment_names` of the part nearest to each point (P, 3)."""
    geometry = limb.geometry
    d = geometry.part_distances(p)[geometry.segment_rows]
    return d.argmin(axis=0).astype(np.uint32)
