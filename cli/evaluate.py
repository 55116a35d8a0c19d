"""`dresslog eval MODEL DATA [--bounds] [--plot PNG] [--per-sequence CSV] [--json]`: the
paper's RMSE on the test split, and more."""

from __future__ import annotations

import click

from .common import reports_errors


@click.command("eval")
@click.argument("model", type=click.Path())
@click.argument("data", type=click.Path())
@click.option("--split", type=click.Choice(["test", "train"]), default="test", show_default=True,
              help="The dataset split to score.")  # fmt: skip
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option(
    "--bounds",
    is_flag=True,
    help="Add oracle ratios, to read the model's against: what estimates handed part of "
    "the truth score (every force placed within 0.5-8 cm; each step's total spread by a "
    "profile; the truth's own flicker).",
)
@click.option("--plot", type=click.Path(dir_okay=False), metavar="PNG",
              help="Also draw where along the limb the model errs, and at what total "
              "force, as a PNG.")  # fmt: skip
@click.option("--per-sequence", type=click.Path(dir_okay=False), metavar="CSV",
              help="Also write each sequence's spec, outcome and scores as a CSV.")  # fmt: skip
@click.option("--overwrite", is_flag=True, help="Replace an existing --plot or --per-sequence.")
@click.option("--quiet", "-q", is_flag=True, help="No progress bar.")
@reports_errors
def evaluate(
    model: str,
    data: str,
    split: str,
    bounds: bool,
    plot: str | None,
    per_sequence: str | None,
    overwrite: bool,
    as_json: bool,
    quiet: bool,
) -> None:
    """RMSE after Eq. 2, the all-zero baseline, their ratio, per outcome; contact P/R."""
    from dresslog.experiments import evaluate_dataset

    report = evaluate_dataset(
        model, data, split=split, bounds=bounds, plot=plot, per_sequence=per_sequence,
        overwrite=overwrite, progress=not quiet and not as_json,
    )  # fmt: skip
    click.echo(report.to_json() if as_json else report.table())
    for written in (plot, per_sequence):
        if written and not as_json:
            click.echo(f"wrote {written}")
