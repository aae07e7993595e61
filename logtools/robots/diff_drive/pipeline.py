"""The differential drive's analysis: least-squares odometry calibration, UMBmark, the
gyro's effective track, dead reckoning before / after and discovery, for one log or several runs.

Imported on first analysis (not by the plugin declaration in ``__init__``): it pulls in
:mod:`calib.diff_drive`'s estimators and scipy, which resolving a log's signals never needs.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from calib.diff_drive.data import DriveRun
from calib.diff_drive.dead_reckoning import dead_reckon
from calib.diff_drive.discovery import discover
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odometry_lsq import LsqFit, calibrate_lsq
from calib.diff_drive.skid import effective_track
from calib.diff_drive.umbmark import umbmark, umbmark_result
from calib.errors import InsufficientDataError
from calib.results import AnalysisResult, CalibrationResult
from logtools.load import LoadedLog
from logtools.robots.base import Progress
from logtools.stages import Stages

__all__ = ["NOMINAL_RECORD", "analyze_diff_drive", "nominal_params", "pool_diff_drive"]

NOMINAL_RECORD = "logcal.nominal"
_NOMINAL_KEYS = {
    "wheel_radius_right": ("wheel_radius_right", "r_R", "R"),
    "wheel_radius_left": ("wheel_radius_left", "r_L", "R"),
    "track_width": ("track_width", "b", "track"),
}


def nominal_params(loaded: LoadedLog) -> DiffDriveParams | None:
    """Nominal radii and track from the channel map's [robot] table or the log's
    ``logcal.nominal`` record (``l_a`` half-track and ``R`` are accepted too); None if absent."""
    found: dict[str, float] = {}
    sources: list[Mapping[str, Any]] = [
        loaded.robot_config.params,
        loaded.log.metadata.get(NOMINAL_RECORD, {}),
    ]
    for src in sources:
        for name, keys in _NOMINAL_KEYS.items():
            for k in keys:
                if name not in found and k in src:
                    try:
                        found[name] = float(src[k])
                    except (TypeError, ValueError):
                        continue
        if "track_width" not in found and "l_a" in src:
            found["track_width"] = 2 * float(src["l_a"])
    if len(found) < 3 or not all(math.isfinite(v) and v > 0 for v in found.values()):
        return None
    return DiffDriveParams(
        found["wheel_radius_right"], found["wheel_radius_left"], found["track_width"]
    )


def _drive_run(loaded: LoadedLog) -> DriveRun:
    f = loaded.frame
    missing = [c for c in ("wheel_right", "wheel_left", "x", "y", "yaw") if c not in f.columns]
    if missing:
        raise InsufficientDataError(
            f"{loaded.path}: the calibration needs ground-truth pose and wheel angles; missing "
            f"{', '.join(missing)}"
        )
    t = (f["t_ns"].to_numpy() - f["t_ns"][0]) * 1e-9
    return DriveRun(
        t,
        f["wheel_right"].to_numpy().astype(float),
        f["wheel_left"].to_numpy().astype(float),
        f["x"].to_numpy().astype(float),
        f["y"].to_numpy().astype(float),
        f["yaw"].to_numpy().astype(float),
        name=loaded.path,
    )


def _dr_summary(run: DriveRun, params: DiffDriveParams) -> tuple[dict[str, float], dict[str, Any]]:
    dr = dead_reckon(
        run.t, run.wheel_right, run.wheel_left, params, (run.x[0], run.y[0], run.yaw[0])
    )
    err = float(np.hypot(dr.x[-1] - run.x[-1], dr.y[-1] - run.y[-1]))
    length = run.path_length()
    summary = {
        "end_point_error_m": err,
        "end_heading_error_rad": float(dr.yaw[-1] - run.yaw[-1]),
        "path_length_m": length,
        "drift_percent_of_path": 100 * err / length if length > 0 else math.nan,
    }
    return summary, {"t": dr.t, "x": dr.x, "y": dr.y, "yaw": dr.yaw}


def _dead_reckoning(
    runs: Sequence[DriveRun], nominal: DiffDriveParams | None, calibrated: CalibrationResult | None
) -> tuple[dict[str, Any], dict[str, Any]]:
    """Per run: end-point error with the nominal and the calibrated parameters; arrays for the
    views (true path, both dead-reckoned paths)."""
    section: dict[str, Any] = {"scheme": "arc (exact for constant wheel rates per interval)"}
    arrays: dict[str, Any] = {}
    per_run = []
    for run in runs:
        row: dict[str, Any] = {"run": run.name}
        arrays[run.name] = {"truth": {"t": run.t, "x": run.x, "y": run.y, "yaw": run.yaw}}
        for label, params in (
            ("nominal", nominal),
            ("calibrated", None if calibrated is None else _params_of(calibrated)),
        ):
            if params is None:
                continue
            row[label], arrays[run.name][label] = _dr_summary(run, params)
        if "nominal" in row and "calibrated" in row:
            after = row["calibrated"]["end_point_error_m"]
            row["improvement_factor"] = (
                row["nominal"]["end_point_error_m"] / after if after > 0 else math.inf
            )
        per_run.append(row)
    section["runs"] = per_run
    if calibrated is not None:
        section["calibrated_with"] = calibrated.method
    return section, arrays


def _params_of(result: CalibrationResult) -> DiffDriveParams:
    p = result.parameters
    return DiffDriveParams(
        p["wheel_radius_right"].value, p["wheel_radius_left"].value, p["track_width"].value
    )


def _analyze_runs(
    runs: list[DriveRun],
    nominal: DiffDriveParams | None,
    config: Any,
    progress: Progress,
    gyro: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None,
    side: float | None,
) -> tuple[
    list[CalibrationResult], CalibrationResult | None, dict[str, Any], Any, Any, dict[str, Any]
]:
    stages = Stages(getattr(config, "debug", False))
    seed = int(getattr(config, "seed", 0))
    methods: list[CalibrationResult] = []
    sections: dict[str, Any] = {}
    progress("least-squares odometry calibration")
    lsq = stages.run("calibration.lsq", lambda: calibrate_lsq(runs, seed=seed))
    fit: LsqFit | None = None
    if lsq is not None:
        methods.append(lsq[0])
        fit = lsq[1]
        if fit.offset is not None:
            sx, sy = fit.offset_std
            sections["ground_truth_offset"] = {
                "x_m": fit.offset.real,
                "y_m": fit.offset.imag,
                "x_std_m": sx,
                "y_std_m": sy,
                "note": "where the ground-truth marker sits ahead of / left of the axle centre",
            }
    if nominal is None:
        stages.skip("calibration.umbmark", "no nominal parameters to correct")
    else:
        progress("UMBmark")

        def _umb() -> CalibrationResult:
            res = umbmark(runs, nominal, side)
            return umbmark_result(res, len(res.errors_cw), len(res.errors_ccw))

        umb = stages.run("calibration.umbmark", _umb)
        if umb is not None:
            methods.append(umb)
    if gyro is not None:
        t, pr, pl, rate = gyro
        radii = _params_of(methods[0]) if lsq is not None else nominal
        if radii is None:
            stages.skip("effective_track.gyro", "no radii (nominal or calibrated)")
        else:
            et = stages.run(
                "effective_track.gyro",
                lambda: effective_track(t, pr, pl, radii.r_R, radii.r_L, yaw_rate=rate, seed=seed),
            )
            if et is not None:
                sections["effective_track"] = {
                    "from": "gyro",
                    "estimate": et.estimate.to_dict(),
                    "geometric_track_m": None if nominal is None else nominal.b,
                }
    recommended = methods[0] if methods else None
    progress("dead reckoning")
    dr = stages.run("dead_reckoning", lambda: _dead_reckoning(runs, nominal, recommended))
    arrays: dict[str, Any] = {}
    if dr is not None:
        sections["dead_reckoning"], arrays = dr
    disc = None
    if getattr(config, "discovery", True) and fit is not None:
        progress("discovery")
        disc = stages.run("discovery", lambda: discover(runs, fit, nominal))
    elif fit is None:
        stages.skip("discovery", "no least-squares fit to test")
    return methods, recommended, sections, disc, stages, arrays


def _gyro(loaded: LoadedLog) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    f = loaded.frame
    if not {"omega", "wheel_right", "wheel_left"} <= set(f.columns):
        return None
    t = (f["t_ns"].to_numpy() - f["t_ns"][0]) * 1e-9
    cols = [f[c].to_numpy().astype(float) for c in ("wheel_right", "wheel_left", "omega")]
    return t, cols[0], cols[1], cols[2]


def _side(loaded: LoadedLog) -> float | None:
    v = loaded.log.metadata.get(NOMINAL_RECORD, {}).get("square_side")
    try:
        return float(v) if v is not None else None
    except ValueError:
        return None


def analyze_diff_drive(loaded: LoadedLog, config: Any, progress: Progress) -> AnalysisResult:
    """Calibrate one differential-drive log (the plugin's ``analyze``)."""
    nominal = nominal_params(loaded)
    warnings = [str(p) for p in loaded.problems]
    if nominal is None:
        warnings.append(
            "no nominal wheel radii / track (channel map [robot] wheel_radius_right, "
            "wheel_radius_left, track_width, or metadata record logcal.nominal): drift before "
            "calibration and the effective-track test are not reported"
        )
    stages_pre = Stages(getattr(config, "debug", False))
    run = stages_pre.run("ground_truth", lambda: _drive_run(loaded))
    runs = [run] if run is not None else []
    methods, rec, sections, disc, stages, arrays = _analyze_runs(
        runs, nominal, config, progress, _gyro(loaded), _side(loaded)
    )
    if nominal is not None:
        sections["nominal"] = nominal.as_dict()
    return AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=methods,
        estimate=rec,  # None when no calibration ran: the nominal values are in "nominal"
        discovery=disc,
        truth=loaded.truth,
        source={"path": loaded.path, "samples": loaded.frame.height},
        warnings=warnings,
        stages=stages_pre.status + stages.status,
        sections=sections,
        artifacts={"trajectories": arrays},
    )


def pool_diff_drive(
    runs: Sequence[tuple[LoadedLog, AnalysisResult]], config: Any, progress: Progress
) -> AnalysisResult:
    """All runs together: one least-squares fit, UMBmark over the square runs, dead reckoning
    of every run with the pooled parameters."""
    loaded0 = runs[0][0]
    nominal = nominal_params(loaded0)
    drive_runs = []
    for loaded, _ in runs:
        try:
            drive_runs.append(_drive_run(loaded))
        except InsufficientDataError:
            continue
    methods, rec, sections, disc, stages, arrays = _analyze_runs(
        drive_runs, nominal, config, progress, None, _side(loaded0)
    )
    if nominal is not None:
        sections["nominal"] = nominal.as_dict()
    return AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=methods,
        estimate=rec,
        discovery=disc,
        truth=loaded0.truth,
        source={"runs": [lo.path for lo, _ in runs]},
        warnings=[w for _, r in runs for w in r.warnings],
        stages=stages.status,
        runs=[r for _, r in runs],
        sections=sections,
        artifacts={"trajectories": arrays},
    )
