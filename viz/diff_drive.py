"""Rerun views of a differential-drive analysis: ground truth vs dead-reckoned paths (nominal
and calibrated) per run, and each method's parameters with 95 % intervals. Draws only what the
analysis carries (``result.artifacts["trajectories"]``, ``result.methods``)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from calib.results import AnalysisResult

__all__ = ["log_views"]

_COLOURS = {"truth": (40, 40, 40), "nominal": (220, 60, 60), "calibrated": (40, 120, 220)}


def _path_name(name: str) -> str:
    return Path(name).stem.replace(".", "_") or "run"


def log_views(recording_path: Path, loaded: Any, result: AnalysisResult, **_: Any) -> Path:
    """Write the .rrd to ``recording_path`` and return it."""
    out = Path(recording_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream("logcal_diff_drive")
    rec.save(out)
    try:
        trajectories = result.artifacts.get("trajectories", {})
        for run_name, paths in trajectories.items():
            base = f"world/{_path_name(run_name)}"
            for label, arr in paths.items():
                xy = np.column_stack([np.asarray(arr["x"]), np.asarray(arr["y"])])
                rec.log(
                    f"{base}/{label}",
                    rr.LineStrips2D([xy], colors=[_COLOURS.get(label, (0, 0, 0))], labels=[label]),
                    static=True,
                )
        for m in result.methods:
            for name, e in m.parameters.items():
                if not math.isfinite(e.value):
                    continue
                lo, hi = e.ci95
                rec.log(
                    f"methods/{name}/{m.method}",
                    rr.TextLog(
                        f"{e.value * 1e3:.3f} mm [95 %: {lo * 1e3:.3f}, {hi * 1e3:.3f}]"
                        if math.isfinite(lo) and math.isfinite(hi)
                        else f"{e.value * 1e3:.3f} mm (no interval)"
                    ),
                    static=True,
                )
                rec.log(
                    f"method_bars/{name}",
                    rr.Points2D(
                        [[len(result.methods) and result.methods.index(m), e.value]],
                        labels=[m.method],
                    ),
                    static=True,
                )
                if math.isfinite(lo) and math.isfinite(hi):
                    x = result.methods.index(m)
                    rec.log(
                        f"method_bars/{name}/{m.method}_ci",
                        rr.LineStrips2D([[[x, lo], [x, hi]]]),
                        static=True,
                    )
    finally:
        rec.flush()
        rec.disconnect()
    return out
