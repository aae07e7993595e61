"""The differential drive's analysis: least-squares odometry calibration, UMBmark, the
gyro's effective track, dead reckoning before / after, the adequacy of the calibrated model,
discovery through the shared engine (stuck encoder readings excluded, a radius change split),
for one log or several runs. A pose that is the wheels' own dead reckoning is not taken as
ground truth; a log of wheel odometry and an IMU (no encoders, no ground truth) gets what it
determines: the yaw-rate gain against the gyro. The pipeline reads, runs the stages and
reports; the judgement of the calibration is :mod:`calib.diff_drive.judgement`'s.

Imported on first analysis (not by the plugin declaration in ``__init__``): it pulls in
:mod:`calib.diff_drive`'s estimators and scipy, which resolving a log's signals never needs.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from calib.adequacy import Adequacy, ParameterChange, not_assessed
from calib.diff_drive.adequacy import (
    StuckSpan,
    assess_fit,
    exclude_spans,
    exclusion_masks,
    find_stuck_spans,
    radius_change,
    split_at,
)
from calib.diff_drive.data import DriveRun
from calib.diff_drive.dead_reckoning import dead_reckon
from calib.diff_drive.effects import (
    WHEEL_SLIP,
    DiffDriveSelection,
    discover_effects,
    stuck_spec,
)
from calib.diff_drive.explain import correcting_effects, drive_discovery_report, explained_runs
from calib.diff_drive.judgement import (
    LSQ_MODEL,
    excluded_stuck_spans,
    judge_plausible,
    judged_estimate,
    log_verdict,
    model_label,
    radius_pieces,
)
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.odom_imu import analyze_odom_imu
from calib.diff_drive.odom_imu.report import odom_imu_discovery_report
from calib.diff_drive.odom_imu.result import allowed_range
from calib.diff_drive.odometry_lsq import (
    PARAMETER_NAMES,
    LsqFit,
    calibrate_lsq,
    fit_lsq,
    make_estimates,
)
from calib.diff_drive.provenance import Provenance, pose_provenance
from calib.diff_drive.skid import effective_track
from calib.diff_drive.slip import SlipFit, fit_slip, slip_corrected, spanned
from calib.diff_drive.umbmark import umbmark, umbmark_result
from calib.discovery import DiscoveryReport
from calib.errors import InsufficientDataError
from calib.results import AnalysisResult, CalibrationResult, Estimate
from logtools.loaded import LoadedLog
from logtools.robots.base import Progress
from logtools.stages import Stages

if TYPE_CHECKING:
    from logtools.analysis_config import AnalysisConfig

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


def _lsq_section(fit: LsqFit, sections: dict[str, Any]) -> None:
    if fit.offset is not None:
        sx, sy = fit.offset_std
        sections["ground_truth_offset"] = {
            "x_m": fit.offset.real,
            "y_m": fit.offset.imag,
            "x_std_m": sx,
            "y_std_m": sy,
            "note": "where the ground-truth marker sits ahead of / left of the axle centre",
        }


@dataclass(frozen=True)
class _Judged:
    """What the final adequacy judges: the runs (corrected by a named slip), the parameters and
    the marker offset, the model's label; and the runs a radius change is sought on (``used``:
    stuck spans left out, a named slip corrected)."""

    runs: list[DriveRun]
    params: DiffDriveParams
    offset: complex | None
    model: str
    used: list[DriveRun]


def _calibrate_and_judge(
    runs: list[DriveRun],
    nominal: DiffDriveParams | None,
    stages: Stages,
    seed: int,
    discovery_on: bool,
    progress: Progress,
) -> tuple[
    CalibrationResult | None,
    LsqFit | None,
    Adequacy,
    DiscoveryReport | None,
    dict[str, Any],
    list[str],
]:
    """LSQ, adequacy, discovery (stuck spans excluded), a radius change (split and estimated
    per piece), the final adequacy and intervals under misfit (the judgement is
    :mod:`calib.diff_drive.judgement`'s)."""
    sections: dict[str, Any] = {}
    warnings: list[str] = []
    progress("least-squares odometry calibration")
    lsq = stages.run("calibration.lsq", lambda: calibrate_lsq(runs, seed=seed))
    if lsq is None:
        return None, None, not_assessed(LSQ_MODEL, "no least-squares fit"), None, sections, []
    result, fit = lsq
    progress("adequacy")
    first = stages.run(
        "adequacy", lambda: assess_fit(runs, fit.params, model=LSQ_MODEL, offset=fit.offset)
    )
    if first is None:
        _lsq_section(fit, sections)
        return result, fit, not_assessed(LSQ_MODEL, "the adequacy check failed"), None, sections, []
    floor = first.channels[0].noise_floor if first.channels else 0.0
    spans = find_stuck_spans(runs, fit.params, floor)
    disc = _discovery(runs, nominal, fit, spans, stages, discovery_on, progress)
    lsq_nominal, recorded = result, runs
    explained = _rerun_under_effects(runs, disc, stages, seed, warnings)
    if explained is not None:
        runs, result, fit = explained
    excluded = excluded_stuck_spans(spans, disc)
    used, result, fit = _excluding_stuck(runs, excluded, result, fit, stages, seed, warnings)
    _lsq_section(fit, sections)
    progress("speed-dependent slip")
    slip = stages.run("calibration.slip", lambda: fit_slip(used, fit.params, fit.offset))
    judged = _Judged(runs, fit.params, fit.offset, model_label(excluded), used)
    if slip is not None:
        sections["wheel_slip"] = slip.to_dict()
        judged, result, disc = _with_slip(judged, slip, result, disc, warnings)
    change, pieces = _radius_change(judged, stages, seed, sections, warnings)
    rerun = explained is not None
    adequacy = _final_adequacy(runs, judged, first, excluded, change, slip, rerun, stages)
    result = judged_estimate(result, disc, change, adequacy, pieces, recorded, seed)
    named = slip if slip is not None and slip.significant else None
    adequacy = log_verdict(adequacy, first, excluded, named)
    result, found = judge_plausible(result, adequacy)
    warnings += found
    report = drive_discovery_report(
        disc,
        first,
        adequacy,
        lsq_nominal,
        result,
        LSQ_MODEL,
        slip=named.k if named is not None else None,
        runs=recorded if discovery_on else (),
        seed=seed,
    )
    return result, fit, adequacy, report if discovery_on else None, sections, warnings


def _discovery(
    runs: list[DriveRun],
    nominal: DiffDriveParams | None,
    fit: LsqFit,
    spans: list[StuckSpan],
    stages: Stages,
    discovery_on: bool,
    progress: Progress,
) -> DiffDriveSelection | None:
    """Discovery through the shared engine from the calibrated parameters (None when switched
    off or failed; the stage says which)."""
    if not discovery_on:
        stages.skip("discovery", "switched off")
        return None
    progress("discovery")
    return stages.run(
        "discovery",
        lambda: discover_effects(
            runs, nominal, calibrated=fit.params, marker=fit.offset, spans=spans
        ),
    )


def _excluding_stuck(
    runs: list[DriveRun],
    excluded: Sequence[StuckSpan],
    result: CalibrationResult,
    fit: LsqFit,
    stages: Stages,
    seed: int,
    warnings: list[str],
) -> tuple[list[DriveRun], CalibrationResult, LsqFit]:
    """The runs with the stuck encoder spans ``excluded`` cut out, and the calibration refitted
    on them (the estimate and fit as they were when there are none or the refit failed)."""
    if not excluded:
        return runs, result, fit
    used = exclude_spans(runs, excluded)
    warnings.append(
        "stuck or dropped wheel-encoder readings ("
        + ", ".join(
            f"{s.label}: the ground truth turned {s.heading_rad:+.3g} rad the wheels did not report"
            for s in excluded
        )
        + "): those samples are left out of the calibration"
    )
    refit = stages.run("calibration.lsq_excluding_stuck", lambda: calibrate_lsq(used, seed=seed))
    if refit is None:
        return used, result, fit
    result, fit = refit
    result = dataclasses.replace(
        result,
        method="LSQ",
        verdict=result.verdict + " (stuck-encoder samples "
        "excluded: " + ", ".join(s.label for s in excluded) + ")",
    )
    return used, result, fit


def _with_slip(
    judged: _Judged,
    slip: SlipFit,
    result: CalibrationResult,
    disc: DiffDriveSelection | None,
    warnings: list[str],
) -> tuple[_Judged, CalibrationResult, DiffDriveSelection | None]:
    """A significant speed-dependent slip: the data corrected by it, the slip fit's radii and
    track as the estimate (no covariance: the LSQ bootstrap's is not theirs), the slip named in
    discovery; an insignificant one: the estimate spanning it."""
    if not slip.significant:
        return (
            judged,
            dataclasses.replace(result, parameters=spanned(result.parameters, slip)),
            disc,
        )
    k = slip.k.value
    judged = _Judged(
        slip_corrected(judged.runs, slip.params, k),
        slip.params,
        slip.offset,
        judged.model + f" + {WHEEL_SLIP.key}",
        slip_corrected(judged.used, slip.params, k),
    )
    result = dataclasses.replace(
        result,
        method="LSQ",
        parameters={**result.parameters, **{n: slip.with_slip[n] for n in PARAMETER_NAMES}},
        covariance=None,
        verdict=result.verdict + "; " + slip.note,
    )
    warnings.append(f"{slip.note} ({WHEEL_SLIP.id})")
    if disc is not None:
        disc = dataclasses.replace(disc, also_named=(WHEEL_SLIP.id,))
    return judged, result, disc


def _radius_change(
    judged: _Judged,
    stages: Stages,
    seed: int,
    sections: dict[str, Any],
    warnings: list[str],
) -> tuple[ParameterChange | None, dict[str, list[float]]]:
    """A change of the wheel radii mid-log: the log split there and each part estimated
    (``sections["parameter_change"]``), and the radii on consecutive pieces for the intervals;
    (None, {}) when one set describes the log."""
    used, params, offset = judged.used, judged.params, judged.offset
    change = stages.run("adequacy.radius_change", lambda: radius_change(used, params, offset))
    if change is None:
        return None, {}
    per_piece = _per_part_estimates(used, change, stages, seed)
    sections["parameter_change"] = {"change": change.to_dict(), "pieces": per_piece}
    warnings.append(
        change.note + ": the log was split there and each part estimated (parameter_change)"
    )
    return change, radius_pieces(used, params, offset)


def _per_part_estimates(
    used: list[DriveRun], change: ParameterChange, stages: Stages, seed: int
) -> list[dict[str, Any]]:
    """The LSQ estimate on each side of the radius change (a part whose fit fails is left
    out; its stage says why)."""
    before_runs, after_runs = split_at(used, change.t_s)
    per_piece = []

    def _fit_part(part: list[DriveRun]) -> Callable[[], LsqFit]:
        return lambda: fit_lsq(part, n_boot=200, seed=seed)

    for label, part in (("before", before_runs), ("after", after_runs)):
        f = stages.run(f"calibration.lsq_{label}_change", _fit_part(part))
        if f is None:
            continue
        p = f.params
        est = make_estimates(
            [p.r_R, p.r_L, p.b],
            f.std.tolist(),
            True,
            f"LSQ on the part {label} t = {change.t_s:.1f} s",
            f.quantile(),
        )
        per_piece.append({"part": label, "estimate": {k: e.to_dict() for k, e in est.items()}})
    return per_piece


def _final_adequacy(
    runs: list[DriveRun],
    judged: _Judged,
    first: Adequacy,
    excluded: Sequence[StuckSpan],
    change: ParameterChange | None,
    slip: SlipFit | None,
    rerun: bool,
    stages: Stages,
) -> Adequacy:
    """The adequacy of the model judged (stuck spans masked, a named slip and a radius change
    in its notes), against the first adequacy when anything changed since (``rerun``: the
    calibration was rerun under discovery's effects); the first when it fails."""
    changes = [change] if change is not None else []
    masks = exclusion_masks(runs, excluded) if excluded else None
    notes = [f"{stuck_spec(s).key} excluded from the calibration" for s in excluded]
    if slip is not None and slip.significant:
        notes.append(slip.note)
    changed = bool(excluded or changes or judged.runs is not runs or rerun)
    final = stages.run(
        "adequacy.final",
        lambda: assess_fit(
            judged.runs,
            judged.params,
            model=judged.model,
            offset=judged.offset,
            excluded=masks,
            before=first if changed else None,
            changes=changes,
            notes=notes,
        ),
    )
    return final if final is not None else first


def _rerun_under_effects(
    runs: list[DriveRun],
    disc: DiffDriveSelection | None,
    stages: Stages,
    seed: int,
    warnings: list[str],
) -> tuple[list[DriveRun], CalibrationResult, LsqFit] | None:
    """The calibration rerun on the data corrected by the clock and described effects
    discovery named (``calib.diff_drive.explain``), or None when it named none."""
    fixed = explained_runs(runs, disc) if disc is not None else None
    if fixed is None or disc is None:
        return None
    labels = ", ".join(e.key for e in correcting_effects(disc))
    redo = stages.run("calibration.lsq_under_effects", lambda: calibrate_lsq(fixed, seed=seed))
    if redo is None:
        return None
    result, fit = redo
    warnings.append(f"re-estimated under {labels}: the data corrected by them")
    verdict = result.verdict + f" (re-estimated under {labels}, the data corrected by them)"
    return fixed, dataclasses.replace(result, method="LSQ", verdict=verdict), fit


def _analyze_runs(
    runs: list[DriveRun],
    nominal: DiffDriveParams | None,
    config: AnalysisConfig,
    progress: Progress,
    gyro: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None,
    side: float | None,
) -> tuple[
    list[CalibrationResult],
    CalibrationResult | None,
    dict[str, Any],
    Any,
    Any,
    dict[str, Any],
    Adequacy,
    list[str],
]:
    stages = Stages(config.debug)
    seed = config.seed
    methods: list[CalibrationResult] = []
    sections: dict[str, Any] = {}
    warnings: list[str] = []
    disc: DiscoveryReport | None = None
    adequacy = not_assessed(LSQ_MODEL, "no ground-truth pose with wheel angles")
    if runs:
        lsq, _fit, adequacy, disc, sec, warnings = _calibrate_and_judge(
            runs, nominal, stages, seed, config.discovery, progress
        )
        sections.update(sec)
        if lsq is not None:
            methods.append(lsq)
    else:
        stages.skip("calibration.lsq", "no ground-truth pose with wheel angles")
    if nominal is None:
        stages.skip("calibration.umbmark", "no nominal parameters to correct")
    elif runs:
        progress("UMBmark")

        def _umb() -> CalibrationResult:
            res = umbmark(runs, nominal, side)
            return umbmark_result(res, len(res.errors_cw), len(res.errors_ccw))

        umb = stages.run("calibration.umbmark", _umb)
        if umb is not None:
            methods.append(umb)
    if gyro is not None:
        t, pr, pl, rate = gyro
        radii = _params_of(methods[0]) if methods and methods[0].method == "LSQ" else nominal
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
    arrays: dict[str, Any] = {}
    if runs:
        dr = stages.run("dead_reckoning", lambda: _dead_reckoning(runs, nominal, recommended))
        if dr is not None:
            sections["dead_reckoning"], arrays = dr
    return methods, recommended, sections, disc, stages, arrays, adequacy, warnings


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


_NOT_TRUTH = ("odom", "filtered", "ekf", "ukf")
"""Topic name parts of poses that are (or fuse) the wheels' own odometry."""


def _quat_yaw(f: Any, prefix: str) -> np.ndarray:
    """Yaw (rad) of the quaternion columns ``{prefix}x`` .. ``{prefix}w``."""
    qx, qy, qz, qw = (f[f"{prefix}{c}"].to_numpy().astype(float) for c in "xyzw")
    return np.asarray(np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz)))


