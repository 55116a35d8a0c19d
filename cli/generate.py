"""`dresslog generate --task gown --trials 1000 --out data/gown [--workers N] [--seed S]`."""

from __future__ import annotations

import click

from dresslog.spec import Task

from .common import reports_errors


@click.command("generate")
@click.option("--task", type=click.Choice([t.value for t in Task]), required=True)
@click.option("--trials", type=click.IntRange(min=1), required=True, help="Train + test.")
@click.option("--out", "-o", type=click.Path(file_okay=False), required=True)
@click.option("--workers", type=click.IntRange(min=1), help="Parallel trials [all cores].")
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--test-fraction", type=click.FloatRange(0, 1, max_open=True), default=1 / 6, help="[1/6]"
)
@click.option("--duration", type=click.FloatRange(min=0, min_open=True), help="Seconds/trial.")
@click.option("--executor", type=click.Choice(["process", "ray"]), default="process")
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
    executor: str,
    quiet: bool,
) -> None:
    """Simulate many trials in parallel into OUT; run again to resume or extend it.

    Failed (unstable) trials are listed in OUT/manifest.json and replaced by fresh seeds.
    """
    from dresslog.dataset import generate as generate_dataset

    manifest = generate_dataset(
        task,
        trials,
        out,
        workers=workers,
        seed=seed,
        test_fraction=test_fraction,
        overrides={"duration": duration} if duration else None,
        executor=executor,
        progress=not quiet,
    )
    click.echo(f"{out}: {manifest.describe()}")
