"""Procedural garment meshes: a gown (sleeve tube, body a flange round the armhole) and shorts.

Meshes are built in the garment frame: the gripper at the origin, the garment's
leading opening (armhole, waist) at x = 0 and the rest trailing along +x, z up.
The opening that receives the limb leads, as when dressing: the fist enters the
armhole and leaves through the cuff; the foot enters the waist and leaves
through a leg opening. Coarse on purpose (about 200 vertices): fine enough
to fold and catch on a fist or heel, coarse enough for real time in pybullet.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from dresslog.errors import SimulationError
from dresslog.spec import SIMULATOR, Task, task_of


@dataclass(frozen=True)
class Garment:
    """A triangle mesh with the vertices the gripper holds and the openings' rims."""

    name: str
    vertices: np.ndarray  # (V, 3) float64, garment frame
    triangles: np.ndarray  # (F, 3) uint32
    gripped: np.ndarray  # vertex indices anchored to the end effector
    #: the leading opening (armhole / waist) the limb must pass through
    entry_rim: np.ndarray
    #: the opening the limb leaves through (cuff / the +y leg's opening)
    exit_rim: np.ndarray
    #: the cloth's stretch stiffness where the spec leaves it to the garment
    #: (`SimParams.elastic_stiffness` None)
    elastic_stiffness: float = 40.0
    #: the cloth's friction on the limb where the spec leaves it to the garment
    #: (`SimParams.friction` None)
    friction: float = 0.5

    def write_obj(self, directory: str | Path) -> Path:
        """Write the mesh as a Wavefront .obj (what pybullet's loadSoftBody reads)."""
        path = Path(directory) / f"{self.name}.obj"
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in self.vertices]
        lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in self.triangles]
        path.write_text("\n".join(lines) + "\n")
        return path