_POSE_LAYOUTS = (
    ("pose.pose.position.", "pose.pose.orientation."),  # Odometry, PoseWithCovarianceStamped
    ("pose.position.", "pose.orientation."),  # PoseStamped
    ("transform.translation.", "transform.rotation."),  # TransformStamped
    ("position.", "orientation."),  # Pose
)


def _alternative_pose(
    loaded: LoadedLog, used: str, t_ns: np.ndarray
) -> tuple[str, np.ndarray, np.ndarray, np.ndarray] | None:
    """Another pose topic of the log (motion capture, a localisation) that is not odometry,
    resampled at ``t_ns``; None when the log has none."""
    for topic in sorted(loaded.log.topics):
        if topic == used or any(p in topic.lower() for p in _NOT_TRUTH):
            continue
        f = loaded.log.topics[topic]
        for pos, rot in _POSE_LAYOUTS:
            cols = [f"{pos}x", f"{pos}y", *(f"{rot}{c}" for c in "xyzw")]
            if not all(c in f.columns for c in cols) or f.height < 10:
                continue
            ts = f["t_ns"].to_numpy().astype(float)
            order = np.argsort(ts, kind="stable")
            ts = ts[order]
            inside = (t_ns >= ts[0]) & (t_ns <= ts[-1])
            if inside.mean() < 0.8:
                continue
            x = f[cols[0]].to_numpy().astype(float)[order]
            y = f[cols[1]].to_numpy().astype(float)[order]
            yaw = np.unwrap(_quat_yaw(f, rot)[order])
            return (topic, np.interp(t_ns, ts, x), np.interp(t_ns, ts, y), np.interp(t_ns, ts, yaw))
    return None


