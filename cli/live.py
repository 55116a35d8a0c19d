"""`dresslog live --task gown|shorts --wrench-topic T (--twist-topic T | --pose-topic T)
[signal options] [-o session.mcap] [--connect URL]`."""

from __future__ import annotations

import click

from dresslog.live.options import HIGH_FORCE_N, PREFIX, WAIT_S

from .common import reports_errors
from .options import FiniteRange, signal_options, task_option


@click.command("live")
@task_option
@click.option("--model", type=click.Path(path_type=str), help="Model folder.",
              show_default="the bundled one for --task")  # fmt: skip
@click.option("--wrench-topic", required=True, help="The sensor's WrenchStamped topic.")
@click.option("--twist-topic", help="The gripper's TwistStamped topic, for the velocity.")
@click.option("--pose-topic", help="The gripper's PoseStamped topic (velocity by "
              "differentiation if no twist; needed by --wrench-frame pose).")  # fmt: skip
@signal_options
@click.option("-o", "--output", type=click.Path(path_type=str),
              help="Record the session as a trial (.mcap), ended by Ctrl-C/SIGTERM.")  # fmt: skip
@click.option("--overwrite", is_flag=True, help="Replace OUTPUT if it exists.")
@click.option("--connect", metavar="URL", help="Also stream to a Rerun viewer at this gRPC URL "
              "(rerun+http://HOST:9876/proxy), as `view` draws it.")  # fmt: skip
@click.option("--high-force", "high_force_n", type=FiniteRange(0, min_open=True),
              default=HIGH_FORCE_N, show_default=True, metavar="N",
              help="The summary flags a total estimated force above N newtons.")  # fmt: skip
@click.option("--wait", "wait_s", type=FiniteRange(0, min_open=True), default=WAIT_S,
              show_default=True, metavar="SECONDS",
              help="Give up if a topic stays silent this long at the start.")  # fmt: skip
@click.option("--frame-id", default="world", show_default=True,
              help="Frame of the published force and contact maps.")  # fmt: skip
@click.option("--prefix", default=PREFIX, show_default=True,
              help="Topics published: PREFIX/force_map, /contact_map, /summary.")  # fmt: skip
@click.option("--best-effort", is_flag=True,
              help="Subscribe best effort, as a sensor-data QoS publisher needs.")  # fmt: skip
@reports_errors
def live(**options: object) -> None:
    """Estimate the force map from a robot's ROS 2 stream as it arrives, and publish it."""
    from dresslog.convert import OptionError
    from dresslog.live import LiveOptions, run_live

    try:
        settings = LiveOptions.build(**options)  # type: ignore[arg-type]
    except OptionError as err:  # options that contradict each other: how the command is used
        raise click.UsageError(str(err)) from None
    report = run_live(settings, announce=lambda line: click.echo(line, err=True))
    click.echo(report.summary())