def _strip(a: np.ndarray, b: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles joining two closed rings of equal length (vertex index arrays)."""
    n = len(a)
    tris = []
    for i in range(n):
        j = (i + 1) % n
        tris += [(a[i], a[j], b[j]), (a[i], b[j], b[i])]
    return tris


def _doubling_strip(a: np.ndarray, b: np.ndarray) -> list[tuple[int, int, int]]:
    """Triangles joining a closed ring to one with twice its vertices (b[2i] beside a[i])."""
    n = len(a)
    tris = []
    for i in range(n):
        j = (i + 1) % n
        b0, b1, b2 = b[2 * i], b[2 * i + 1], b[(2 * i + 2) % (2 * n)]
        tris += [(a[i], b0, b1), (a[i], b1, a[j]), (a[j], b1, b2)]
    return tris


def _circle(verts: list, x: float, r: float, n: int, zc: float) -> np.ndarray:
    """Append n vertices on a circle of radius r in the plane at x, centre (y 0, z zc)."""
    start = len(verts)
    for i in range(n):
        a = 2 * np.pi * i / n
        verts.append((x, r * np.sin(a), r * np.cos(a) + zc))
    return np.arange(start, start + n)


def _top(ring: np.ndarray, verts: list, count: int) -> list[int]:
    z = np.array([verts[i][2] for i in ring])
    return [int(ring[i]) for i in np.argsort(-z)[:count]]


def gown(
    armhole: float = 0.11,
    cuff: float = 0.065,
    length: float = 0.20,
    ring: int = 14,
    rows: int = 8,
    body: tuple[float, ...] = (0.16, 0.22, 0.28),
    pinch: int | None = 2,
    grip_nodes: int = 5,
) -> Garment:
    """A hospital-gown sleeve (a tube tapering from armhole to cuff) and the gown's body.

    The body is a flange around the armhole, in the armhole's plane, out to
    `body[-1]` m (rings at the radii in `body`; the outer ones twice as dense): the
    part of the gown that meets the arm when the hand misses the sleeve. The paper
    chose its arm offsets so that garment and limb always touch; a bare sleeve
    misses the arm entirely in about a quarter of trials.

    `pinch`: the gripper holds the top `grip_nodes` nodes of the first `pinch` rings, a
    pinch at the shoulder seam as a robot's gripper holds a gown (v9: five nodes, 20 cm
    of the armhole's rim, which keeps the hanging armhole a slit the fist can find); None
    holds the top of every ring, the whole top seam, so the sleeve stays a rigid hoop (v8).
    """
    verts: list[tuple[float, float, float]] = []
    rings = [
        _circle(verts, length * j / (rows - 1), armhole + (cuff - armhole) * j / (rows - 1),
                ring, -armhole)
        for j in range(rows)
    ]  # fmt: skip
    tris = [t for j in range(rows - 1) for t in _strip(rings[j], rings[j + 1])]
    held = rings if pinch is None else rings[:pinch]
    gripped = sorted(i for r in held for i in _top(r, verts, grip_nodes))
    inner = rings[0]
    for k, r in enumerate(body):
        outer = _circle(verts, 0.0, r, 2 * ring if k else ring, -armhole)
        tris += (_strip if len(outer) == len(inner) else _doubling_strip)(inner, outer)
        inner = outer
    return Garment(
        name="gown",
        vertices=np.array(verts),
        triangles=np.array(tris, dtype=np.uint32),
        gripped=np.array(gripped),
        entry_rim=rings[0],
        exit_rim=rings[-1],
    )


def shorts(
    waist_radius: float = 0.14,
    leg_radius: float = 0.09,
    leg_spacing: float = 0.06,
    waist_length: float = 0.06,
    leg_length: float = 0.20,
    n: int = 8,
    m: int = 6,
    waist_rows: int = 3,
    leg_rows: int = 6,
    pinch: bool = True,
    elastic_stiffness: float = 80.0,
) -> Garment:
    """Shorts: a waist tube whose cross-section splits, at a crotch seam, into two leg tubes.

    Leg A (+y) is the one the leg should go through. The two leg circles (centres
    y = +-leg_spacing, radius leg_radius) overlap; their crossing points F (top)
    and B (bottom) start a seam of m-1 shared vertices, so the mesh is one piece.

    `pinch`: the gripper holds the waistband's top three nodes at its opening, as a
    robot's gripper pinches it (v9); False holds the top of every waist ring (v8).
    `elastic_stiffness`: the shorts' heavier cloth and waistband stretch half as much
    as the gown's under the same pull (v9: 80; v8: 40).
    """
    r, a, rw = leg_radius, leg_spacing, waist_radius
    zc = -rw
    h = np.sqrt(r * r - a * a)
    phi_f = np.arctan2(h, -a)  # angle of F seen from leg A's centre
    verts: list[tuple[float, float, float]] = []

    def add(x: float, y: float, z: float) -> int:
        verts.append((x, y, z))
        return len(verts) - 1

    def leg_point(side: int, phi: float) -> tuple[float, float]:
        return side * (a + r * np.cos(phi)), zc + r * np.sin(phi)

    # outer loop at the crotch: F, A outer arc, B, B outer arc (2n points)
    outer_phi = [phi_f - 2 * phi_f * k / n for k in range(n + 1)]  # F .. B around +y
    outer_yz = [leg_point(1, p) for p in outer_phi]
    outer_yz += [leg_point(-1, p) for p in outer_phi[::-1][1:-1]]  # B .. F around -y
    waist_ang = [np.arctan2(z - zc, y) for y, z in outer_yz]
    x_seam = waist_length + 0.04
    waist_rings = []
    for j in range(waist_rows):
        x = waist_length * j / max(1, waist_rows - 1)
        waist_rings.append(
            np.array([add(x, rw * np.cos(t), zc + rw * np.sin(t)) for t in waist_ang])
        )
    seam_outer = np.array([add(x_seam, y, z) for y, z in outer_yz])
    f_idx, b_idx = int(seam_outer[0]), int(seam_outer[n])
    seam = [add(x_seam, 0.0, zc - h + 2 * h * k / m) for k in range(1, m)]  # B -> F
    ring_a0 = np.array([*seam_outer[: n + 1], *seam])
    ring_b0 = np.array([b_idx, *seam_outer[n + 1 :], f_idx, *seam[::-1]])
    tris = [t for j in range(waist_rows - 1) for t in _strip(waist_rings[j], waist_rings[j + 1])]
    tris += _strip(waist_rings[-1], seam_outer)
    inner_phi = [-phi_f - (2 * np.pi - 2 * phi_f) * k / m for k in range(1, m)]
    legs = {}
    for side, first in ((1, ring_a0), (-1, ring_b0)):
        phis = outer_phi + inner_phi
        if side == -1:  # leg B's ring starts at B and runs around -y to F
            phis = outer_phi[::-1] + [-p for p in inner_phi]
        rings = [first]
        for j in range(1, leg_rows):
            x = x_seam + leg_length * j / (leg_rows - 1)
            pts = [leg_point(side, p) for p in phis]
            rings.append(np.array([add(x, y, z) for y, z in pts]))
        for j in range(leg_rows - 1):
            tris += _strip(rings[j], rings[j + 1])
        legs[side] = rings
    # only the waistband is held: anchoring the legs too makes the anchors fight
    gripped = {i for r_ in waist_rings[: 1 if pinch else None] for i in _top(r_, verts, 3)}
    v = np.array(verts)
    v[:, 1] -= a  # put leg A's axis on y = 0
    return Garment(
        name="shorts",
        vertices=v,
        triangles=np.array(tris, dtype=np.uint32),
        gripped=np.array(sorted(gripped)),
        entry_rim=waist_rings[0],
        exit_rim=legs[1][-1],
        elastic_stiffness=elastic_stiffness,
    )


#: Each simulator version's garments where they differ from the constructors' defaults,
#: which are v9's (docs/simulator.md gives v9's sizes and sources). v10's shorts have
#: leg openings 50 cm round (v9: 57 cm), a slimmer pair's, so that with v10's higher
#: path the waist catches on the foot in a quarter of trials, as the paper's often do
#: (docs/simulator.md, "v10").
_SIZES: dict[int, dict[Task, dict[str, Any]]] = {
    8: {
        Task.GOWN: {"armhole": 0.10, "cuff": 0.10, "length": 0.27, "rows": 10, "pinch": None,
                    "grip_nodes": 3},
        Task.SHORTS: {"waist_radius": 0.17, "leg_radius": 0.10, "leg_spacing": 0.07,
                      "waist_length": 0.08, "leg_length": 0.25, "pinch": False,
                      "elastic_stiffness": 40.0},
    },
    10: {Task.SHORTS: {"leg_radius": 0.08}},
}  # fmt: skip


#: v10's gown slides on the limb at this friction (v9 and before: 0.5), so that the
#: armhole's rim, pulled up beside the upper arm, slides round the elbow instead of
#: hooking under the forearm (docs/simulator.md, "v10").
V10_GOWN_FRICTION = 0.3


def garment_for(task: Task | str, simulator: int = SIMULATOR) -> Garment:
    """The task's garment as simulator version `simulator` makes it."""
    task = task_of(task, SimulationError)
    sizes = _SIZES.get(simulator, {}).get(task, {})
    garment = gown(**sizes) if task is Task.GOWN else shorts(**sizes)
    if simulator >= 10 and task is Task.GOWN:
        garment = replace(garment, friction=V10_GOWN_FRICTION)
    return garment
