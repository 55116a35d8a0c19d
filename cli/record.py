"""`dresslog record`: simulate one dressing trial into an MCAP file."""

from __future__ import annotations

import click

from dresslog.errors import DresslogError
from dresslog.spec import LimbRotation, Task


@click.command("record")
@click.option("--task", type=click.Choice([t.value for t in Task]), required=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False), required=True)
@click.option("--seed", type=int, default=0, show_default=True, help="draws the random spec")
@click.option("--speed", type=float, help="end-effector speed, m/s")
@click.option("--offset", type=float, nargs=3, help="limb offset X Y Z, m")
@click.option("--rotation", type=(click.Choice(["x", "y", "z"]), float), help="AXIS DEG")
@click.option("--duration", type=float, help="recorded motion, s")
@click.option("--overwrite", is_flag=True, help="replace an existing file")
def record(task, output, seed, speed, offset, rotation, duration, overwrite) -> None:
    """Simulate one trial (random spec from --seed, or set explicitly) and record it."""
    from dresslog.sim import random_spec, record_trial

    overrides: dict[str, object] = {}
    if speed is not None:
        overrides["speed"] = speed
    if offset:
        overrides["limb_offset"] = tuple(offset)
    if rotation:
        overrides["limb_rotation"] = LimbRotation(axis=rotation[0], degrees=rotation[1])
    if duration is not None:
        overrides["duration"] = duration
    try:
        result = record_trial(random_spec(task, seed, **overrides), output, overwrite=overwrite)
    except (DresslogError, ValueError) as err:
        raise click.ClickException(str(err)) from err
    click.echo(result.summary())
