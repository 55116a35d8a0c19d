"""`dresslog infer TRIAL.mcap [--model M] [-o OUT.rrd] [--mcap-out OUT.mcap]`."""

from __future__ import annotations

from pathlib import Path

import click

from .common import reports_errors


@click.command("infer")
@click.argument("trial", type=click.Path(path_type=Path))
@click.option("--model", "-m", type=click.Path(path_type=Path), help="Model folder.",
              show_default="bundled, for the trial's task")  # fmt: skip
@click.option("-o", "--output", "--out", "output", type=click.Path(path_type=Path),
              help="Rerun recording to write (.rrd).", show_default="TRIAL.rrd")  # fmt: skip
@click.option("--mcap-out", type=click.Path(path_type=Path),
              help="Also write the trial with the estimate (.mcap).")  # fmt: skip
@click.option("--timings", is_flag=True, help="Print the time of each stage.")
@reports_errors
def infer(
    trial: Path, model: Path | None, output: Path | None, mcap_out: Path | None, timings: bool
) -> None:
    """Stream TRIAL step by step through the force-map LSTM and write a Rerun recording.

    Prints the RMSE against ground truth when the trial has it.
    """
    from dresslog.replay.pipeline import replay_file

    default = trial.with_suffix(".rrd") if trial.name else trial  # `.` is refused as input first
    report = replay_file(trial, model=model, rrd=output or default, mcap=mcap_out)
    click.echo(report.summary())
    if timings:
        click.echo("  " + ", ".join(f"{k} {v * 1e3:.0f} ms" for k, v in report.timings.items()))
