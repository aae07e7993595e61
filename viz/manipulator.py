"""rerun views of an arm analysis: the arm drawn moving (forward-kinematics points carried in the
result), measured vs predicted torque per joint on the held-out part, and the parameter
convergence of the recursive estimators. Draws only what ``result.artifacts`` carries."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from calib.results import AnalysisResult

__all__ = ["log_views"]


def log_views(recording_path: str | Path, loaded: Any, result: AnalysisResult) -> Path:
    """Save the arm's views of ``result`` to ``recording_path`` (.rrd); ``loaded`` is unused
    (the arrays drawn are in ``result.artifacts``)."""
    art = result.artifacts
    out = Path(recording_path)
    out.parent.mkdir(parents=True, exist_ok=True)
    rec = rr.RecordingStream("logcal")
    rec.save(out)
    try:
        rec.log(
            "summary", rr.TextDocument(_summary(result), media_type="text/markdown"), static=True
        )
        if "points" in art:
            for t, pts in zip(art["t_s"], art["points"], strict=True):
                rec.set_time("time", duration=float(t))
                rec.log("arm/links", rr.LineStrips3D([pts]))
                rec.log("arm/joints", rr.Points3D(pts, radii=0.01))
        names = art.get("joint_names", [])
        if "holdout_t_s" in art:
            meas, pred = art["holdout_measured"], art["holdout_predicted"]
            for k, t in enumerate(art["holdout_t_s"]):
                rec.set_time("time", duration=float(t))
                for j, name in enumerate(names):
                    rec.log(f"torque/{name}/measured", rr.Scalars(float(meas[k, j])))
                    rec.log(f"torque/{name}/predicted", rr.Scalars(float(pred[k, j])))
        pnames = art.get("parameter_names", [])
        for est, traj in art.get("trajectories", {}).items():
            for k, t in enumerate(art["trajectory_t_s"]):
                rec.set_time("time", duration=float(t))
                for p, name in enumerate(pnames):
                    v = float(traj[k, p])
                    if np.isfinite(v):
                        rec.log(f"convergence/{est}/{_safe(name)}", rr.Scalars(v))
    finally:
        rec.flush()
        rec.disconnect()
    return out


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "_-" else "_" for c in name)[:60]


def _summary(result: AnalysisResult) -> str:
    s = result.sections
    lines = [f"# {result.robot}: {', '.join(s.get('joints', []))}"]
    if "torque_rms_holdout_ratio" in s:
        lines.append(f"Held-out torque error: {100 * s['torque_rms_holdout_ratio']:.1f} % of RMS")
    if result.estimate is not None:
        lines += ["```", result.estimate.report(), "```"]
    return "\n\n".join(lines)
