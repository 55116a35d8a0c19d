"""The `dresslog` command: a lazy click group, so `--help` never imports torch or pybullet."""

from __future__ import annotations

import importlib
import signal

import click

from dresslog import __version__

#: command name -> "module:attribute"; each module is imported only when its command runs.
COMMANDS = {
    "info": "dresslog.cli.info:info",
    "record": "dresslog.cli.record:record",
    "convert": "dresslog.cli.convert:convert",
    "live": "dresslog.cli.live:live",
    "infer": "dresslog.cli.infer:infer",
    "view": "dresslog.cli.view:view",
    "generate": "dresslog.cli.generate:generate",
    "train": "dresslog.cli.train:train",
    "eval": "dresslog.cli.evaluate:evaluate",
    "sweep": "dresslog.cli.sweep:sweep",
    "export": "dresslog.cli.export:export",
}

HELP = {
    "info": "Summarise a trial, a model folder, a dataset folder or a ROS bag.",
    "record": "Simulate one dressing trial in pybullet and record it to MCAP.",
    "convert": "Convert a ROS bag or force/torque CSV into a dresslog trial.",
    "live": "Estimate the force map from a robot's ROS 2 stream, live.",
    "infer": "Stream trials through the force-map LSTM; write Rerun recordings.",
    "view": "Open a trial or .rrd in the Rerun viewer.",
    "generate": "Simulate many trials in parallel into a dataset folder.",
    "train": "Train a force-map LSTM on a dataset.",
    "eval": "Evaluate a model on a dataset's test (or training) split.",
    "sweep": "Generalisation sweeps over speed and limb rotation.",
    "export": "Write a dataset folder as a LeRobot v3.0 dataset.",
}


class LazyGroup(click.Group):
    """A group whose subcommands are imported on first use."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        """Every command's name, without importing any (`--help` stays fast)."""
        return list(COMMANDS)

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        """The command `cmd_name`, its module imported now; None for an unknown name."""
        if cmd_name not in COMMANDS:
            return None
        module, attribute = COMMANDS[cmd_name].split(":")
        return getattr(importlib.import_module(module), attribute)

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        """The help's command list, from the short texts in `HELP`: no command module imported."""
        with formatter.section("Commands"):
            formatter.write_dl([(name, HELP[name]) for name in self.list_commands(ctx)])


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="dresslog")
def main() -> None:
    """dresslog: simulate robot-assisted dressing, record trials, infer the forces felt."""


def run() -> None:
    """The console script: a kill (SIGTERM) or a closed terminal (SIGHUP, unless `nohup`
    ignores it) stops a command as Ctrl-C does, so what it was writing is removed."""
    from dresslog.stops import stop_signals

    for number in stop_signals():
        signal.signal(number, signal.default_int_handler)
    main()
