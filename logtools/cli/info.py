"""`logcal info LOG [--json]`: topics, types, counts, rates, time span, signals found, robot."""

from __future__ import annotations

import json
from pathlib import Path

import typer

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the `info` command to ``app``."""

    @app.command("info")
    def _cmd(
        log: Path = typer.Argument(
            ..., help="Drive log: MCAP, CSV or a ROS bag (rosbag2 folder or .bag)."
        ),
        as_json: bool = typer.Option(False, "--json", help="Print a JSON document instead."),
        channel_map: Path | None = typer.Option(
            None, "--channel-map", help="TOML mapping topics/fields to logical signals."
        ),
    ) -> None:
        """Show what a log holds: topics, types, counts, rates, signals found, robot, problems."""
        from logtools.channel_map import load_channel_map
        from logtools.loginfo import summarize_log

        mapping = load_channel_map(channel_map) if channel_map is not None else None
        summary = summarize_log(log, mapping)
        if as_json:
            typer.echo(json.dumps(summary.to_dict(), indent=2))
        else:
            typer.echo(summary.report())
