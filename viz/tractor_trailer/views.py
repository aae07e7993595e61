"""Entry points the robot plugins name for their views (``RobotPlugin.views``/``png``).

The rerun views are a ``Views`` (logtools.robots.base) function ``(out, loaded, result, options)``
returning the file written; ``loaded`` is the read log (its aligned ``frame``), ``result`` the
analysis, ``options`` the robot's own options; they draw what those carry. The report image is
``(out, loaded, result)``."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from calib.results import AnalysisResult
from viz.loaded import LoadedLike

__all__ = ["TractorViewOptions", "tractor_trailer_png", "tractor_trailer_rrd"]


class TractorViewOptions(Protocol):
    """The tractor-trailer's view option (its ``TractorTrailerOptions``, read structurally):
    the method whose lengths also draw the joint angle."""

    @property
    def method_for_psi(self) -> str | None: ...


def tractor_trailer_rrd(
    out: Path,
    loaded: LoadedLike,
    result: AnalysisResult,
    options: TractorViewOptions | None = None,
) -> Path:
    """The tractor-trailer's rerun recording (world, ICR construction, signals, methods);
    ``options.method_for_psi`` names the method whose lengths drew the steady-state joint angle
    too (the analysis computed it from the same options). A pooled ``result`` (``runs`` set)
    draws its summary and methods only: ``loaded`` is then one run of several."""
    from viz.tractor_trailer.recording import write_recording

    method = options.method_for_psi if options is not None else None
    if result.runs:  # a pooled answer: its summary and methods, not one run's signals
        return write_recording(out, loaded.frame.head(0), result, views={})
    return write_recording(out, loaded.frame, result, method_for_psi=method, raw=loaded.log.topics)


def tractor_trailer_png(out: Path, loaded: LoadedLike, result: AnalysisResult) -> Path:
    """The tractor-trailer's static report image."""
    from viz.tractor_trailer.plots import write_report_png

    write_report_png(out, loaded.frame, result)
    return out
