"""Entry points the robot plugins name for their views (``RobotPlugin.views``/``png``).

Each takes ``(out_path, loaded, result, **options)`` and returns the file written; ``loaded`` is
the read log (its aligned ``frame``), ``result`` the analysis; they draw what those carry."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from calib.results import AnalysisResult

__all__ = ["tractor_trailer_png", "tractor_trailer_rrd"]


def tractor_trailer_rrd(
    out: Path, loaded: Any, result: AnalysisResult, method_for_psi: str | None = None
) -> Path:
    """The tractor-trailer's rerun recording (world, ICR construction, signals, methods);
    ``method_for_psi`` names the method whose lengths drew the steady-state joint angle (the
    analysis computed it: ``AnalysisConfig.extra["method_for_psi"]``)."""
    from viz.tractor_trailer.recording import write_recording

    return write_recording(out, loaded.frame, result, method_for_psi=method_for_psi)


def tractor_trailer_png(out: Path, loaded: Any, result: AnalysisResult) -> Path:
    """The tractor-trailer's static report image."""
    from viz.tractor_trailer.plots import write_report_png

    write_report_png(out, loaded.frame, result)
    return out
