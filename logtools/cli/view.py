"""``logcal view LOG``: analyse LOG, save a rerun recording and open the viewer if one can start."""

from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``view`` command to ``app``."""

    @app.command("view")
    def view(
        log: Path = typer.Argument(
            ..., help="Drive log: MCAP, CSV or a ROS bag (rosbag2 folder or .bag)."
        ),
        rrd: Path | None = typer.Option(
            None, "--rrd", help="Where to save the recording (default: LOG with suffix .rrd)."
        ),
        method: str | None = typer.Option(
            None, "--method", help="Also show psi predicted by this method (e.g. OLS1(EM1))."
        ),
        no_viewer: bool = typer.Option(False, "--no-viewer", help="Only save the recording."),
        repeats: int = typer.Option(10, "--repeats", min=1, help="Bootstrap repeats per method."),
        channel_map: Path | None = typer.Option(
            None, "--channel-map", help="TOML mapping topics/fields to logical signals."
        ),
    ) -> None:
        """Show LOG in the rerun viewer (or save the .rrd and say where when none can start)."""
        from logtools.analyze import AnalysisConfig, analyze_log
        from logtools.channel_map import load_channel_map
        from logtools.errors import LogcalInputError
        from logtools.outputs import check_output, write_atomically
        from logtools.robots import plugin_for
        from logtools.robots.base import load_view
        from viz.viewer import open_viewer

        target = check_output(
            rrd or log.with_suffix(".rrd"), option="--rrd", suffixes=(".rrd",), inputs=[log]
        )
        cmap = load_channel_map(channel_map) if channel_map else None
        extra = {"method_for_psi": method} if method else {}
        loaded, result = analyze_log(
            log, channel_map=cmap, config=AnalysisConfig(repeats=repeats, extra=extra)
        )
        plugin = plugin_for(result.robot)
        if plugin.views is None:
            raise LogcalInputError(f"{log}: the {plugin.title} has no rerun views yet.")
        draw = load_view(plugin.views)
        write_atomically(target, lambda tmp: draw(tmp, loaded, result, **extra))
        out = target
        viewer = None if no_viewer else open_viewer(out)
        if viewer is None:
            typer.echo(f"rerun recording saved: {out} (open it with: rerun {out})")
        else:
            typer.echo(
                f"rerun recording saved: {out}; viewer started (pid {viewer.process.pid}, "
                f"listening on {viewer.host}:{viewer.port} only)"
            )
