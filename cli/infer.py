"""`dresslog infer TRIAL.mcap... [--model M] [-o OUT.rrd|DIR] [--mcap-out OUT.mcap|DIR]`."""

from __future__ import annotations

from pathlib import Path

import click

from .common import error_line, reports_errors


@click.command("infer")
@click.argument("trials", metavar="TRIAL...", nargs=-1, required=True,
                type=click.Path(path_type=Path))  # fmt: skip
@click.option("--model", "-m", type=click.Path(path_type=Path), help="Model folder.",
              show_default="bundled, for the trial's task")  # fmt: skip
@click.option("-o", "--output", "--out", "output", type=click.Path(),
              help="Rerun recording to write (.rrd), or the folder for each TRIAL.rrd (with "
              "several trials, an existing folder, or one ending in /).",
              show_default="TRIAL.rrd, beside the trial")  # fmt: skip
@click.option("--mcap-out", type=click.Path(),
              help="Also write the trial with the estimate (.mcap), or the folder for "
              "each TRIAL.mcap (with several trials, an existing folder, or one ending "
              "in /).")  # fmt: skip
@click.option("--overwrite", is_flag=True, help="Replace existing outputs.")
@click.option("--timings", is_flag=True, help="Print the time of each stage.")
@reports_errors
def infer(
    trials: tuple[Path, ...],
    model: Path | None,
    output: str | None,  # str, not Path: `out/` names a folder by its trailing /
    mcap_out: str | None,
    overwrite: bool,
    timings: bool,
) -> None:
    """Stream each TRIAL step by step through the force-map LSTM and write a Rerun recording.

    Prints the RMSE against ground truth when a trial has it; with several trials, their
    mean too, and a bad trial is reported without stopping the others.
    """
    from dresslog.errors import TrialWriteError
    from dresslog.replay.batch import TrialFailure, replay_files
    from dresslog.replay.pipeline import InferenceReport

    def show(outcome: InferenceReport | TrialFailure) -> None:  # as each trial is done
        if isinstance(outcome, TrialFailure):
            line = error_line(outcome.error)
            if len(trials) > 1 and not line.startswith(f"{outcome.trial}: "):  # the model's
                line = f"{outcome.trial}: {line}"  # error, say: which trial it failed
            click.echo(f"Error: {line}", err=True)
            return
        click.echo(outcome.summary())
        if timings:
            times = outcome.timings.items()
            click.echo("  " + ", ".join(f"{k} {v * 1e3:.0f} ms" for k, v in times))

    try:  # -o and --mcap-out name a file; with several trials, a folder
        batch = replay_files(
            trials, model=model, rrd=output, mcap=mcap_out, on_trial=show, overwrite=overwrite,
            progress=True,
        )  # fmt: skip
    except TrialWriteError as err:  # only the folders, refused before any trial
        raise click.UsageError(error_line(err)) from None
    if len(trials) > 1:
        click.echo(batch.summary())
    if batch.failures and len(trials) > 1:
        raise click.ClickException(f"{len(batch.failures)} of {len(trials)} trials failed")
    if batch.failures:
        raise click.exceptions.Exit(1)  # its error is said
