"""``logcal view LOG...``: analyse the log(s), save a rerun recording and open the viewer if one
can start (without a display, say so plainly and where the recording is)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import typer

from logtools.cli._inputs import (
    channel_map_option,
    end_option,
    ground_truth_option,
    logs_argument,
    signal_option,
    start_option,
    t_max_diff_option,
    t_offset_option,
)
from logtools.cli._robot_options import GivenOptions, with_robot_options

_LOGS = logs_argument()
_CHANNEL_MAP = channel_map_option()
_SIGNAL = signal_option()
_GROUND_TRUTH = ground_truth_option()

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``view`` command to ``app``."""

    @app.command("view")
    @with_robot_options("view")
    def view(
        logs: list[Path] = _LOGS,
        rrd: Path | None = typer.Option(
            None,
            "--rrd",
            metavar="FILE.rrd",
            help="Where to save the recording (default: the first LOG with suffix .rrd; "
            "several runs: one file holding every run).",
        ),
        no_viewer: bool = typer.Option(False, "--no-viewer", help="Only save the recording."),
        repeats: int = typer.Option(
            10, "--repeats", min=1, metavar="N", help="Bootstrap repeats per method."
        ),
        channel_map: Path | None = _CHANNEL_MAP,
        signal: list[str] | None = _SIGNAL,
        ground_truth: Path | None = _GROUND_TRUTH,
        t_offset: str | None = t_offset_option(),
        t_max_diff: float | None = t_max_diff_option(),
        start: float | None = start_option(),
        end: float | None = end_option(),
        *,
        robot_options: GivenOptions,
    ) -> None:
        """Show LOG in the rerun viewer (or save the .rrd and say where when none can start)."""
        from logtools.analyze import AnalysisConfig, analyze_logs
        from logtools.cli._inputs import read_inputs, say
        from logtools.cli._robot_options import general_warnings
        from logtools.cli.analyze import say_written
        from logtools.errors import LogcalInputError
        from logtools.outputs import check_output
        from logtools.robots import plugin_for
        from logtools.views import write_views
        from viz.viewer import can_start_viewer, open_viewer

        viewer_missing = None if no_viewer else _why_no_viewer(can_start_viewer())
        if viewer_missing is not None:  # said before any work: the user may stop here
            say(
                f"logcal: {viewer_missing}, so the viewer cannot open; the recording will only "
                "be saved (--no-viewer says you want just that)",
                stderr=False,
            )
        inputs = read_inputs(
            logs,
            channel_map=channel_map,
            signals=signal,
            ground_truth=ground_truth,
            t_offset=t_offset,
            t_max_diff=t_max_diff,
            start=start,
            end=end,
        )
        first, given = Path(inputs.runs[0]), logs[0]
        every = [Path(r) for r in inputs.runs] + list(logs)
        default = (
            given.with_suffix(".rrd")
            if given.is_file()
            else given.resolve().with_name(given.resolve().name + ".rrd")
        )  # a folder's recording beside it
        target = check_output(rrd or default, option="--rrd", suffixes=(".rrd",), inputs=every)
        for note in inputs.notes:
            say(f"logcal: {note}")
        cfg = AnalysisConfig(
            repeats=repeats, robot_options=robot_options.by_robot(), window_s=0.0
        )  # the views draw every sample: never by windows
        loadeds, result = analyze_logs(inputs.runs, channel_map=inputs.channel_map, config=cfg)
        plugin = plugin_for(result.robot)
        for warning in robot_options.unused(plugin) + general_warnings(
            plugin,
            {
                "--ground-truth": ("pose", ground_truth),
            },
        ):
            say(f"logcal: warning: {warning}")
        if plugin.views is None:
            raise LogcalInputError(f"{first}: the {plugin.title} has no rerun views yet.")
        written = write_views(loadeds, result, rrd=target, png=None, inputs=every, config=cfg)
        say_written(written)
        out = written.rrd
        assert out is not None  # the plugin has views
        if no_viewer:
            return
        if viewer_missing is not None:
            say(
                f"logcal: {viewer_missing}; the recording is saved as {out}: open it where a "
                f"viewer can start with: rerun {out}",
                stderr=False,
            )
            return
        viewer = open_viewer(out)
        if viewer is None:
            say(
                f"logcal: the rerun viewer did not start (or did not answer within 20 s); the "
                f"recording is saved as {out}: open it with: rerun {out}",
                stderr=False,
            )
        else:
            say(
                f"viewer started (pid {viewer.process.pid}, listening on "
                f"{viewer.host}:{viewer.port} only) on {out}",
                stderr=False,
            )


def _why_no_viewer(display: bool) -> str | None:
    """Why the rerun viewer cannot start here (``display``: whether there is a display), or
    None when it can: no display, or no rerun viewer installed."""
    if not display:
        return "no display here (neither DISPLAY nor WAYLAND_DISPLAY is set)"
    if importlib.util.find_spec("rerun") is None:
        return "no rerun viewer is installed (pip install rerun-sdk)"
    return None
