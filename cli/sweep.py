"""`dresslog sweep MODEL --speeds 0.2,0.25 --rotations y:-15,z:15`: Figs. 12 and 13."""

from __future__ import annotations

from typing import Any

import click

from .common import reports_errors
from .options import duration_option, executor_option


def _items(ctx: click.Context, param: click.Parameter, values: tuple[str, ...]) -> list[str]:
    """The comma-separated values, each of the form the library reads (else exit 2)."""
    from dresslog.errors import DatasetError
    from dresslog.experiments.sweeps import parse_rotation, parse_speed

    items = [v.strip() for value in values for v in value.split(",") if v.strip()]
    parse = parse_speed if param.name == "speeds" else parse_rotation
    for item in items:
        try:
            parse(item)
        except DatasetError as err:
            raise click.BadParameter(err.message) from None
    return items


@click.command("sweep")
@click.argument("model", type=click.Path())
@click.option("--speeds", multiple=True, callback=_items, metavar="LIST",
              help="End-effector speeds to sweep, m/s, comma-separated: 0.2,0.25 (each 0<x<=1). "
              "Give --speeds, --rotations or both.")  # fmt: skip
@click.option("--rotations", multiple=True, callback=_items, metavar="LIST",
              help="Limb rotations to sweep, AXIS:DEG, comma-separated: y:-15,z:10 "
              "(-90<=DEG<=90). Give --speeds, --rotations or both.")  # fmt: skip
@click.option("-o", "--output", "--out", "out", type=click.Path(file_okay=False),
              help="Sweep folder to write or extend.",
              show_default="./NAME-sweep, NAME the model folder's")  # fmt: skip
@click.option("--sequences", "-n", type=click.IntRange(min=1), default=128, show_default=True,
              help="Fresh sequences per setting (at most 1,000,000).")  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Draws the sequences' specs.")  # fmt: skip
@duration_option(" per sequence")
@click.option("--workers", type=click.IntRange(min=1), help="Sequences simulated at once.",
              show_default="all cores")  # fmt: skip
@executor_option
@click.option("--quiet", "-q", is_flag=True, help="No progress bars.")
@reports_errors
def sweep(
    model: str,
    speeds: list[str],
    rotations: list[str],
    out: str | None,
    sequences: int,
    quiet: bool,
    **options: Any,
) -> None:
    """RMSE per speed and limb rotation on fresh sequences: sweep.csv, sweep.json, sweep.png."""
    from dresslog.experiments import default_sweep_folder
    from dresslog.experiments import sweep as run_sweep

    if not speeds and not rotations:
        raise click.UsageError("give --speeds, --rotations or both")
    out = out or str(default_sweep_folder(model))
    report = run_sweep(
        model, out, speeds=speeds, rotations=rotations, n=sequences,
        progress=not quiet, **options,
    )  # fmt: skip
    click.echo(report.table())
    click.echo(f"wrote {out}: sweep.csv, sweep.json and sweep.png")
