"""Trial specification and metadata: what a trial was asked to be and what it became.

A `TrialSpec` fully determines a simulated trial (same spec, same bytes); a
`TrialMetadata` is what a recording carries about itself: the spec (or, for a
converted log, its source), the outcome and the software that wrote it.
These are pydantic models: built directly with a bad value
(`TrialSpec(task="gown", speed=5)`) they raise pydantic's `ValidationError`, as pydantic
models do; `dresslog.sim.random_spec` is the library's way to a spec and raises
`SimulationError` instead.
`task_of(value, error)` turns a task name into a `Task`, or raises the caller's
`DresslogError` subclass naming the two tasks.
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import StrEnum
from typing import Annotated, Any, Final, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    FiniteFloat,
    StrictInt,
    ValidationInfo,
    field_validator,
    model_validator,
)

from dresslog.errors import DresslogError

Vec3 = tuple[FiniteFloat, FiniteFloat, FiniteFloat]
#: Longest trial a spec accepts, s: an hour at 100 Hz (a typo like 1e9 would need TBs).
MAX_DURATION = 3600.0
#: How far (m) the limb may move from its nominal pose along each axis: the paper's
#: range is +-0.2 m; a few metres away (a limb the garment never reaches) still simulates.
MAX_OFFSET = 10.0
#: Fastest end-effector speed a spec accepts, m/s (the paper's: 0.10-0.20).
MAX_SPEED = 1
#: Largest turn of the distal limb part either way, degrees: a joint's range, not a full turn.
MAX_ROTATION = 90
#: The sensor is tared over the last this many seconds of the settling, after the wind.
TARE_S = 0.1
#: Validation context for specs read back from a recording or a manifest: the checks that
#: keep a simulation sound are for specs about to run, and a trial already made stays
#: readable (`SimParams(settle_s=0.3, wind_s=0.3)` recorded before they were added).
RECORDED: Final = {"recorded": True}


def _recorded(info: ValidationInfo) -> bool:
    return isinstance(info.context, dict) and info.context.get("recorded") is True


class Task(StrEnum):
    """The two dressing tasks of the paper; each has its own limb and garment."""

    GOWN = "gown"
    SHORTS = "shorts"


#: End-effector speeds (m/s) drawn per trial, the paper's ranges (`random_spec`): what a
#: model trained on `generate`'s defaults has seen, which `infer` checks a trial against.
SPEED_RANGE = {Task.GOWN: (0.10, 0.15), Task.SHORTS: (0.15, 0.20)}

#: The simulator version every command and the library record with when not told:
#: v9's garments drape, are held by a pinch, and are drawn up the arm or the leg
#: (docs/simulator.md). v8 (and v7, v8 with the constraint's wrench) stay reachable by
#: name for old data: `SimParams(simulator=8)`.
SIMULATOR: Final[Literal[8, 9]] = 9

#: Limb offsets (m) drawn per trial, +- these per axis, by simulator version
#: (`random_spec`). The paper gives (x, y, z) in its frame, whose y is up (`PAPER_AXES`):
#: v9 maps them onto ours (z up), so the gown's arm moves +-20 cm up and down and +-10 cm
#: sideways. v8 and before applied the paper's numbers to our axes unmapped (the arm
#: +-20 cm sideways); kept so that their seeds draw the specs they always drew.
OFFSET_RANGES = {
    8: {Task.GOWN: (0.05, 0.20, 0.10), Task.SHORTS: (0.05, 0.075, 0.05)},
    9: {Task.GOWN: (0.05, 0.10, 0.20), Task.SHORTS: (0.05, 0.05, 0.075)},
}
OFFSET_RANGES[10] = OFFSET_RANGES[9]  # v10 changed the paths and garments, not the limb
#: The current simulator's offsets, what `generate`'s folders draw.
OFFSET_RANGE = OFFSET_RANGES[SIMULATOR]


def task_of(value: Task | str, error: type[DresslogError]) -> Task:
    """`value` as a Task; otherwise `error` (the caller's family) naming it and the tasks."""
    try:
        return Task(value)
    except ValueError:
        raise error(f"task {value!r} is not one of {', '.join(Task)}") from None


class Outcome(StrEnum):
    """How a trial ended, decided from where the garment ends up on the limb."""

    DRESSED = "dressed"
    MISSED = "missed"
    CAUGHT = "caught"
    FAILED = "failed"
    UNKNOWN = "unknown"


#: The paper's name for each of our axes. Its frame (PhysX) has y up, ours z up, so our
#: y is its Z and our z its Y; a rotation's sign agrees (our +y, like its +Z, raises the
#: fist towards the gripper and steepens the foot; our z, like its Y, swings the limb
#: part sideways).
PAPER_AXES = {"x": "X", "y": "Z", "z": "Y"}


#: A limb part's rotation axis (ours: z up) and angle: a joint's range, not a full turn
#: (999 degrees is a typo, not a pose).
Axis = Literal["x", "y", "z"]
Degrees = Annotated[float, Field(ge=-MAX_ROTATION, le=MAX_ROTATION)]


class LimbRotation(BaseModel):
    """A rotation of the distal limb part: forearm about the elbow, foot about the ankle.

    The axes are ours (z up); `PAPER_AXES` names the paper's axis for each.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    axis: Axis = "z"
    degrees: Degrees = 0.0


class RotationRange(BaseModel):
    """Rotations about `axis` drawn per trial, uniformly from `low` to `high` degrees: a
    dataset across a span of conditions (to train a model for all of them), not one."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    axis: Axis
    low: Degrees
    high: Degrees

    @model_validator(mode="after")
    def _a_span(self) -> RotationRange:
        if not self.low < self.high:  # equal bounds are one condition: --rotation's
            raise ValueError(f"low {self.low:g} must be below high {self.high:g}")
        return self

    def draw(self, seed: int) -> LimbRotation:
        """The rotation of the trial with `seed`, from a stream of its own: the rest of
        the trial's spec is the one `seed` draws without a range."""
        import numpy as np  # lazily: `info` and `infer` load this module at start-up

        degrees = np.random.default_rng((seed, _ROTATION_STREAM)).uniform(self.low, self.high)
        return LimbRotation(axis=self.axis, degrees=float(degrees))

    def __str__(self) -> str:
        return f"{self.axis} {self.low:+g}...{self.high:+g} deg"


#: Keys the rotation's random stream apart from the seed's own (offset, speed, path).
_ROTATION_STREAM = 1


class SimParams(BaseModel):
    """Physics settings of the pybullet simulation (SI units)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    simulator: Literal[8, 9, 10] = Field(
        SIMULATOR,
        description="the garments, the grip and the paths: 9 drapes and is held by a pinch; "
        "10 draws the gown's sleeve up beside the upper arm and the shorts' waist higher "
        "over the foot; 8 is simulator v8 and before "
        "(v7: 8 with the constraint's wrench)",
    )
    physics_hz: int = Field(300, gt=0, description="physics steps per second")
    record_hz: int = Field(100, gt=0, description="recorded measurements per second")
    settle_s: float = Field(1.0, ge=0, description="time the garment hangs before the motion")
    wind_s: float = Field(0.3, ge=0, description="duration of the random perturbing force")
    wind_accel: float = Field(2.0, ge=0, description="peak random acceleration per vertex, m/s^2")
    garment_mass: float = Field(0.25, gt=0, description="kg")
    elastic_stiffness: float | None = Field(
        None,
        gt=0,
        description="the springs' stretch stiffness; None takes the garment's own (v9: the "
        "gown 40, the heavier shorts 80; v8: 40 for both)",
    )
    damping_stiffness: float = Field(
        0.1,
        ge=0,
        description="spring damping, in all directions: v8's 1.0 held a sleeve open as a "
        "rigid tube; 0.1 lets it drape and still comes to rest",
    )
    bending_stiffness: float = Field(
        0.0, ge=0, description="bending springs' stiffness; 0 has none, so the cloth folds (v9)"
    )
    friction: float | None = Field(
        None,
        ge=0,
        description="the cloth's friction on the limb; None takes the garment's own (v10: "
        "the gown 0.3, whose sleeve then slides round the elbow; otherwise 0.5)",
    )
    collision_margin: float = Field(0.006, gt=0)
    contact_spread: int = Field(
        3,
        ge=0,
        description="a cloth node's contact force is spread over its triangles, sampled at "
        "this many intervals per edge, where they lie on the limb; 0 keeps it at the node "
        "(simulator v6 and before)",
    )
    contact_reach: float = Field(
        0.012, ge=0, description="cloth samples this close to the limb surface share its force, m"
    )
    grip_clearance: float = Field(
        0.01,
        ge=0,
        description="the gripper and the garment edge it holds keep this far off the limb, m",
    )
    max_grip_lift: float = Field(
        0.25, ge=0, description="the gripper stops where keeping clear would lift it more, m"
    )
    lift_smoothing: float = Field(
        0.25, ge=0, description="the gripper spreads a change of its lift rate over this long, s"
    )
    max_limb_force: float = Field(200.0, gt=0, description="instability guard, N")
    wrench_from: Literal["constraint", "momentum"] = Field(
        "momentum",
        description="the gripper's wrench as its constraint reports it (a changing share of "
        "the garment's load), or as the garment's momentum balance leaves it of gravity and "
        "the limb's contact forces",
    )

    @model_validator(mode="before")
    @classmethod
    def _defaults_of_its_version(cls, data: object, info: ValidationInfo) -> object:
        """Fields left unsaid take the defaults of the spec's simulator version.

        A recorded spec (a trial's, a manifest's) that names no version is from v8 or
        before, which saved every field but a constraint's `wrench_from` (v7); asked for
        by name, `simulator=8` brings v8's cloth, grip lift and wrench.
        """
        if not isinstance(data, dict):
            return data
        if "simulator" not in data and _recorded(info):
            data = {"simulator": 8, "wrench_from": "constraint", **data}
        if data.get("simulator") == 8:
            data = {**V8_DEFAULTS, **data}
        return data

    def settle_steps(self) -> tuple[int, int, int]:
        """Physics steps of the settling, of the wind at its start and of the tare at its end."""
        hz = self.physics_hz
        return round(self.settle_s * hz), round(self.wind_s * hz), max(1, round(TARE_S * hz))

    @model_validator(mode="after")
    def _tare_after_the_wind(self, info: ValidationInfo) -> SimParams:
        settle, wind, tare = self.settle_steps()  # counted as the simulator counts them
        if settle - wind < tare and not _recorded(info):  # the tare took in the wind
            raise ValueError(
                f"settle_s must leave {TARE_S:g} s after the wind (wind_s {self.wind_s:g}) "
                f"to tare the sensor with the garment hanging still: {self.wind_s + TARE_S:.4g} "
                "or more"
            )
        return self


#: What simulator v8 used where v9 changed a default (`SimParams(simulator=8)`).
V8_DEFAULTS: Final = {
    "elastic_stiffness": 40.0,
    "damping_stiffness": 1.0,
    "bending_stiffness": 2.0,
    "max_grip_lift": 0.10,
    "wrench_from": "momentum",
}


#: The simulator versions a spec can ask for, by name, newest first: what `--simulator`
#: takes. v7 is v8's garments and paths with the wrench read from the gripper's
#: constraint. v10 (the gown's sleeve drawn up beside the upper arm, on a smoother
#: cloth; the shorts' waist drawn higher over the foot, into slimmer legs) is asked for
#: by name until the bundled models are trained on it.
SIMULATORS: Final = ("v10", "v9", "v8", "v7")
#: The name of `SIMULATOR`, what `--simulator` and a folder that does not say default to.
SIMULATOR_NAME: Final = f"v{SIMULATOR}"


def oldest_first(name: str) -> int:
    """Sort key of simulator names, oldest (v7) to newest: as strings, v10 sorts first."""
    return -SIMULATORS.index(name) if name in SIMULATORS else len(SIMULATORS)


def simulator_name(sim: SimParams) -> str:
    """`v10`, `v9`, `v8` or `v7`: the version a spec's physics are, as the docs name them."""
    if sim.simulator == 8 and sim.wrench_from == "constraint":
        return "v7"
    return f"v{sim.simulator}"


def simulator_of(sim: Mapping[str, Any] | None) -> str:
    """The version name of saved `sim` fields (a folder's overrides, a model card's): a
    mapping that names no simulator is from v8 or before, and v7 said no `wrench_from`."""
    sim = sim or {}
    if sim.get("simulator", 8) != 8:
        return f"v{sim['simulator']}"
    return "v7" if sim.get("wrench_from", "constraint") == "constraint" else "v8"


def simulator_fields(name: str) -> dict[str, Any]:
    """The `sim` fields that ask for simulator `name` (one of `SIMULATORS`), as a
    folder's overrides save them: v9 `{"simulator": 9}`, v7 `{"simulator": 8,
    "wrench_from": "constraint"}`."""
    if name not in SIMULATORS:
        raise ValueError(f"simulator {name!r} is not one of {', '.join(SIMULATORS)}")
    if name in ("v9", "v10"):
        return {"simulator": int(name[1:])}
    return {"simulator": 8, "wrench_from": "constraint" if name == "v7" else "momentum"}


class TrialSpec(BaseModel):
    """Everything that determines one simulated dressing trial."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    task: Task
    seed: int = Field(0, ge=0)
    speed: Annotated[
        float, Field(gt=0, le=MAX_SPEED, description="end-effector speed, m/s (dressing: cm/s)")
    ] = 0.125
    limb_offset: Vec3 = Field((0.0, 0.0, 0.0), description="limb offset from nominal, m")
    limb_rotation: LimbRotation = LimbRotation()
    duration: Annotated[float, Field(gt=0, le=MAX_DURATION, description="recorded motion, s")] = 7.0
    control_points: list[Vec3] = Field(
        default_factory=list,
        description="end-effector path control points in the world frame, m; "
        "empty means drawn from the seed",
    )
    sim: SimParams = SimParams()

    @field_validator("control_points")
    @classmethod
    def _a_path_within_reach(cls, points: list[Vec3]) -> list[Vec3]:
        if len(points) == 1:
            raise ValueError("at least two points for a path (or none, drawn from the seed)")
        if any(abs(v) > MAX_OFFSET for point in points for v in point):
            raise ValueError(f"each component within +-{MAX_OFFSET} m of the world origin")
        return points

    @field_validator("limb_offset")
    @classmethod
    def _limb_within_reach(cls, offset: tuple[float, float, float]) -> tuple[float, float, float]:
        if max(abs(v) for v in offset) > MAX_OFFSET:
            raise ValueError(f"each component within +-{MAX_OFFSET} m of the nominal pose")
        return offset

    @model_validator(mode="after")
    def _at_least_two_steps(self) -> TrialSpec:
        if round(self.duration * self.sim.record_hz) < 2:
            raise ValueError(f"duration: at least two recorded steps, {2 / self.sim.record_hz} s")
        return self

    def describe(self) -> str:
        """The spec in one line: what `info` prints and the viewer shows."""
        return (
            f"seed {self.seed}, speed {self.speed:.3f} m/s, offset "
            f"({', '.join(f'{v:+.3f}' for v in self.limb_offset)}) m, rotation "
            f"{self.limb_rotation.degrees:+g} deg about {self.limb_rotation.axis}, "
            f"duration {self.duration:g} s, simulator {simulator_name(self.sim)}"
        )


#: The version of the metadata a trial written now carries; a newer one is refused.
#: 2: stamps count from `time_origin_ns` (2020-01-01), not from 0.
TRIAL_FORMAT_VERSION = 2


class TrialMetadata(BaseModel):
    """What a recording says about itself (the MCAP metadata record `dresslog`)."""

    model_config = ConfigDict(extra="forbid")

    format_version: StrictInt = TRIAL_FORMAT_VERSION
    task: Task
    spec: TrialSpec | None = Field(None, description="the spec of a simulated trial")
    outcome: Outcome = Outcome.UNKNOWN
    caught_on: str | None = Field(
        None, description="for a caught trial: the limb part the garment was held on"
    )
    failure_reason: str | None = None
    source: dict[str, object] = Field(
        default_factory=dict,
        description="for converted logs: source file, topics, rates, processing",
    )
    software: dict[str, str] = Field(default_factory=dict)
    time_origin_ns: StrictInt = Field(
        0,
        ge=0,
        description="the stamp (ns since the Unix epoch) of the trial's time 0, which "
        "readers count its times from: 2020-01-01 in files of format 2, 0 in those before",
    )


SCHEMA_FILE = "trial_metadata.schema.json"


def metadata_json_schema() -> dict[str, object]:
    """The JSON Schema of the `dresslog` metadata record, as kept in `schemas/`."""
    schema = TrialMetadata.model_json_schema()
    return {"$comment": "Generated by `python -m dresslog.spec`; do not edit.", **schema}


if __name__ == "__main__":  # regenerate schemas/trial_metadata.schema.json
    import json
    import sys
    from importlib import resources

    if sys.argv[1:]:  # `--help` too: it takes none, and writes only when run bare
        sys.exit("usage: python -m dresslog.spec (regenerates the metadata JSON Schema)")
    target = resources.files("dresslog.schemas").joinpath(SCHEMA_FILE)
    with resources.as_file(target) as path:
        text = json.dumps(metadata_json_schema(), indent=2) + "\n"
        if path.exists() and path.read_text(encoding="utf-8") == text:
            print(f"up to date: {path}")
        else:
            path.write_text(text, encoding="utf-8")
            print(f"wrote {path}")
