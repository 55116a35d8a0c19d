"""`dresslog record`: simulate one dressing trial into an MCAP file."""

from __future__ import annotations

from pathlib import Path

import click

from dresslog.spec import Task

from .common import reports_errors


@click.command("record")
@click.option("--task", type=click.Choice([t.value for t in Task]), required=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path), required=True)
@click.option(
    "--seed", type=click.IntRange(min=0), default=0, show_default=True, help="Draws the spec."
)
@click.option("--speed", type=float, help="End-effector speed, m/s.")
@click.option("--offset", type=float, nargs=3, help="Limb offset X Y Z, m.")
@click.option("--rotation", type=(click.Choice(["x", "y", "z"]), float), help="AXIS DEG.")
@click.option("--duration", type=float, help="Recorded motion, s.")
@click.option("--overwrite", is_flag=True, help="Replace an existing file.")
@click.option("--live", is_flag=True, help="Stream to a live Rerun viewer while simulating.")
@click.option("--model", type=click.Path(path_type=Path), help="Model for --live [bundled].")
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
    turn = dict(zip(("axis", "degrees"), rotation, strict=True)) if rotation else None
    spec = random_spec(
        task, seed, speed=speed, duration=duration, limb_offset=offset or None, limb_rotation=turn
    )
    if streamed:
        from dresslog.replay.live import record_live

        result, metrics = record_live(
            spec, output, model=model, overwrite=overwrite, connect=connect
        )
        if metrics.rmse is not None:
            ratio = f", ratio {metrics.ratio:.3f}" if metrics.ratio is not None else ""
            click.echo(
                f"estimate RMSE {metrics.rmse:.4g} N (all-zero {metrics.zero_rmse:.4g} N{ratio})"
            )
    else:
        result = record_trial(spec, output, overwrite=overwrite, progress=True)
    click.echo(result.summary())
