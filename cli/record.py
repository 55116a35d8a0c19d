"""`dresslog record`: simulate one dressing trial into an MCAP file."""

from __future__ import annotations

from pathlib import Path

import click

from dresslog.spec import MAX_OFFSET, simulator_fields

from .common import reports_errors
from .options import (
    FiniteRange,
    duration_option,
    rotation_option,
    rotation_spec,
    simulator_option,
    speed_option,
    task_option,
)


@click.command("record")
@task_option
@click.option("-o", "--output", "--out", "output", type=click.Path(dir_okay=False, path_type=Path),
              required=True, help="Trial file to write (.mcap).")  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True,
              help="Draws speed, limb offset and path.")  # fmt: skip
@speed_option("from --seed")
@click.option("--offset", type=FiniteRange(-MAX_OFFSET, MAX_OFFSET), nargs=3, metavar="X Y Z",
              help="Limb offset from its nominal pose, m (the range is each component's).",
              show_default="from --seed, within the paper's ranges")  # fmt: skip
@rotation_option
@duration_option("", checked=False)
@simulator_option
@click.option("--overwrite", is_flag=True, help="Replace an existing file.")
@click.option("--live", is_flag=True, help="Stream to a live Rerun viewer while simulating.")
@click.option("--model", "-m", type=click.Path(path_type=Path),
              help="Model folder for --live or --connect.",
              show_default="bundled, for the task")  # fmt: skip
@click.option(
    "--connect",
    metavar="URL",
    help="Stream to the Rerun viewer at URL (rerun+http://HOST:9876/proxy); implies --live.",
)
@reports_errors
def record(
    task: str,
    output: Path,
    seed: int,
    speed: float | None,
    offset: tuple[float, float, float] | None,
    rotation: tuple[str, float] | None,
    duration: float | None,
    simulator: str,
    overwrite: bool,
    live: bool,
    model: Path | None,
    connect: str | None,
) -> None:
    """Simulate one trial (random spec from --seed, or set explicitly) and record it."""
    from dresslog.sim import random_spec, record_trial

    streamed = live or connect is not None  # `--connect ""` (an unset $VIEWER) is refused
    if model is not None and not streamed:
        raise click.UsageError("--model is the live view's; use it with --live or --connect")
    spec = random_spec(
        task,
        seed,
        speed=speed,
        duration=duration,
        limb_offset=offset or None,
        limb_rotation=rotation_spec(rotation),
        sim=simulator_fields(simulator),
    )
    if streamed:
        from dresslog.replay.live import record_live

        result, metrics = record_live(
            spec, output, model=model, overwrite=overwrite, connect=connect
        )
        if scores := metrics.scores():
            click.echo(f"estimate {scores}")
    else:
        result = record_trial(spec, output, overwrite=overwrite, progress=True)
    click.echo(result.summary())
