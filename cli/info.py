"""`dresslog info FILE.mcap [--json]`."""

from __future__ import annotations

import click

from dresslog.cli.common import reports_errors


@click.command("info")
@click.argument("path", type=click.Path(path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@reports_errors
def info(path: str, as_json: bool) -> None:
    """Summarise a trial file: task, duration, rate, channels, spec, ground truth."""
    from dresslog.io.summary import format_summary, summarize

    summary = summarize(path)
    click.echo(summary.model_dump_json(indent=2) if as_json else format_summary(summary))
