"""``logcal reproduce``: published results recomputed from their own scenario, one subcommand per
robot's publication (``RobotPlugin.reproduce``: ``patent`` of the tractor-trailer, ``wmr`` of the
differential drive, ``momentum`` of the arm). The group is rebuilt from the plugins registered
when the command line is built (:func:`sync`)."""

from __future__ import annotations

import typer

__all__ = ["register", "sync"]

_GROUP = typer.Typer(
    name="reproduce",
    help="Reproduce published results from their own scenario.",
    invoke_without_command=True,
    rich_markup_mode=None,
)


@_GROUP.callback()
def _group(ctx: typer.Context) -> None:
    """Reproduce published results from their own scenario."""
    if ctx.invoked_subcommand is None:  # bare ``logcal reproduce``: its help, success
        typer.echo(ctx.get_help())
        raise typer.Exit(0)


def sync() -> None:
    """(Re)build the group's subcommands from the registered robots."""
    from logtools.robots import plugins
    from logtools.robots.base import load_commands

    _GROUP.registered_commands.clear()
    for plugin in plugins():
        if plugin.reproduce is not None:
            load_commands(plugin.reproduce)(_GROUP)


def register(app: typer.Typer) -> None:
    """Add the ``reproduce`` command group to ``app``."""
    sync()
    app.add_typer(_GROUP, name="reproduce")
