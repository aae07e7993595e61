"""``logcal analyze LOG``: calibrate, report with uncertainty, discover model mismatch."""

from __future__ import annotations

import json
import sys
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import typer
from rich.console import Console
from rich.text import Text

from calib.results import Baseline
from logtools.cli._inputs import (
    LOGS_HELP,
    channel_map_option,
    cutoff_option,
    end_option,
    ground_truth_option,
    logs_argument,
    signal_option,
    start_option,
    urdf_option,
)
from logtools.errors import LogcalInputError

_LOGS = logs_argument(
    LOGS_HELP + " Several runs of one robot are also pooled into one estimate; files holding the "
    "same recording are counted once."
)
_CHANNEL_MAP = channel_map_option()
_SIGNAL = signal_option()
_GROUND_TRUTH = ground_truth_option()

__all__ = ["register", "write_views"]


def register(app: typer.Typer) -> None:
    """Add the ``analyze`` command to ``app``."""

    @app.command("analyze")
    def analyze(
        logs: list[Path] = _LOGS,
        as_json: bool = typer.Option(False, "--json", help="Print one JSON document."),
        rrd: Path | None = typer.Option(
            None, "--rrd", metavar="FILE.rrd",
            help="Save a rerun recording here (several runs: one file holding every run).",
        ),
        png: Path | None = typer.Option(
            None, "--png", metavar="FILE.png",
            help="Save a static PNG of the main views (default: beside --rrd; one run only).",
        ),
        repeats: int = typer.Option(
            10, "--repeats", min=1, metavar="N", help="Bootstrap repeats per method."
        ),
        baseline: Baseline = typer.Option(
            Baseline.TRANSIENT, "--baseline",
            help="Discovery baseline of the tractor-trailer: transient (default) or steady "
            "(the patent's view).",
        ),
        urdf: str | None = urdf_option(),
        cutoff_hz: float | None = cutoff_option(),
        channel_map: Path | None = _CHANNEL_MAP,
        signal: list[str] | None = _SIGNAL,
        ground_truth: Path | None = _GROUND_TRUTH,
        start: float | None = start_option(),
        end: float | None = end_option(),
        no_discovery: bool = typer.Option(False, "--no-discovery", help="Skip discovery."),
        discovery_span: float | None = typer.Option(
            None, "--discovery-span", min=0.0, metavar="SECONDS",
            help="Seconds of a long tractor-trailer log discovery looks at, in windows spread "
            "over it (default 600; 0: all of it, slower).",
        ),
        seed: int = typer.Option(0, "--seed", metavar="N", help="Seed of the bootstrap draws."),
        methods: bool = typer.Option(
            False, "--methods", "-v",
            help="Also print every method's table and the robot's diagnostics (the report "
            "opens with the answer either way).",
        ),
        quiet: bool = typer.Option(
            False, "--quiet", "-q",
            help="Print only the answer: the recommended estimate and whether the model "
            "explains the log.",
        ),
    ) -> None:
        """Calibrate the robot's parameters from LOG(s) and explain model mismatch."""
        from logtools.analyze import AnalysisConfig, analyze_logs
        from logtools.cli._inputs import read_inputs, say, unused_options
        from logtools.outputs import check_output
        from logtools.report import print_analysis
        from logtools.safe_text import printable

        inputs = read_inputs(logs, channel_map=channel_map, signals=signal,
                             ground_truth=ground_truth, start=start, end=end)
        runs = inputs.runs
        every = [Path(r) for r in runs] + [g for s in inputs.same for g in s.same] + list(logs)
        if rrd is not None:
            check_output(rrd, option="--rrd", suffixes=(".rrd",), inputs=every)
        if png is not None:
            check_output(png, option="--png", suffixes=(".png",), inputs=every)
            if len(runs) > 1:
                raise LogcalInputError(
                    f"--png {png}: a report image shows one run and {len(runs)} runs were given; "
                    "give one log, or use --rrd (one recording file holds every run)"
                )
        cfg = AnalysisConfig(
            repeats=repeats, baseline=baseline, seed=seed, discovery=not no_discovery,
            debug=_debug(),
            extra=({"urdf": urdf} if urdf else {})
            | ({"cutoff_hz": cutoff_hz} if cutoff_hz is not None else {})
            | ({"discovery_span_s": discovery_span} if discovery_span is not None else {}),
        )
        err = Console(stderr=True)
        from calib.tractor_trailer.models.hitch_rk4 import compiled_available

        if not compiled_available():
            err.print(
                "logcal: the compiled integrator (calib/tractor_trailer/models/_hitch_rk4.c) is "
                "not built here; "
                "analysing on its numpy loop, about 5x slower (pip install . builds it)",
                markup=False,
            )
        if sys.stderr.isatty():
            with err.status("analysing", spinner="dots") as status:
                loadeds, result = analyze_logs(
                    runs, channel_map=inputs.channel_map, config=cfg,
                    progress=lambda s: status.update(Text(s)),
                )
        else:
            loadeds, result = analyze_logs(runs, channel_map=inputs.channel_map, config=cfg)
        unused = unused_options(str(result.robot), {
            "--urdf": urdf, "--cutoff-hz": cutoff_hz, "--discovery-span": discovery_span,
            "--baseline": baseline if baseline is not Baseline.TRANSIENT else None,
            "--ground-truth": ground_truth,
        })
        for warning in unused:
            say(f"logcal: warning: {warning}")
        if inputs.same or unused:
            result = replace(
                result,
                warnings=[*inputs.notes, *unused, *result.warnings],
                source={**result.source, "same_recordings": [
                    {"kept": str(g.kept), "same": [str(p) for p in g.same],
                     "evidence": g.evidence} for g in inputs.same
                ]},
            )
        if rrd is not None or png is not None:
            write_views(loadeds, result, rrd=rrd, png=png, inputs=every,
                        implicit_png=png is None)
        if as_json:
            sys.stdout.write(json.dumps(result.to_dict(), indent=2) + "\n")
        else:
            print_analysis(result, detail="quiet" if quiet else "methods" if methods
                           else "answer")
        bad = result.source.get("errors") or []
        if bad:
            for message in bad:
                err.print(f"logcal: error: {printable(message)}", markup=False,
                          highlight=False)
            raise typer.Exit(2)


