"""logcal ingest, alignment, segmentation, CLI and reports: reads logs and orchestrates.

The public Python API, in the manner of rosbags' ``AnyReader`` or mcap's ``make_reader``: load a
log, analyse it, read the result::

    import logtools

    loaded, result = logtools.analyze_log("sample_logs/tt_mixed.mcap")
    for name, e in result.estimate.parameters.items():
        print(name, e.value, e.ci95, e.identifiable)

Names are imported on first use (``import logtools`` stays cheap for the command line).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "AnalysisConfig",
    "AnalysisResult",
    "CalibrationResult",
    "Estimate",
    "LoadedLog",
    "LogcalInputError",
    "analyze_loaded",
    "analyze_log",
    "analyze_logs",
    "load_log",
]

_WHERE = {
    "AnalysisConfig": "logtools.analysis_config",
    "AnalysisResult": "calib.results",
    "CalibrationResult": "calib.results",
    "Estimate": "calib.results",
    "LoadedLog": "logtools.loaded",
    "LogcalInputError": "logtools.errors",
    "analyze_log": "logtools.analyze",
    "analyze_loaded": "logtools.analyze",
    "analyze_logs": "logtools.analyze",
    "load_log": "logtools.load",
}


def __getattr__(name: str) -> Any:
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module 'logtools' has no attribute {name!r}")
    value = getattr(importlib.import_module(where), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
