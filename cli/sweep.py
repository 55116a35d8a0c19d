"""`dresslog sweep MODEL --speeds 0.2,0.25 --rotations y:-15,z:15`: Figs. 12 and 13."""

from __future__ import annotations

from typing import Any

import click
from click.core import ParameterSource

from dresslog.dataset.generate import MAX_TRIALS

from .common import reports_errors
from .options import (
    ROTATION_RANGE,
    SPEED_RANGE,
    duration_option,
    executor_option,
    ray_address_option,
)


def _items(ctx: click.Context, param: click.Parameter, values: tuple[str, ...]) -> list[str]:
    """The comma-separated values, each parsed as the library parses it and its number
    checked against the spec's range, so a bad one is a usage error naming the option before
    the model loads; the library keeps its own checks (and the limb's geometry, which only
    it knows)."""
    from dresslog.errors import DatasetError
    from dresslog.experiments.sweeps import parse_rotation, parse_speed

    items = [v.strip() for value in values for v in value.split(",") if v.strip()]
    for item in items:
        try:
            if param.name == "speeds":
                SPEED_RANGE.convert(parse_speed(item), param, ctx)
            else:
                ROTATION_RANGE.convert(parse_rotation(item)[1], param, ctx)
        except DatasetError as err:
            raise click.BadParameter(err.message) from None
    return items


@click.command("sweep")
@click.argument("model", type=click.Path())
@click.option("--speeds", multiple=True, callback=_items, metavar="LIST",
              help="End-effector speeds to sweep, m/s, comma-separated: 0.2,0.25 "
              f"(each {SPEED_RANGE.describe()}). Give --speeds, --rotations or both.")  # fmt: skip
@click.option("--rotations", multiple=True, callback=_items, metavar="LIST",
              help="Limb rotations to sweep, AXIS:DEG, comma-separated: y:-15,z:10 "
              f"({ROTATION_RANGE.describe('DEG')}). Give --speeds, --rotations or "
              "both.")  # fmt: skip
@click.option("-o", "--output", "--out", "out", type=click.Path(file_okay=False),
              help="Sweep folder to write or extend.",
              show_default="./NAME-sweep, NAME the model folder's")  # fmt: skip
@click.option("--sequences", "-n", type=click.IntRange(1, MAX_TRIALS), default=128,
              show_default=True, help="Fresh sequences per setting.")  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Draws the sequences' specs.")  # fmt: skip
@duration_option(" per sequence")
@click.option("--workers", type=click.IntRange(min=1), help="Sequences simulated at once.",
              show_default="all cores")  # fmt: skip
@executor_option
@ray_address_option
@click.option("--quiet", "-q", is_flag=True, help="No progress bars.")
@reports_errors
def sweep(
    model: str,
    speeds: list[str],
    rotations: list[str],
    out: str | None,
    sequences: int,
    workers: int | None,
    executor: str,
    ray_address: str | None,
    quiet: bool,
    **options: Any,
) -> None:
    """RMSE per speed and limb rotation on fresh sequences: sweep.csv, sweep.json, sweep.png."""
    from dresslog.dataset import Execution
    from dresslog.experiments import default_sweep_folder
    from dresslog.experiments import sweep as run_sweep

    if not speeds and not rotations:  # `--speeds "$SPEEDS"` of an empty variable says so
        ctx = click.get_current_context()
        empty = [f"--{name} is empty; " for name in ("speeds", "rotations")
                 if ctx.get_parameter_source(name) is ParameterSource.COMMANDLINE]  # fmt: skip
        raise click.UsageError(f"{''.join(empty[:1])}give --speeds, --rotations or both")
    if ray_address is not None and executor != "ray":
        raise click.UsageError("--address is the Ray cluster to join: give --executor ray too")
    out = out or str(default_sweep_folder(model))
    execution = Execution(workers=workers, executor=executor, ray_address=ray_address)
    report = run_sweep(
        model, out, speeds=speeds, rotations=rotations, n=sequences, execution=execution,
        progress=not quiet, **options,
    )  # fmt: skip
    click.echo(report.table())
    click.echo(report.trained())
    click.echo(f"wrote {out}: sweep.csv, sweep.json and sweep.png")
