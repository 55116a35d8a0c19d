"""`dresslog generate --task gown --trials 1000 --out data/gown [--workers N] [--seed S]`."""

from __future__ import annotations

import click

from dresslog.dataset.generate import MAX_TRIALS
from dresslog.spec import simulator_fields

from .common import reports_errors
from .options import (
    AXIS,
    ROTATION_RANGE,
    FiniteRange,
    duration_option,
    executor_option,
    ray_address_option,
    rotation_option,
    rotation_spec,
    simulator_option,
    speed_option,
    task_option,
)


@click.command("generate")
@task_option
@click.option("--trials", type=click.IntRange(1, MAX_TRIALS), required=True,
              help="Trials in all, train + test.")  # fmt: skip
@click.option("-o", "--output", "--out", "out", type=click.Path(file_okay=False), required=True,
              help="Dataset folder to write or extend.")  # fmt: skip
@click.option("--workers", type=click.IntRange(min=1), help="Trials simulated at once.",
              show_default="all cores")  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Draws every trial's spec.")  # fmt: skip
@click.option("--test-fraction", type=FiniteRange(0, 1), default=1 / 6, show_default="1/6",
              help="Share of the trials in the test split (1: a test set of fresh seeds "
              "only, to score models on).")  # fmt: skip
@duration_option(" per trial")
@speed_option("drawn per trial")
@rotation_option
@click.option("--rotation-range", type=(AXIS, ROTATION_RANGE, ROTATION_RANGE),
              metavar="AXIS LOW HIGH", show_default="none",
              help="Draw each trial's rotation about AXIS, LOW to HIGH degrees.")  # fmt: skip
@simulator_option
@executor_option
@ray_address_option
@click.option("--quiet", "-q", is_flag=True, help="No progress bar.")
@reports_errors
def generate(
    task: str,
    trials: int,
    out: str,
    workers: int | None,
    seed: int,
    test_fraction: float,
    duration: float | None,
    speed: float | None,
    rotation: tuple[str, float] | None,
    rotation_range: tuple[str, float, float] | None,
    simulator: str,
    executor: str,
    ray_address: str | None,
    quiet: bool,
) -> None:
    """Simulate many trials in parallel into OUT; run again to resume or extend it.

    Failed (unstable) trials are listed in OUT/manifest.json and replaced by fresh seeds.
    --speed and --rotation make every trial of one condition (a forearm turned aside, say), to
    train or score a model on; --rotation-range makes them across a span of conditions.
    """
    from dresslog.dataset import Execution
    from dresslog.dataset import generate as generate_dataset

    if ray_address is not None and executor != "ray":
        raise click.UsageError("--address is the Ray cluster to join: give --executor ray too")
    if rotation and rotation_range:
        raise click.UsageError("--rotation fixes every trial's rotation, --rotation-range draws "
                               "it; give one")  # fmt: skip

    sim = simulator_fields(simulator)
    fixed = {"duration": duration, "speed": speed, "limb_rotation": rotation_spec(rotation),
             "sim": sim}  # fmt: skip
    manifest = generate_dataset(
        task,
        trials,
        out,
        seed=seed,
        test_fraction=test_fraction,
        overrides={field: value for field, value in fixed.items() if value is not None},
        rotation_range=dict(zip(("axis", "low", "high"), rotation_range, strict=True))
        if rotation_range
        else None,
        execution=Execution(workers=workers, executor=executor, ray_address=ray_address),
        progress=not quiet,
    )
    click.echo(f"{out}: {manifest.describe()}")
