"""The speeds, limb rotations, limb offsets and durations of a model's training trials,
and of others.

`sweep` shades the model's on its plot; `eval` says when a dataset's lie outside them,
and `infer` when a simulated trial's does, so an error measured on rotated, faster,
displaced or longer trials is not read as the model's fit. Offsets and durations are
named only when outside: every folder `generate` makes draws the offsets over the
paper's ranges, and most keep the spec's 7 s.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from dresslog.model.files import ModelCard
from dresslog.spec import (
    OFFSET_RANGES,
    SIMULATOR_NAME,
    SPEED_RANGE,
    LimbRotation,
    RotationRange,
    Task,
    TrialSpec,
    oldest_first,
    simulator_fields,
    simulator_name,
    simulator_of,
)

#: the spec fields `describe` says when fixed for every trial (offsets and durations are
#: named only when outside)
DESCRIBED_FIELDS = ("speed", "limb_rotation")
#: a speed span, m/s (low == high for one fixed speed)
Speeds = tuple[float, float]
#: a rotation span about an axis, degrees (low == high for one fixed rotation)
Turn = tuple[str, float, float]
#: the duration of a trial whose spec does not set one, s
DURATION: float = TrialSpec.model_fields["duration"].default
#: the simulator a folder's trials come from when its overrides do not say: v7, whose
#: folders and cards saved no `sim` fields
UNSAID = "v7"


def simulator_in(overrides: Mapping[str, Any]) -> str:
    """The simulator version (`v10` ... `v7`) of trials made with these spec `overrides`."""
    return simulator_of(overrides.get("sim"))


#: a limb offset box, m: (low, high) along x, y and z (low == high for a fixed offset)
Box = tuple[tuple[float, float], ...]


@dataclass(frozen=True)
class Conditions:
    """What a set of trials held: speed spans, rotation spans, whether some trials had
    the limb unturned (a span through 0 deg holds those too), limb offset boxes,
    durations (s), and the simulator versions that made them (`simulator_of`)."""

    speeds: tuple[Speeds, ...]
    rotations: tuple[Turn, ...]
    unturned: bool
    offsets: tuple[Box, ...]
    durations: tuple[float, ...]
    simulators: tuple[str, ...] = (UNSAID,)

    def describe(self) -> str:
        """`speeds 0.1-0.15 m/s, the limb never turned`, as a sweep's line and eval say it."""
        return describe(self.speeds, self.rotations, unturned=self.unturned)

    def outside(self, trained: Conditions) -> list[str]:
        """What of these conditions `trained` does not cover, one phrase each."""
        missing = [
            f"speed {_span(lo, hi)} m/s"
            for lo, hi in self.speeds
            if not any(a <= lo and hi <= b for a, b in trained.speeds)
        ]
        if self.unturned and not trained.holds_unturned:
            missing.append("the limb unturned")
        missing += [
            f"rotation about {axis} {_turn(lo, hi)} deg"
            for axis, lo, hi in self.rotations
            if not trained.turns(axis, lo, hi)
        ]
        missing += [
            _offset_outside(box, trained.offsets)
            for box in self.offsets
            if not any(_within(box, other) for other in trained.offsets)
        ]
        if max(self.durations) > (longest := max(trained.durations)):  # shorter: a prefix
            missing.append(f"duration {max(self.durations):g} s (trained on {longest:g} s)")
        missing += [
            f"simulator {v} (trained on {' and '.join(trained.simulators)})"
            for v in self.simulators
            if v not in trained.simulators
        ]
        return missing

    @property
    def holds_unturned(self) -> bool:
        """Whether some trials had the limb unturned: 0 deg about any axis counts."""
        return self.unturned or any(lo <= 0 <= hi for _, lo, hi in self.rotations)

    def turns(self, axis: str, low: float, high: float) -> bool:
        """Whether one rotation span here holds `low`...`high` about `axis`."""
        return any(a == axis and lo <= low and high <= hi for a, lo, hi in self.rotations)


def describe(speeds: Iterable[Speeds], rotations: Iterable[Turn], *, unturned: bool) -> str:
    """Speed and rotation spans in words: `speeds 0.1-0.15 m/s; the limb turned about z
    -15...+15 deg` (`unturned or turned` when some trials had no rotation), or `...,
    the limb never turned`."""
    said = ", ".join(_span(lo, hi) for lo, hi in speeds)
    turned = ", ".join(f"about {axis} {_turn(lo, hi)}" for axis, lo, hi in rotations)
    if not turned:
        return f"speeds {said} m/s, the limb never turned"
    return f"speeds {said} m/s; the limb {'unturned or ' * unturned}turned {turned} deg"


def _within(box: Box, other: Box) -> bool:
    return all(a <= lo and hi <= b for (lo, hi), (a, b) in zip(box, other, strict=True))


