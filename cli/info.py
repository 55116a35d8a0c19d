"""`dresslog info FILE.mcap|MODEL|DATA|BAG [--json]`."""

from __future__ import annotations

import click

from .common import reports_errors


@click.command("info")
@click.argument("path", type=click.Path(path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print it as JSON (card, manifest, bag).")
@reports_errors
def info(path: str, as_json: bool) -> None:
    """Summarise a trial file, a model folder (its card), a dataset folder (its manifest)
    or a ROS bag (its topics and tf tree, to choose convert's options).

    A model whose weights do not match its card is described, and the command fails.
    """
    from dresslog.info import describe

    text, problem = describe(path, as_json=as_json)
    click.echo(text)
    if problem is not None:
        raise problem
