"""A robot's views of an analysis written to files: its rerun recording (several runs: one file
holding each run's recording) and its static report image, through its plugin only
(``RobotPlugin.views``/``png``, imported by path so that ``logtools`` never imports rerun).

One function for every caller (``logcal analyze --rrd/--png``, ``logcal view``, the batch).
The library never prints: what was written and what was not, and why, is returned
(:class:`WrittenViews`) for the caller to say.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from logtools.outputs import check_output, write_atomically
from logtools.robots import plugin_for
from logtools.robots.base import load_view, load_views

if TYPE_CHECKING:
    from calib.results import AnalysisResult
    from logtools.analyze import AnalysisConfig
    from logtools.load import LoadedLog
    from logtools.robot_options import RobotOptions

__all__ = ["WrittenViews", "write_views"]


@dataclass(frozen=True)
class WrittenViews:
    """What :func:`write_views` wrote.

    Attributes:
        rrd: the rerun recording written (None: none).
        png: the report image written (None: none).
        messages: in order, ``("saved", sentence)`` for a file written and ``("note",
            sentence)`` for one not written and why (no views for this robot, several runs for
            one image, a view that failed with ``on_error="note"``).
    """

    rrd: Path | None = None
    png: Path | None = None
    messages: list[tuple[Literal["saved", "note"], str]] = field(default_factory=list)

    @property
    def notes(self) -> list[str]:
        """The sentences of what was not written."""
        return [text for kind, text in self.messages if kind == "note"]


def _has_answer(result: AnalysisResult) -> bool:
    """Whether a pooled ``result`` carries an answer of its own (methods or an estimate)."""
    return bool(result.runs) and (result.estimate is not None or bool(result.methods))


def write_views(
    loadeds: Sequence[LoadedLog],
    result: AnalysisResult,
    *,
    rrd: Path | None,
    png: Path | None,
    inputs: Sequence[Path] = (),
    implicit_png: bool = False,
    config: AnalysisConfig | None = None,
    options: RobotOptions | None = None,
    on_error: Literal["raise", "note"] = "raise",
) -> WrittenViews:
    """Write the robot's rerun recording to ``rrd`` (several runs: one file holding each run's
    recording, and the pooled answer's when there is one, each under its own application id so
    that the viewer shows each through its own layout) and its report image to ``png`` (or
    beside ``rrd`` when ``implicit_png``; one run only). Output paths are checked against
    ``inputs`` and written atomically.

    The views get the robot's own options: ``options`` when given, else those of ``config``
    (``config.options(plugin.options)``), else the defaults.

    ``on_error="note"`` turns a view that fails into a note (the batch: the analysis stands);
    ``"raise"`` lets it raise.

    Raises:
        LogcalInputError: an output path logcal may not write, or (``on_error="raise"``) the
            runs' recordings could not be merged or a view named an unknown method.
    """
    from logtools.recordings import merge_recordings

    plugin = plugin_for(result.robot)
    per_run = result.runs or [result]
    if options is None or not isinstance(options, plugin.options):
        options = config.options(plugin.options) if config is not None else plugin.options()
    messages: list[tuple[Literal["saved", "note"], str]] = []
    written_rrd: Path | None = None
    written_png: Path | None = None
    if rrd is not None:
        if plugin.views is None:
            messages.append(("note", f"the {plugin.title} has no rerun recording yet; not written"))
        else:
            out = check_output(rrd, option="--rrd", suffixes=(".rrd",), inputs=inputs)
            draw = load_views(plugin.views)
            opts = options

            def write_all(tmp: Path) -> Path:
                if len(per_run) == 1:
                    return draw(tmp, loadeds[0], per_run[0], opts)
                with tempfile.TemporaryDirectory(prefix=".logcal-runs-", dir=tmp.parent) as d:
                    parts = [
                        draw(Path(d) / f"run{i + 1}.rrd", lo, res, opts)
                        for i, (lo, res) in enumerate(zip(loadeds, per_run, strict=True))
                    ]
                    if _has_answer(result):  # the pooled answer: its own recording
                        parts.append(draw(Path(d) / "pooled.rrd", loadeds[0], result, opts))
                    return merge_recordings(parts, tmp)

            try:
                write_atomically(out, write_all)
            except Exception as err:
                if on_error == "raise":
                    raise
                messages.append(("note", f"rerun recording not drawn: {type(err).__name__}: {err}"))
            else:
                pooled_note = " and the pooled answer" if _has_answer(result) else ""
                runs_note = (
                    f" ({len(per_run)} runs, one recording each{pooled_note})"
                    if len(per_run) > 1
                    else ""
                )
                messages.append(("saved", f"rerun recording saved: {out}{runs_note}"))
                written_rrd = out
    png_path = (
        png
        if png is not None
        else (rrd.with_suffix(".png") if rrd is not None and implicit_png else None)
    )
    if png_path is not None:
        if len(per_run) > 1:
            messages.append(
                ("note", f"no report image: {png_path} would show one run of {len(per_run)}")
            )
        elif plugin.png is None:
            messages.append(("note", f"the {plugin.title} has no report image yet; not written"))
        else:
            out = check_output(png_path, option="--png", suffixes=(".png",), inputs=inputs)
            draw_png = load_view(plugin.png)
            try:
                write_atomically(out, lambda tmp: draw_png(tmp, loadeds[0], per_run[0]))
            except Exception as err:
                if on_error == "raise":
                    raise
                messages.append(("note", f"report image not drawn: {type(err).__name__}: {err}"))
            else:
                messages.append(("saved", f"report image saved: {out}"))
                written_png = out
    return WrittenViews(written_rrd, written_png, messages)
