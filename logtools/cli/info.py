"""`logcal info LOG... [--json]`: topics, types, counts, rates, time span, signals found, robot;
and what each robot says of the options ``info`` takes (declared ``option(..., info=True)``,
answered by the robot's ``RobotPlugin.info`` hook, e.g. an arm's URDF transmissions)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

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
from logtools.safe_text import no_nan

if TYPE_CHECKING:
    from logtools.robots.info import InfoSection

_LOGS = logs_argument()
_CHANNEL_MAP = channel_map_option()
_SIGNAL = signal_option()
_GROUND_TRUTH = ground_truth_option()

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the `info` command to ``app``."""

    @app.command("info")
    @with_robot_options("info")
    def _cmd(
        logs: list[Path] = _LOGS,
        as_json: bool = typer.Option(
            False, "--json", help="Print a JSON document instead (several logs: one 'logs' list)."
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
        """Show what a log holds: topics, types, counts, rates, signals found, robot, problems."""
        from logtools.cli._inputs import read_inputs, say
        from logtools.loginfo import summarize_log
        from logtools.recordings import distinct_recordings

        inputs = read_inputs(
            logs,
            channel_map=channel_map,
            signals=signal,
            ground_truth=ground_truth,
            t_offset=t_offset,
            t_max_diff=t_max_diff,
            start=start,
            end=end,
            dedupe=False,
        )
        summaries = [summarize_log(run, inputs.channel_map) for run in inputs.runs]
        sections = _robot_sections(robot_options)
        same = (
            distinct_recordings(inputs.runs, inputs.channel_map)[1] if len(inputs.runs) > 1 else []
        )
        if as_json:
            doc: dict[str, Any] = (
                summaries[0].to_dict()
                if len(summaries) == 1
                else {
                    "logs": [s.to_dict() for s in summaries],
                    "same_recordings": [
                        {
                            "kept": str(g.kept),
                            "same": [str(p) for p in g.same],
                            "evidence": g.evidence,
                        }
                        for g in same
                    ],
                }
            )
            for section in sections:
                doc[section.key] = dict(section.doc)
            typer.echo(json.dumps(doc, indent=2))
            return
        typer.echo(no_nan("\n\n".join(s.report() for s in summaries)))
        for section in sections:
            for line in section.lines:
                say(line, stderr=False)  # each line escaped on its own
        for group in same:
            say(f"note: {group.sentence('analyse it once')}", stderr=False)


def _robot_sections(given: GivenOptions) -> list[InfoSection]:
    """What each robot given options says of them (its ``RobotPlugin.info`` hook), in
    registry order."""
    from logtools.robots import plugins
    from logtools.robots.info import load_info

    built = given.by_robot()
    out = []
    for plugin in plugins():
        if plugin.name in built and plugin.info is not None:
            section = load_info(plugin.info)(built[plugin.name])
            if section is not None:
                out.append(section)
    return out
