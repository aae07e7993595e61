"""`logcal info LOG... [--json]`: topics, types, counts, rates, time span, signals found, robot."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer

from logtools.cli._inputs import (
    channel_map_option,
    end_option,
    ground_truth_option,
    logs_argument,
    signal_option,
    start_option,
)

_LOGS = logs_argument()
_CHANNEL_MAP = channel_map_option()
_SIGNAL = signal_option()
_GROUND_TRUTH = ground_truth_option()

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the `info` command to ``app``."""

    @app.command("info")
    def _cmd(
        logs: list[Path] = _LOGS,
        as_json: bool = typer.Option(
            False, "--json", help="Print a JSON document instead (several logs: one 'logs' list)."
        ),
        channel_map: Path | None = _CHANNEL_MAP,
        signal: list[str] | None = _SIGNAL,
        ground_truth: Path | None = _GROUND_TRUTH,
        start: float | None = start_option(),
        end: float | None = end_option(),
        urdf: str | None = typer.Option(
            None, "--urdf", metavar="PATH_OR_NAME",
            help="An arm's URDF file or example-robot-data name: also list its transmissions "
            "(what --effort actuator uses)."),
    ) -> None:
        """Show what a log holds: topics, types, counts, rates, signals found, robot, problems."""
        from logtools.cli._inputs import read_inputs, say
        from logtools.loginfo import summarize_log
        from logtools.recordings import distinct_recordings

        inputs = read_inputs(logs, channel_map=channel_map, signals=signal,
                             ground_truth=ground_truth, start=start, end=end, dedupe=False)
        summaries = [summarize_log(run, inputs.channel_map) for run in inputs.runs]
        trans = _transmissions(urdf) if urdf else None
        same = distinct_recordings(inputs.runs, inputs.channel_map)[1] if len(
            inputs.runs) > 1 else []
        if as_json:
            doc: dict[str, Any] = (
                summaries[0].to_dict() if len(summaries) == 1 else {
                    "logs": [s.to_dict() for s in summaries],
                    "same_recordings": [
                        {"kept": str(g.kept), "same": [str(p) for p in g.same],
                         "evidence": g.evidence} for g in same
                    ],
                }
            )
            if trans is not None:
                doc["urdf"] = trans
            typer.echo(json.dumps(doc, indent=2))
            return
        typer.echo("\n\n".join(s.report() for s in summaries))
        if trans is not None:
            shown = [f"  {t['line']}" for t in trans["transmissions"]] or ["  none"]
            for line in [f"Transmissions in {trans['source']}:", *shown]:
                say(line, stderr=False)  # each line escaped on its own
        for group in same:
            say(f"note: {group.sentence('analyse it once')}", stderr=False)


def _transmissions(urdf: str) -> dict[str, Any]:
    """The URDF's transmissions (``calib.manipulator.serial.read_transmissions``) as JSON, each
    with its line for people."""
    from calib.errors import CalibError
    from calib.manipulator.serial import read_transmissions, urdf_path
    from logtools.errors import LogcalInputError

    try:
        path = urdf_path(urdf)
        found = read_transmissions(path)
    except CalibError as err:
        raise LogcalInputError(f"--urdf {urdf}: {err}") from err
    return {"source": str(path), "transmissions": [
        {**t.to_dict(), "simple": t.simple, "line": t.describe()} for t in found]}
