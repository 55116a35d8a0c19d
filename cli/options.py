"""Options several commands share, written once so their help reads alike.

Kept apart from `common` because they need `dresslog.spec` (pydantic), which the
commands that take none of them (`infer`, `view`, `info`) do not load at start-up.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import click

from dresslog.spec import MAX_DURATION, Task, TrialSpec

task_option = click.option(
    "--task",
    type=click.Choice([t.value for t in Task]),
    required=True,
    help="Dressing task: gown (arm) or shorts (leg).",
)

executor_option = click.option(
    "--executor",
    type=click.Choice(["process", "ray"]),
    default="process",
    show_default=True,
    help="Local processes, or Ray ($RAY_ADDRESS's cluster, else local).",
)


def duration_option(each: str, kind: Any = float) -> Callable[[Any], Any]:
    """`--duration`, `each` naming what it sets ("", " per trial"); `kind` its click type
    (`record` leaves the range to the library, whose error names the bound)."""
    return click.option(
        "--duration",
        type=kind,
        metavar="SECONDS",
        help=f"Recorded motion{each}, s (0<x<={MAX_DURATION:g}); outcomes are judged at its "
        "end, and a path takes 4-7 s.",
        show_default=f"{TrialSpec.model_fields['duration'].default:g} s",
    )


class FiniteRange(click.FloatRange):
    """`click.FloatRange` that refuses nan too, which compares false with either bound and
    so slipped through to the library's error (exit 1, not the usage error's 2)."""

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        number = super().convert(value, param, ctx)
        if math.isnan(number):
            self.fail(f"{number} is not in the range {self._describe_range()}.", param, ctx)
        return number
