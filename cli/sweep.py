"""`dresslog sweep MODEL --speeds 0.2,0.25 --rotations y:-15,z:15`: Figs. 12 and 13."""

from __future__ import annotations

from typing import Any

import click

from .common import reports_errors


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
@click.option(
    "--speeds", multiple=True, callback=_items, help="End-effector speeds, m/s (comma-separated)."
)
@click.option(
    "--rotations", multiple=True, callback=_items, help="Limb rotations AXIS:DEGREES: y:-15,z:10."
)
@click.option("--out", "-o", type=click.Path(file_okay=False), help="[./MODEL-sweep]")
@click.option("--sequences", "-n", type=click.IntRange(min=1), default=128, show_default=True)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option("--duration", type=click.FloatRange(min=0, min_open=True), help="Seconds/trial.")
@click.option("--workers", type=click.IntRange(min=1), help="Parallel trials [all cores].")
@click.option("--executor", type=click.Choice(["process", "ray"]), default="process")
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
