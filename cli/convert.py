"""`dresslog convert INPUT -o trial.mcap --task gown|shorts [topics, CSV columns, tare, rotate,
translate, window]`."""

from __future__ import annotations

import click

from .common import reports_errors
from .options import FiniteRange, signal_options, task_option


@click.command("convert")
@click.argument("source", type=click.Path(path_type=str))
@click.option("-o", "--output", "--out", "output", required=True, type=click.Path(path_type=str),
              help="Trial file to write (.mcap).")  # fmt: skip
@task_option
@click.option("--wrench-topic", help="A bag's WrenchStamped topic.",
              show_default="the only one")  # fmt: skip
@click.option("--twist-topic", help="A bag's TwistStamped topic, for the velocity.",
              show_default="the only one")  # fmt: skip
@click.option("--pose-topic", help="A bag's PoseStamped topic (velocity by differentiation if "
              "no twist).", show_default="the only one")  # fmt: skip
@click.option("--pose-tf", metavar="PARENT:CHILD", help="A bag's pose from its /tf and "
              "/tf_static instead: CHILD's in PARENT, e.g. base_link:tool0.")  # fmt: skip
@click.option("--motion", type=click.Path(path_type=str),
              help="CSV with velocity or position, beside a force/torque CSV.")  # fmt: skip
@click.option("--column", "columns", multiple=True, metavar="ROLE=HEADER",
              help="Map a CSV column: time, fx..tz, vx..vz, wx..wz, x..z, qx..qw; repeatable.",
              show_default="recognised by header")  # fmt: skip
@click.option("--time-unit", type=click.Choice(["s", "ms", "us", "ns"]), help="A CSV's time unit.",
              show_default="from the header, else s or ns by size")  # fmt: skip
@click.option("--clock", type=click.Choice(["header", "log"]), default="header", show_default=True,
              help="A bag's times: header stamps, or receive times (clocks differ).")  # fmt: skip
@signal_options
@click.option("--start", "start_s", type=FiniteRange(min=0), default=0.0, metavar="SECONDS",
              show_default=True, help="Keep the steps from SECONDS (from the first step every "
              "stream covers), e.g. one trial of a session.")  # fmt: skip
@click.option("--end", "end_s", type=FiniteRange(min=0), metavar="SECONDS",
              show_default="the log's end", help="Keep the steps before SECONDS.")  # fmt: skip
@click.option("--overwrite", is_flag=True, help="Replace OUTPUT if it exists.")
@reports_errors
def convert(source: str, output: str, columns: tuple[str, ...], **options: object) -> None:
    """Convert a ROS 1/2 bag, ROS 2 MCAP file or force/torque CSV into a dresslog trial."""
    from dresslog.convert import ConvertOptions, OptionError
    from dresslog.convert import convert as run

    if bad := [c for c in columns if "=" not in c]:
        raise click.BadParameter(f"{bad[0]!r} is not ROLE=HEADER", param_hint="'--column'")
    mapping: dict[str, str] = {}
    for role, name in (c.split("=", 1) for c in columns):
        if mapping.setdefault(role, name) != name:  # else the last would win unsaid
            raise click.BadParameter(
                f"{role} is given twice ({role}={mapping[role]}, {role}={name}); map each role "
                "to one column",
                param_hint="'--column'",
            )
    try:
        settings = ConvertOptions.build(columns=mapping or None, **options)  # type: ignore[arg-type]
    except OptionError as err:  # options that contradict each other: how the command is used
        raise click.UsageError(str(err)) from None
    report = run(source, output, settings)
    click.echo(f"{output}: {report.steps} steps ({report.duration_s:.2f} s at 100 Hz) "
               f"from {report.messages_in} messages in {report.elapsed_s:.2f} s")  # fmt: skip
