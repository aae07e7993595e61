"""``logcal simulate``: write simulated drive logs with known truth (LOG_FORMAT.md).

Each robot adds its own subcommand(s) (``RobotPlugin.simulate``); ``logcal simulate samples
[DIR]`` regenerates ``sample_logs/`` from the robots' declared samples (``RobotPlugin.samples``,
:mod:`logtools.sample_logs`). The group is rebuilt from the plugins registered when the command
line is built (:func:`sync`), so a plugin registered at run time brings its command too.
"""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register", "sync"]

_GROUP = typer.Typer(
    name="simulate",
    help="Write simulated drive logs whose true parameters are in the 'logcal' metadata.",
    invoke_without_command=True,
    rich_markup_mode=None,
)


@_GROUP.callback()
def _group(ctx: typer.Context) -> None:
    if ctx.invoked_subcommand is None:  # bare ``logcal simulate``: its help, success
        typer.echo(ctx.get_help())
        raise typer.Exit(0)


def _samples(
    out_dir: Path = typer.Argument(Path("sample_logs"), help="Directory for the logs."),
) -> None:
    """Regenerate every robot's sample logs (same as `python -m logtools.sample_logs DIR`)."""
    from logtools.sample_logs import write_sample_logs

    for path in write_sample_logs(out_dir):
        print(f"{path}  {path.stat().st_size / 1e6:.2f} MB")


def sync() -> None:
    """(Re)build the group's subcommands: each registered robot's, then ``samples``."""
    from logtools.robots import plugins
    from logtools.robots.base import load_commands

    _GROUP.registered_commands.clear()
    for plugin in plugins():
        if plugin.simulate is not None:
            load_commands(plugin.simulate)(_GROUP)
    _GROUP.command("samples")(_samples)


def register(app: typer.Typer) -> None:
    """Add the ``simulate`` command group to ``app``."""
    sync()
    app.add_typer(_GROUP, name="simulate")