def _offset_outside(box: Box, trained: tuple[Box, ...]) -> str:
    """`limb offset y +0.35 m (trained on y -0.2...+0.2)`: the axes on which `box` leaves
    the span of every trained box (all three if none alone holds it)."""
    hull = [(min(b[k][0] for b in trained), max(b[k][1] for b in trained)) for k in range(3)]
    out = [k for k in range(3) if box[k][0] < hull[k][0] or box[k][1] > hull[k][1]] or [0, 1, 2]
    said = ", ".join(f"{'xyz'[k]} {_metres(*box[k])}" for k in out)
    drew = ", ".join(f"{'xyz'[k]} {_metres(*hull[k])}" for k in out)
    return f"limb offset {said} m (trained on {drew})"


def _span(low: float, high: float) -> str:
    return f"{low:g}" if low == high else f"{low:g}-{high:g}"


def _turn(low: float, high: float) -> str:
    return f"{low:+g}" if low == high else f"{low:+g}...{high:+g}"


def _metres(low: float, high: float) -> str:
    return f"{low:+.3g}" if low == high else f"{low:+.3g}...{high:+.3g}"


def folder_conditions(
    task: Task, overrides: Mapping[str, Any] | None, rotation_range: RotationRange | None
) -> Conditions:
    """The conditions of one folder's trials from what its manifest fixed and drew. None
    for `overrides` (a card before format 4, or one made by hand) reads as `generate`'s
    defaults: speeds drawn over the task's range, no rotation, the current simulator."""
    fixed = overrides or {}
    speed = fixed.get("speed")
    rotations: list[Turn] = []
    if "limb_rotation" in fixed:
        turned = LimbRotation.model_validate(fixed["limb_rotation"])
        if turned.degrees:  # 0 deg is the unturned limb
            rotations.append((turned.axis, turned.degrees, turned.degrees))
    if rotation_range is not None:
        rotations.append((rotation_range.axis, rotation_range.low, rotation_range.high))
    # a card that names no folder's fields (before format 4, or made by hand) cannot
    # say; it reads as `generate`'s defaults, the current simulator's
    simulator = SIMULATOR_NAME if overrides is None else simulator_in(fixed)
    if (offset := fixed.get("limb_offset")) is None:  # drawn over its simulator's ranges
        ranges = OFFSET_RANGES[simulator_fields(simulator)["simulator"]]
        box = tuple((-r, r) for r in ranges[task])
    else:
        box = tuple((float(v), float(v)) for v in offset)
    return Conditions(
        speeds=(SPEED_RANGE[task] if speed is None else (speed, speed),),
        rotations=tuple(rotations),
        unturned=not rotations,
        offsets=(box,),
        durations=(float(fixed.get("duration", DURATION)),),
        simulators=(simulator,),
    )


def combined(conditions: Iterable[Conditions]) -> Conditions:
    """The conditions of several folders' trials together, each span once, sorted."""
    parts = list(conditions)
    return Conditions(
        speeds=tuple(sorted({s for c in parts for s in c.speeds})),
        rotations=tuple(sorted({r for c in parts for r in c.rotations})),
        unturned=any(c.unturned for c in parts),
        offsets=tuple(sorted({b for c in parts for b in c.offsets})),
        durations=tuple(sorted({d for c in parts for d in c.durations})),
        simulators=tuple(sorted({v for c in parts for v in c.simulators}, key=oldest_first)),
    )


def trained_conditions(card: ModelCard) -> Conditions:
    """The conditions of every folder the model's weights have seen
    (`ModelCard.trained_folders`), an initial model's included."""
    return combined(
        folder_conditions(card.task, folder.overrides, folder.rotation_range)
        for folder in card.trained_folders()
    )


def spec_conditions(spec: TrialSpec) -> Conditions:
    """The conditions of one simulated trial, from its spec."""
    fixed = {"speed": spec.speed, "limb_rotation": spec.limb_rotation.model_dump(),
             "limb_offset": spec.limb_offset, "duration": spec.duration,
             "sim": simulator_fields(simulator_name(spec.sim))}  # fmt: skip
    return folder_conditions(spec.task, fixed, None)


def training_warning(spec: TrialSpec, card: ModelCard) -> str | None:
    """What `infer` and `record --live` warn of for a simulated trial the model was not
    trained on (`outside the model's training (speeds 0.1-0.15 m/s, the limb never
    turned): speed 0.2 m/s, so ...`), or None for one within its training."""
    trained = trained_conditions(card)
    if not (outside := spec_conditions(spec).outside(trained)):
        return None
    return (
        f"outside the model's training ({trained.describe()}): {'; '.join(outside)}, "
        "so the estimate measures how it generalises"
    )
