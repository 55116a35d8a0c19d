"""`dresslog info FILE.mcap|MODEL|DATA [--json]`."""

from __future__ import annotations

from pathlib import Path

import click

from dresslog.cli.common import reports_errors
from dresslog.errors import DresslogError


@click.command("info")
@click.argument("path", type=click.Path(path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print it as JSON (card, manifest).")
@reports_errors
def info(path: str, as_json: bool) -> None:
    """Summarise a trial file, a model folder (its card) or a dataset folder (its manifest)."""
    from dresslog.dataset.manifest import MANIFEST_FILE, damaged_files, load_manifest

    if (Path(path) / MANIFEST_FILE).is_file():
        manifest = load_manifest(path)
        if as_json:
            click.echo(manifest.model_dump_json(indent=1))
            return
        click.echo(f"{path}: {manifest.describe()}")
        if damaged := list(damaged_files(path, manifest)):
            names = ", ".join(f"{file} ({how})" for file, how in damaged[:5])
            more = f" and {len(damaged) - 5} more" if len(damaged) > 5 else ""
            click.echo(f"  damaged: {names}{more}; run `dresslog generate` on it again")
    elif Path(path).is_dir():
        from dresslog.model.files import CARD_FILE, load_model
        from dresslog.model.summary import format_card

        if not (Path(path) / CARD_FILE).is_file():
            raise DresslogError(
                f"neither a model folder (no {CARD_FILE}) nor a dataset folder "
                f"(no {MANIFEST_FILE})",
                path=path,
            )

        model = load_model(path)  # verifies the weights against the card
        click.echo(model.card.model_dump_json(indent=2) if as_json else format_card(model))
    else:
        from dresslog.io.summary import format_summary, summarize

        summary = summarize(path)
        click.echo(summary.model_dump_json(indent=2) if as_json else format_summary(summary))