def write_views(
    loadeds: list[Any],
    result: Any,
    *,
    rrd: Path | None,
    png: Path | None,
    inputs: list[Path],
    implicit_png: bool = False,
    options: dict[str, Any] | None = None,
) -> Path | None:
    """Write the robot's rerun recording to ``rrd`` (several runs: one file holding each run's
    recording) and its report image to ``png`` (or beside ``rrd`` when ``implicit_png``; one
    run only); say what was written on stderr. Returns the .rrd written, if any.

    Raises:
        LogcalInputError: the robot has no rerun views and ``rrd`` was asked for, or the runs'
            recordings could not be merged.
    """
    from logtools.cli._inputs import say
    from logtools.outputs import check_output, write_atomically
    from logtools.recordings import merge_recordings
    from logtools.robots import plugin_for
    from logtools.robots.base import load_view

    plugin = plugin_for(result.robot)
    per_run = result.runs or [result]
    extra = options or {}
    written = None
    if rrd is not None:
        if plugin.views is None:
            say(f"logcal: the {plugin.title} has no rerun recording yet; not written")
        else:
            out = check_output(rrd, option="--rrd", suffixes=(".rrd",), inputs=inputs)
            draw = load_view(plugin.views)

            def write_all(tmp: Path) -> Path:
                if len(per_run) == 1:
                    return draw(tmp, loadeds[0], per_run[0], **extra)
                with tempfile.TemporaryDirectory(prefix=".logcal-runs-", dir=tmp.parent) as d:
                    parts = [
                        draw(Path(d) / f"run{i + 1}.rrd", lo, res, **extra)
                        for i, (lo, res) in enumerate(zip(loadeds, per_run, strict=True))
                    ]
                    return merge_recordings(parts, tmp)

            write_atomically(out, write_all)
            runs_note = f" ({len(per_run)} runs, one recording each)" if len(per_run) > 1 else ""
            say(f"rerun recording saved: {out}{runs_note}")
            written = out
    png_path = png if png is not None else (
        rrd.with_suffix(".png") if rrd is not None and implicit_png else None
    )
    if png_path is not None:
        if len(per_run) > 1:
            say(f"logcal: no report image: {png_path} would show one run of {len(per_run)}")
        elif plugin.png is None:
            say(f"logcal: the {plugin.title} has no report image yet; not written")
        else:
            out = check_output(png_path, option="--png", suffixes=(".png",), inputs=inputs)
            draw_png = load_view(plugin.png)
            write_atomically(out, lambda tmp: draw_png(tmp, loadeds[0], per_run[0]))
            say(f"report image saved: {out}")
    return written


def _debug() -> bool:
    from logtools.cli.state import debug_enabled

    return debug_enabled()
