"""How a trial ended: dressed, missed, or caught (and where), from what the physics did.

Simulator v9 judges a trial as a person watching it would:

- caught: while the gripper moves, the garment is held on the fist or elbow (gown), or
  on the heel or foot (shorts): for `HOLD_S` or longer the gripper pulls with more than
  `CAUGHT_FORCE` while most of the limb's force lies there. The paper's Figs. 7 and 8.
  A catch that lets go, with the opening then past the joint, is dressed after all;
- dressed: the garment's opening encircles the limb past the joint it must pass (the
  gown's armhole over the wrist and up to the elbow; the shorts' waist over the foot, on
  the shin or thigh), and nothing holds it at the end;
- missed: neither.

v8 and before judged by the final gripper force alone (`decide_outcome_v8`), kept for
their specs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dresslog.limb import Limb, limb_sdf
from dresslog.sim.garments import Garment
from dresslog.spec import Outcome, Task

#: Tared gripper force (N) that means the garment is held back.
CAUGHT_FORCE = 2.0
#: How long (s) the garment must be held, gripper moving, to count as caught.
HOLD_S = 0.3
#: Share of the limb's force on one catching part for the garment to be held there.
HELD_SHARE = 0.5
#: Gripper speed (m/s) above which it is pulling.
MOVING = 0.01
#: Limb points this near (m) the elbow's centre count as the elbow: the crook of the arm
#: where the forearm and upper arm meet holds a sleeve as the elbow's sphere does.
ELBOW_REACH = 0.09
#: The parts a garment catches on, by task, and the name each catch goes by.
CATCH_PARTS = {
    Task.GOWN: {"fist": "fist", "elbow": "elbow"},
    Task.SHORTS: {"heel": "heel", "heel_link": "heel", "toe": "foot", "foot": "foot",
                  "ankle": "foot"},
}  # fmt: skip


def _winding(rim: np.ndarray, origin: np.ndarray, axis: np.ndarray) -> float:
    """How many times the closed rim polygon winds around the line (origin, axis)."""
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    d = rim - origin
    ang = np.arctan2(d @ e2, d @ e1)
    step = np.diff(np.concatenate([ang, ang[:1]]))
    step = (step + np.pi) % (2 * np.pi) - np.pi
    return float(abs(step.sum()) / (2 * np.pi))


def _encircles(
    limb: Limb, rim: np.ndarray, prox: np.ndarray, dist: np.ndarray, reach: tuple[float, float]
) -> bool:
    """Whether the rim winds round the segment prox->dist, its centre within `reach`
    (fractions of the segment from prox) and nearer the limb's surface than the rim's
    own radius (a rim round the axis's extension past a far-off limb holds nothing)."""
    length = float(np.linalg.norm(dist - prox))
    axis = (dist - prox) / length
    centre = rim.mean(axis=0)
    along = float((centre - prox) @ axis) / length
    radius = float(np.linalg.norm(rim - centre, axis=1).mean())
    holds_limb = float(limb_sdf(limb, centre[None])[0]) < radius
    return _winding(rim, prox, axis) > 0.5 and reach[0] <= along <= reach[1] and holds_limb


def decide_outcome_v8(
    task: Task, limb: Limb, garment: Garment, verts: np.ndarray, final_force: float
) -> Outcome:
    """v8 and before: dressed if the entry opening encircles the limb past the hand or
    foot; else caught if the gripper still feels a pull at the end, else missed."""
    s = limb.spheres
    prox, dist = (s["elbow"], s["wrist"]) if task is Task.GOWN else (s["hip"], s["ankle"])
    if _encircles(limb, verts[garment.entry_rim], prox.center, dist.center, (-np.inf, 0.95)):
        return Outcome.DRESSED
    return Outcome.CAUGHT if final_force > CAUGHT_FORCE else Outcome.MISSED


def passed_the_joint(task: Task, limb: Limb, garment: Garment, verts: np.ndarray) -> bool:
    """Whether the opening is past the joint it must pass: the gown's armhole over the
    fist and wrist, drawn up the forearm to its elbow half or onto the upper arm (the
    paper's "pulled up the forearm"); the shorts' waist over the foot and ankle, round the
    shin or thigh."""
    s = limb.spheres
    rim = verts[garment.entry_rim]
    if task is Task.GOWN:
        elbow = s["elbow"].center
        return _encircles(limb, rim, elbow, s["wrist"].center, (-0.3, 0.5)) or _encircles(
            limb, rim, elbow, s["shoulder"].center, (0.0, 1.2)
        )
    return _encircles(limb, rim, s["hip"].center, s["knee"].center, (-0.2, 1.0)) or (
        _encircles(limb, rim, s["knee"].center, s["ankle"].center, (0.0, 0.85))
    )


@dataclass
class CatchWatch:
    """Watches each recorded step for the garment held on a catching part while the
    gripper pulls; `caught_on` names the part of the longest such hold."""

    task: Task
    limb: Limb
    record_hz: int
    _run: int = 0
    _run_parts: dict[str, float] = field(default_factory=dict)
    _holds: list[tuple[int, dict[str, float]]] = field(default_factory=list)

    def __post_init__(self) -> None:
        catch = CATCH_PARTS[self.task]
        # each limb part's catch name ("" for none), looked up once, indexed per step
        self._labels = np.array([catch.get(n, "") for n in self.limb.segment_names], object)
        self._elbow = self.limb.spheres["elbow"].center if self.task is Task.GOWN else None

    def step(
        self, speed: float, force: float, positions: np.ndarray, segments: np.ndarray,
        mags: np.ndarray,
    ) -> None:  # fmt: skip
        """One recorded step: gripper speed and force, the contacts' places, parts, forces."""
        pulling = speed > MOVING and force > CAUGHT_FORCE
        part = self._held_on(positions, segments, mags) if pulling else None
        if part is not None:
            self._run += 1
            self._run_parts[part] = self._run_parts.get(part, 0.0) + force
            return
        self._close()

    def _held_on(self, positions: np.ndarray, segments: np.ndarray, mags: np.ndarray) -> str | None:
        total = float(mags.sum())
        if total <= 0:
            return None
        labels = self._labels[segments]  # a copy: the elbow's reach is marked on it
        if self._elbow is not None:
            near = np.linalg.norm(positions - self._elbow, axis=1) < ELBOW_REACH
            labels[near & (labels == "")] = "elbow"
        best, share = "", 0.0
        for name in set(labels) - {""}:
            s = float(mags[labels == name].sum()) / total
            if s > share:
                best, share = str(name), s
        return best if share >= HELD_SHARE else None

    def _close(self) -> None:
        if self._run >= round(HOLD_S * self.record_hz):
            self._holds.append((self._run, self._run_parts))
        self._run, self._run_parts = 0, {}

    def finish(self) -> str | None:
        """The part the garment was held on longest, or None if it never was."""
        self._close()
        if not self._holds:
            return None
        _, parts = max(self._holds, key=lambda h: h[0])
        return max(parts, key=lambda k: parts[k])


def judge(
    task: Task, limb: Limb, garment: Garment, verts: np.ndarray, final_force: float,
    caught_on: str | None,
) -> Outcome:  # fmt: skip
    """v9's outcome from the garment at the end, the final gripper force and the catch."""
    dressed = passed_the_joint(task, limb, garment, verts)
    if caught_on is not None and (not dressed or final_force > CAUGHT_FORCE):
        return Outcome.CAUGHT
    return Outcome.DRESSED if dressed else Outcome.MISSED