def _ground_truth(
    loaded: LoadedLog, run: DriveRun
) -> tuple[DriveRun | None, Provenance, dict[str, Any]]:
    """The run with a pose that is ground truth: the logged one unless it is the encoders'
    dead reckoning, then another pose topic of the log that is not; None when none is."""
    src = loaded.signals.sources.get("yaw")
    topic = src.topic if src is not None else "?"
    prov = pose_provenance(run.wheel_right, run.wheel_left, run.yaw, source=f"the pose on {topic}")
    info: dict[str, Any] = {"topic": topic, **prov.to_dict()}
    if not prov.dead_reckoning:
        info["verdict"] = "ground truth"
        return run, prov, info
    info["verdict"] = "not ground truth"
    t_ns = loaded.frame["t_ns"].to_numpy()
    alt = _alternative_pose(loaded, topic, t_ns)
    if alt is not None:
        name, x, y, yaw = alt
        cand = DriveRun(run.t, run.wheel_right, run.wheel_left, x, y, yaw, name=run.name)
        p2 = pose_provenance(cand.wheel_right, cand.wheel_left, cand.yaw, source=name)
        if not p2.dead_reckoning:
            info["used_instead"] = name
            return cand, prov, info
    return None, prov, info


def _odom_imu(
    loaded: LoadedLog,
    nominal: DiffDriveParams | None,
    stages: Stages,
    seed: int,
) -> tuple[CalibrationResult | None, Adequacy | None, Any, dict[str, Any], Any]:
    """The odometry-vs-gyro calibration, its adequacy (the final model's), its discovery
    report, its JSON section and the analysis result (for the report's lines)."""
    f = loaded.frame
    if not {"odom_omega", "gyro_z"} <= set(f.columns):
        stages.skip("odometry_imu", "no wheel-odometry yaw rate and IMU yaw rate")
        return None, None, None, {}, None
    t = (f["t_ns"].to_numpy() - f["t_ns"][0]) * 1e-9
    col = {c: f[c].to_numpy().astype(float) for c in f.columns if c != "t_ns"}
    gps = (col["gps_lat"], col["gps_lon"]) if {"gps_lat", "gps_lon"} <= set(col) else None
    res = stages.run(
        "odometry_imu",
        lambda: analyze_odom_imu(
            t,
            col["odom_omega"],
            col["gyro_z"],
            odom_v=col.get("odom_v"),
            gps=gps,
            geometric_track=None if nominal is None else nominal.b,
            seed=seed,
        ),
    )
    if res is None:
        return None, None, None, {}, None
    g = res.recommended_gain()
    params = {"yaw_rate_gain": g, **res.law_parameters()}
    if res.effective_track is not None and g.identifiable and nominal is not None:
        params["track_width"] = Estimate(
            "track_width",
            nominal.b * g.value,
            nominal.b * g.std,
            (nominal.b * g.ci95[0], nominal.b * g.ci95[1]),
            True,
            "m",
            f"effective track: geometric track {nominal.b:g} m x yaw-rate gain",
        )
    if res.distance_scale is not None:
        params["distance_scale_gps"] = res.distance_scale
    law = None if res.explained is None else res.explained.law
    said = (
        f"odometry yaw rate / gyro yaw rate = {g.value:.4g} [95 %: {g.ci95[0]:.4g}, "
        f"{g.ci95[1]:.4g}]"
        if g.identifiable
        else "odometry yaw rate / gyro yaw rate not determined by this log: the data allow "
        + allowed_range(g)
    )
    verdict = (
        said
        + ("" if law is None else f" (gain law {law.formula}: {law.adequacy.verdict})")
        + "; wheel radii not determined (no encoder angles and no independent distance"
        + (")" if res.distance_scale is None else " but GPS)")
    )
    cal = CalibrationResult(
        method="odometry vs gyro",
        parameters=params,
        verdict=verdict,
        details={"windows": res.n_windows},
    )
    report = odom_imu_discovery_report(res)
    return cal, res.final_adequacy, report, {"odometry_imu": res.to_dict()}, res


