"""Options several commands share, written once so their help reads alike.

Kept apart from `common` because they need `dresslog.spec` (pydantic), which the
commands that take none of them (`infer`, `view`, `info`) do not load at start-up.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, get_args

import click

from dresslog.spec import (
    MAX_DURATION,
    MAX_ROTATION,
    MAX_SPEED,
    SIMULATOR_NAME,
    SIMULATORS,
    Axis,
    Task,
    TrialSpec,
)


class OneLineChoice(click.Choice):
    """`click.Choice` whose 'Missing option' error stays on one line (`Choose from: gown,
    shorts.`), where click lists the choices one per line after a tab."""

    def get_missing_message(self, param: click.Parameter, ctx: click.Context | None) -> str:
        """The choices on one line, for the 'Missing option' error."""
        return f"Choose from: {', '.join(map(str, self.choices))}."


task_option = click.option(
    "--task",
    type=OneLineChoice([t.value for t in Task]),
    required=True,
    help="Dressing task: gown (arm) or shorts (leg).",
)

executor_option = click.option(
    "--executor",
    type=click.Choice(["process", "ray"]),
    default="process",
    show_default=True,
    help="Local processes, or Ray tasks on a cluster (see --address).",
)

ray_address_option = click.option(
    "--address",
    "ray_address",
    metavar="HOST:PORT",
    help="The Ray cluster to join, with --executor ray.",
    show_default="$RAY_ADDRESS, else the one `ray start` runs here, else a new local one",
)


def duration_option(each: str, *, checked: bool = True) -> Callable[[Any], Any]:
    """`--duration`, `each` naming what it sets ("", " per trial"). `checked`: click refuses a
    value out of 0<x<=MAX_DURATION (nan, inf) as a usage error; `record` leaves it to the
    library (exit 1, `invalid duration: ...`, nan as not finite), whose error names the
    bound, the two-step minimum too."""
    return click.option(
        "--duration",
        type=FiniteRange(0, MAX_DURATION, min_open=True) if checked else float,
        metavar="SECONDS",
        help=f"Recorded motion{each}, s{'' if checked else f' (0<x<={MAX_DURATION:g})'}; "
        "outcomes are judged at its end, and a path takes 4-7 s.",
        show_default=f"{TrialSpec.model_fields['duration'].default:g} s",
    )


#: `--simulator`: the simulator version to record with (`dresslog.spec.SIMULATORS`)
simulator_option = click.option(
    "--simulator",
    type=click.Choice(SIMULATORS),
    default=SIMULATOR_NAME,
    show_default=True,
    help="Simulator version: v9 drapes its garments and draws them up the arm and the "
    "leg, as the bundled models were trained; v10 draws the gown's sleeve up "
    "beside the upper arm on a smoother cloth and the shorts' waist higher over the foot "
    "into slimmer legs; v8 and v7 (its "
    "wrench from the gripper's constraint) stay for old data (docs/simulator.md).",
)


class FiniteRange(click.FloatRange):
    """`click.FloatRange` that refuses nan and inf too: nan compares false with either bound,
    and inf passes an open side (`x>=0`), so both slipped through to the library's error
    (exit 1, not the usage error's 2). With no bounds: any finite number."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        """The number in `value`, refused (a usage error) when it is nan, infinite or out of
        range."""
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            where = f"in the range {self._describe_range()}" if self._describe_range() else "finite"
            self.fail(f"{number} is not {where}.", param, ctx)
        return number

    def _describe_range(self) -> str:
        """What help shows after the default, and errors name; nothing when unbounded."""
        return "" if self.min is None and self.max is None else super()._describe_range()

    def describe(self, variable: str = "x") -> str:
        """The range as a help text writes it (`0<x<=1`), with `variable` for x."""
        return self._describe_range().replace("x", variable)


#: A number, any but nan and inf (a quaternion's or a translation's component).
FINITE = FiniteRange()
#: The spec's ranges, so `record --speed` and `sweep --speeds` refuse alike.
SPEED_RANGE = FiniteRange(0, MAX_SPEED, min_open=True)
ROTATION_RANGE = FiniteRange(-MAX_ROTATION, MAX_ROTATION)
#: The limb's rotation axes (ours: z up).
AXIS = click.Choice(get_args(Axis))


def speed_option(drawn: str) -> Callable[[Any], Any]:
    """`--speed`, fixed; `drawn` says what sets it otherwise ("from --seed")."""
    return click.option("--speed", type=SPEED_RANGE, metavar="M/S", help="End-effector speed, m/s.",
                        show_default=f"{drawn}: gown 0.10-0.15, shorts 0.15-0.20")  # fmt: skip


rotation_option = click.option(
    "--rotation",
    type=(AXIS, ROTATION_RANGE),
    metavar="AXIS DEG",
    help="Turn the forearm (gown) or foot (shorts) about x, y or z, degrees "
    f"({ROTATION_RANGE.describe('DEG')}).",
    show_default="none",
)


def rotation_spec(rotation: tuple[str, float] | None) -> dict[str, Any] | None:
    """`--rotation z -15` as the spec's `limb_rotation` ({"axis": "z", "degrees": -15.0})."""
    return dict(zip(("axis", "degrees"), rotation, strict=True)) if rotation else None


def signal_options(command: Callable[..., Any]) -> Callable[..., Any]:
    """Where the wrench is measured and how the signal is turned into the model's frame:
    `convert`'s and `live`'s options alike (`dresslog.convert.SignalOptions`)."""
    from dresslog.convert.signal import MAX_SENSOR_OFFSET, MAX_TRANSLATE

    options = [
        click.option(
            "--wrench-frame",
            type=click.Choice(["world", "pose"]),
            default="world",
            show_default=True,
            help="The wrench's axes: world, or the gripper's own (turned by the pose's "
            "orientation).",
        ),
        click.option(
            "--sensor-rotation",
            nargs=4,
            type=FINITE,
            metavar="QX QY QZ QW",
            help="With --wrench-frame pose: the sensor's axes in the gripper's (quaternion).",
            show_default="none",
        ),
        click.option(
            "--sensor-offset",
            nargs=3,
            metavar="X Y Z",
            type=FiniteRange(-MAX_SENSOR_OFFSET, MAX_SENSOR_OFFSET),
            help="With --wrench-frame pose: sensor origin from gripper centre, m.",
            show_default="0 0 0",
        ),
        click.option(
            "--rotate",
            nargs=4,
            type=FINITE,
            metavar="QX QY QZ QW",
            help="Rotate every vector into the model's frame (quaternion).",
            show_default="none",
        ),
        click.option(
            "--translate",
            nargs=3,
            type=FiniteRange(-MAX_TRANSLATE, MAX_TRANSLATE),
            metavar="X Y Z",
            help="Then move every pose by X Y Z, m, to place the gripper's path in the "
            "scene's frame (the drawing only: the estimate does not use position).",
            show_default="none",
        ),
        click.option(
            "--tare",
            "tare_s",
            type=FiniteRange(min=0),
            default=0.0,
            metavar="SECONDS",
            show_default=True,
            help="Subtract the mean wrench of the first SECONDS, s; 0: no tare.",
        ),
    ]
    for option in reversed(options):
        command = option(command)
    return command
