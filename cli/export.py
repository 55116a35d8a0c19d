"""`dresslog export DATA --format lerobot -o OUT [--overwrite]`."""

from __future__ import annotations

import click

from .common import reports_errors


@click.command("export")
@click.argument("data", type=click.Path(path_type=str))
@click.option("--format", "fmt", type=click.Choice(["lerobot"]), required=True,
              help="The dataset format to write: LeRobot v3.0 (Parquet and JSON).")  # fmt: skip
@click.option("-o", "--output", "out", type=click.Path(file_okay=False), required=True,
              help="Folder to write the dataset to (made whole, then renamed).")  # fmt: skip
@click.option("--overwrite", is_flag=True, help="Replace an earlier export at OUT.")
@reports_errors
def export(data: str, fmt: str, out: str, overwrite: bool) -> None:
    """Write a dataset folder (from `generate`) in another tool's format: one episode per
    trial at 100 Hz, with wrench, twist, pose, the ground-truth force and contact maps,
    a model's estimate where every trial has one, and the outcome."""
    from dresslog.dataset.lerobot import export_lerobot

    info = export_lerobot(data, out, overwrite=overwrite)
    click.echo(
        f"wrote {out}: LeRobot {info['codebase_version']}, {info['total_episodes']} "
        f"episodes, {info['total_frames']} frames at {info['fps']} Hz"
    )