def analyze_diff_drive(
    loaded: LoadedLog, config: AnalysisConfig, progress: Progress
) -> AnalysisResult:
    """Calibrate one differential-drive log (the plugin's ``analyze``)."""
    nominal = nominal_params(loaded)
    warnings = [str(p) for p in loaded.problems]
    if nominal is None:
        warnings.append(
            "no nominal wheel radii / track (channel map [robot] wheel_radius_right, "
            "wheel_radius_left, track_width, or metadata record logcal.nominal): drift before "
            "calibration and the effective-track test are not reported"
        )
    stages_pre = Stages(config.debug)
    cols = set(loaded.frame.columns)
    has_wheels = {"wheel_right", "wheel_left"} <= cols
    run = stages_pre.run("ground_truth", lambda: _drive_run(loaded)) if has_wheels else None
    if not has_wheels:
        stages_pre.skip("ground_truth", "no wheel angles")
    sections: dict[str, Any] = {}
    if run is not None:
        checked, prov, info = _ground_truth(loaded, run)
        sections["ground_truth"] = info
        if prov.dead_reckoning:
            warnings.append(
                prov.note
                + (
                    f"; {info['used_instead']} is used as the ground truth instead"
                    if checked is not None
                    else "; the log has no other pose (motion capture, GPS): the wheel "
                    "radii and track are not determined by this log"
                )
            )
        run = checked
    runs = [run] if run is not None else []
    methods, rec, sec, disc, stages, arrays, adequacy, more = _analyze_runs(
        runs, nominal, config, progress, _gyro(loaded) if runs else None, _side(loaded)
    )
    sections.update(sec)
    warnings += more
    arrays_extra: dict[str, Any] = {}
    if not runs:
        cal, ad, oi_disc, sec2, oi_res = _odom_imu(loaded, nominal, stages, config.seed)
        sections.update(sec2)
        if cal is not None:
            methods.insert(0, cal)
            rec = cal
            adequacy = ad if ad is not None else adequacy
            disc = oi_disc
            arrays_extra["odometry_imu"] = oi_res
        elif "ground_truth" in sections and sections["ground_truth"]["verdict"] == (
            "not ground truth"
        ):
            adequacy = not_assessed(
                LSQ_MODEL, "the log's pose is the wheels' own dead reckoning, not ground truth"
            )
    if nominal is not None:
        sections["nominal"] = nominal.as_dict()
    return AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=methods,
        estimate=rec,  # None when no calibration ran: the nominal values are in "nominal"
        discovery=disc,
        adequacy=adequacy,
        truth=loaded.truth,
        source={"path": loaded.path, "samples": loaded.frame.height},
        warnings=warnings,
        stages=stages_pre.status + stages.status,
        sections=sections,
        artifacts={"trajectories": arrays, **arrays_extra},
    )


def pool_diff_drive(
    runs: Sequence[tuple[LoadedLog, AnalysisResult]],
    config: AnalysisConfig,
    progress: Progress,
) -> AnalysisResult:
    """All runs together: one least-squares fit, UMBmark over the square runs, dead reckoning
    of every run with the pooled parameters, the adequacy of the pooled model."""
    loaded0 = runs[0][0]
    nominal = nominal_params(loaded0)
    drive_runs = []
    for loaded, _ in runs:
        try:
            run = _drive_run(loaded)
        except InsufficientDataError:
            continue
        checked, _prov, _info = _ground_truth(loaded, run)
        if checked is not None:
            drive_runs.append(checked)
    methods, rec, sections, disc, stages, arrays, adequacy, more = _analyze_runs(
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
        adequacy=adequacy,
        truth=loaded0.truth,
        source={"runs": [lo.path for lo, _ in runs]},
        warnings=[w for _, r in runs for w in r.warnings] + more,
        stages=stages.status,
        runs=[r for _, r in runs],
        sections=sections,
        artifacts={"trajectories": arrays},
    )
