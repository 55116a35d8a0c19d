"""`dresslog view FILE [--model M] [--web] [--save OUT.rrd]`."""

from __future__ import annotations

from pathlib import Path

import click

from .common import reports_errors


@click.command("view")
@click.argument("path", type=click.Path(path_type=Path))
@click.option("--model", "-m", type=click.Path(path_type=Path), help="Model folder for an MCAP.",
              show_default="bundled, for the trial's task")  # fmt: skip
@click.option("--web", is_flag=True, help="Serve the web viewer on localhost; print its address.")
@click.option("--save", type=click.Path(path_type=Path), help="Only write this .rrd; no viewer.")
@click.option("--overwrite", is_flag=True, help="Replace an existing --save file.")
@click.option("--port", "--web-port", "port", type=click.IntRange(1, 65535),
              help="The web page's port, with --web.",
              show_default="9090, else a free one")  # fmt: skip
@click.option("--grpc-port", type=click.IntRange(1, 65535),
              help="The port the web page reads the recording from, with --web.",
              show_default="9876, else a free one")  # fmt: skip
@reports_errors
def view(
    path: Path,
    model: Path | None,
    web: bool,
    save: Path | None,
    overwrite: bool,
    port: int | None,
    grpc_port: int | None,
) -> None:
    """Open a trial (MCAP) or a Rerun recording (.rrd) in the Rerun viewer.

    An MCAP is inferred first when a model for its task is available (--model or
    the bundled one), otherwise shown with ground truth alone.
    """
    from dresslog.replay.viewer import MODEL_FOR_RRD, is_rrd, save_rrd, view_file

    if port is not None and not web:
        raise click.UsageError("--port is the web viewer's; use it with --web")
    if grpc_port is not None and not web:
        raise click.UsageError("--grpc-port is the web viewer's; use it with --web")
    if overwrite and save is None:
        raise click.UsageError("--overwrite replaces the file --save writes; use it with --save")
    if model is not None and is_rrd(path):  # known by its bytes too; the library refuses it too
        raise click.UsageError(f"{path}: {MODEL_FOR_RRD}")
    if save is not None:
        if web:
            raise click.UsageError("--save writes a file and opens no viewer; drop --web")
        click.echo(save_rrd(path, save, model=model, overwrite=overwrite, progress=True))
        return
    view_file(path, model=model, web=web, web_port=port, grpc_port=grpc_port, echo=click.echo,
              progress=True)  # fmt: skip
