"""The tractor-trailer's analysis: steering geometry -> segmentation -> path-driven transient
fit -> no-slip regression -> the patent's least-squares methods -> steady-state and time-domain
estimators -> discovery -> joint refit with the sensor effects discovery named; and the pooled
transient fit over several runs. The pipeline reads, runs the stages and reports; what to
recommend and how to judge it is :mod:`calib.tractor_trailer.judgement`'s.

The library never prints: progress goes to the callback ``progress(stage: str)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import polars as pl

from calib.adequacy import Adequacy
from calib.errors import CalibError
from calib.kinematics.bicycle import SteeringGeometry
from calib.results import AnalysisResult, CalibrationResult, StageStatus
from calib.tractor_trailer.discovery.confounds import SpanChoice
from calib.tractor_trailer.discovery.effects.base import SensorCorrections
from calib.tractor_trailer.discovery.result import DiscoveryResult
from calib.tractor_trailer.estimators.noslip import NoSlipRegression
from calib.tractor_trailer.estimators.path_transient import PathTransientFit
from calib.tractor_trailer.explain import tractor_discovery_report
from calib.tractor_trailer.judgement import (
    FoldedEffects,
    actuator_note,
    confound_explanations,
    folded_effects,
    follows_path,
    judge_along_path,
    judge_plausible,
    judge_unexplained,
    more_precise,
    pose_too_noisy,
    recommended_estimate,
    span_confounds,
)
from calib.tractor_trailer.path_discovery import PathDiscovery
from calib.tractor_trailer.results import CommandType, MethodResult, Segment
from calib.tractor_trailer.views_data import VIEWS
from logtools.errors import LogcalInputError, MissingSignalsError
from logtools.loaded import LoadedLog
from logtools.robots.tractor_trailer.options import TractorTrailerOptions
from logtools.robots.tractor_trailer.path_inputs import (
    PathInputs,
    RobotDidNotMoveError,
    path_inputs,
    relaxation_window_s,
    trailer_pose_inputs,
)
from logtools.stages import Stages

if TYPE_CHECKING:
    from logtools.analysis_config import AnalysisConfig

__all__ = ["PATH_INPUTS", "analyze_tractor_trailer", "pool_tractor_trailer"]

Progress = Callable[[str], None]

PATH_INPUTS = "path_inputs"
"""Key of ``AnalysisResult.artifacts`` holding the transient fit's ``PathInputs`` (pooling)."""


def _require(loaded: LoadedLog, names: tuple[str, ...]) -> None:
    missing = [n for n in names if n not in loaded.frame.columns]
    if missing:
        raise MissingSignalsError(loaded.path, missing, loaded.log.topic_names(), "tractor_trailer")


def _usable_rows(frame: pl.DataFrame, cols: tuple[str, ...]) -> pl.DataFrame:
    """Rows where every column in ``cols`` is a finite number."""
    cond = pl.lit(True)
    for c in cols:
        cond = cond & pl.col(c).is_not_null() & pl.col(c).is_finite()
    return frame.filter(cond)


def _segments(t_s: np.ndarray, frame: pl.DataFrame) -> list[Segment]:
    from calib.tractor_trailer.segmentation import segment_command

    if "kappa_cmd" not in frame.columns:
        return [Segment(0.0, float(t_s[-1]), CommandType.OTHER, 0, len(t_s))]
    return segment_command(t_s, frame["kappa_cmd"].to_numpy())


def _mask_for(segments: list[Segment], kind: CommandType, n: int) -> np.ndarray:
    mask = np.zeros(n, dtype=bool)
    for s in segments:
        if s.command_type == kind:
            mask[s.start_index : s.end_index] = True
    return mask


def _method_tables(
    kappa: np.ndarray,
    psi: np.ndarray,
    segments: list[Segment],
    cfg: AnalysisConfig,
    rng: np.random.Generator,
    progress: Progress,
) -> tuple[list[MethodResult], list[str]]:
    from calib.errors import InsufficientDataError
    from calib.tractor_trailer.repeats import methods_table

    rows: list[MethodResult] = []
    notes: list[str] = []
    groups: list[tuple[str, np.ndarray]] = [("all", np.ones(kappa.size, dtype=bool))]
    if cfg.per_segment:
        kinds = sorted({s.command_type for s in segments}, key=list(CommandType).index)
        groups += [(str(k), _mask_for(segments, k, kappa.size)) for k in kinds]
    for label, mask in groups:
        progress(f"least-squares methods ({label})")
        try:
            rows += methods_table(
                kappa[mask], psi[mask], segment=label, repeats=cfg.repeats, rng=rng
            )
        except InsufficientDataError as err:
            notes.append(f"methods on segment type {label!r} skipped: {err}")
    return rows, notes


def _path_fit(
    loaded: LoadedLog, *, psi_offset: bool = False, psi_shift_s: float = 0.0
) -> tuple[PathInputs, PathTransientFit]:
    """The transient fit along the log's best path source.

    A noisy pose may be smoothed over a tenth of the trailer's relaxation time, which the first
    fit tells (a slow robot affords a longer window than the 0.25 s first assumed); a pose
    that still needs a large noise-bias correction is compared with odometry, and the more
    precise fit is kept, with a note.
    """

    def run(inp: PathInputs) -> PathTransientFit:
        return PathTransientFit(fit_psi_offset=psi_offset).fit(
            inp.path, inp.t_psi_s - psi_shift_s, inp.psi_rad, gaps=inp.gaps
        )

    inp = path_inputs(loaded)
    fit = run(inp)
    if inp.path.source != "pose":
        return inp, fit
    window = relaxation_window_s(inp.path, fit.L2_)
    if window > 0.25:
        again = path_inputs(loaded, max_window_s=window)
        if again.path.smoothing_samples != inp.path.smoothing_samples:
            inp, fit = again, run(again)
    if pose_too_noisy(fit):
        other = path_inputs(loaded, prefer="odometry")
        if other.path.source == "odometry":
            alt = run(other)
            if more_precise(alt, fit):
                alt.notes_.append(
                    "the pose is noisy (a large bias correction): odometry gave "
                    "the more precise fit and is used"
                )
                inp, fit = other, alt
    return inp, fit


def _confound_refits(
    loaded: LoadedLog, spans: Sequence[SpanChoice], stages: Stages
) -> list[tuple[str, PathTransientFit | None]]:
    """The path fit refitted with each confounded explanation's joint-angle corrections (None
    where a refit failed; its stage says why), for :func:`calib.tractor_trailer.judgement.
    span_confounds` to judge."""
    refits: list[tuple[str, PathTransientFit | None]] = []
    for label, option in confound_explanations(spans):

        def fit(o: SensorCorrections = option) -> PathTransientFit:
            return _path_fit(loaded, psi_offset=o.psi_offset, psi_shift_s=o.psi_shift_s)[1]

        refits.append((label, stages.run(f"refit for the confound ({label})", fit)))
    return refits


def _steering_geometry(
    loaded: LoadedLog, stages: Stages, progress: Progress, notes: list[str]
) -> SteeringGeometry | None:
    """Wheelbase and steering offset from the path's curvature, where the log has a steering
    angle (measured, else commanded) and a measured curvature."""
    steer = next((c for c in ("steer", "steer_cmd") if c in loaded.frame.columns), None)
    if steer is None or "kappa" not in loaded.frame.columns:
        return None
    from calib.kinematics.bicycle import fit_steering_geometry

    progress("steering geometry")
    rows = _usable_rows(loaded.frame, ("kappa", steer))
    geometry = stages.run(
        "steering geometry (wheelbase, steering offset)",
        lambda: fit_steering_geometry(rows["kappa"].to_numpy(), rows[steer].to_numpy()),
    )
    if geometry is not None:
        notes.append(geometry.report() + f" (from {steer})")
    return geometry


def _with_kappa_cmd_from_steering(
    loaded: LoadedLog, geometry: SteeringGeometry, notes: list[str]
) -> LoadedLog:
    """A log with a steering command but no wheelbase (so no curvature command): kappa_cmd =
    tan(steer_cmd - offset) / wheelbase with the fitted geometry, said in the notes."""
    if "kappa_cmd" in loaded.frame.columns or "steer_cmd" not in loaded.signals.signals:
        return loaded
    if not geometry.wheelbase.identifiable:
        return loaded
    wb, d0 = geometry.wheelbase.value, geometry.offset.value
    raw = loaded.signals.signals["steer_cmd"]
    derived = raw.with_columns(((pl.col("value") - d0).tan() / wb).alias("value"))
    frame = loaded.frame.with_columns(((pl.col("steer_cmd") - d0).tan() / wb).alias("kappa_cmd"))
    signals = replace(loaded.signals, signals={**loaded.signals.signals, "kappa_cmd": derived})
    notes.append(
        f"kappa_cmd derived as tan(steer_cmd - {d0:.4f}) / {wb:.4f} with the steering geometry "
        "fitted from the path (no wheelbase was given)"
    )
    return replace(loaded, frame=frame, signals=signals)


_PATH_STAGE = "transient fit along the path"
_PATH_DISCOVERY_STAGE = "discovery along the path"
_COMMAND_STAGE = "command-driven discovery"
"""Discovery against the curvature command (``--no-discovery`` skips both as "discovery")."""


def _path_discovery(
    inp: PathInputs,
    fit: PathTransientFit,
    frame: pl.DataFrame,
    segments: list[Segment],
    cfg: AnalysisConfig,
    stages: Stages,
    progress: Progress,
) -> PathDiscovery | None:
    """Discovery along the measured path (joint-angle effects, a mid-log change), or, when it
    is switched off or the log is short, only the nominal path fit's adequacy."""
    from calib.tractor_trailer.path_discovery import (
        MIN_DURATION_S,
        discover_along_path,
        judge_path_fit,
    )

    off = (int(frame["t_ns"][0]) - inp.t0_ns) / 1e9 if frame.height else 0.0
    segs = [(str(s.command_type), s.start_s + off, s.end_s + off) for s in segments]
    dur = float(np.ptp(inp.t_psi_s)) if inp.t_psi_s.size else 0.0
    why = ""
    if not cfg.discovery:
        why = "switched off (--no-discovery)"
    elif dur < MIN_DURATION_S:
        why = f"the log is {dur:.3g} s long; discovery along the path needs {MIN_DURATION_S:g} s"
    if why:
        if cfg.discovery:  # (switched off, the "discovery" stage says so already)
            stages.skip(_PATH_DISCOVERY_STAGE, why)
        progress("adequacy of the path fit")
        try:
            return judge_path_fit(
                inp.path, inp.t_psi_s, inp.psi_rad, inp.gaps, fit, segments=segs, reason=why
            )
        except (CalibError, ValueError, FloatingPointError, np.linalg.LinAlgError) as err:
            if cfg.debug:
                raise
            return PathDiscovery("failed", f"the path fit's adequacy failed: {err}")
    progress(_PATH_DISCOVERY_STAGE)
    return stages.run(
        _PATH_DISCOVERY_STAGE,
        lambda: discover_along_path(
            inp.path, inp.t_psi_s, inp.psi_rad, inp.gaps, fit, segments=segs, progress=progress
        ),
    )


_NOSLIP_STAGE = "no-slip regression on the trailer pose"


def _noslip_fit(loaded: LoadedLog) -> NoSlipRegression:
    t, (x2, y2, yaw2, psi) = trailer_pose_inputs(loaded)
    return NoSlipRegression().fit(t, x2, y2, yaw2, psi)


@dataclass
class _Run:
    """What every step of one log's analysis shares: the configuration, the stages, the random
    stream, the progress callback and the notes (the result's warnings, in the order they
    arise)."""

    cfg: AnalysisConfig
    stages: Stages
    rng: np.random.Generator
    progress: Progress
    notes: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class _Calibrations:
    """The calibrations before discovery: every method's result, the no-slip regression on the
    trailer pose, the steady-state EIV estimate, and why there is none when the robot did not
    move."""

    methods: list[MethodResult]
    noslip: NoSlipRegression | None
    eiv: CalibrationResult | None
    did_not_move: str | None


def analyze_tractor_trailer(
    loaded: LoadedLog, config: AnalysisConfig, progress: Progress
) -> AnalysisResult:
    """Analyse one tractor-trailer log (the plugin's ``analyze``); ``config`` is an
    ``AnalysisConfig``. The transient fit's path inputs are kept in
    ``artifacts[PATH_INPUTS]`` so that pooling reuses them."""
    _require(loaded, ("psi",))
    run = _Run(config, Stages(config.debug), np.random.default_rng(config.seed), progress)
    _note_integrator(run)
    loaded, geometry = _with_steering_geometry(loaded, run)
    frame, t_s = _usable_frame(loaded)
    segments = _segmentation(frame, t_s, run)
    path_out = _transient_fit_along_path(loaded, run)
    path_fit = path_out[1] if path_out else None
    cal = _calibrations(loaded, frame, t_s, segments, path_fit, run)
    estimate, why = recommended_estimate(
        cal.did_not_move, cal.noslip, path_fit, cal.eiv, _stage_failure(run.stages, _PATH_STAGE)
    )
    run.notes += why
    discovery = _command_discovery(loaded, frame, segments, estimate, run)
    folded = folded_effects(discovery)
    estimate, shown_fit, shown_shift = _joint_refit(loaded, estimate, path_fit, folded, run)
    path_disc = None
    if path_out and path_fit is not None and cal.did_not_move is None:
        path_disc = _path_discovery(
            path_out[0], path_fit, frame, segments, run.cfg, run.stages, run.progress
        )
    estimate, adequacy = _judgement(loaded, estimate, path_fit, path_disc, discovery, folded, run)
    if _nominal_not_drawn(path_disc, estimate):
        shown_fit = None  # the views draw the nominal fit only where it is the estimate
    note = actuator_note(estimate, path_fit, discovery)
    if note is not None:
        run.notes.append(note)
    source = _source(loaded, frame, t_s, path_out, geometry)
    estimate, found = judge_plausible(estimate, adequacy)
    run.notes += found
    ok_path_disc = path_disc if path_disc is not None and path_disc.status == "ok" else None
    result = AnalysisResult(
        robot=str(loaded.robot),
        segments=segments,
        methods=cal.methods,
        estimate=estimate,
        discovery=_discovery_shown(path_disc, discovery, adequacy, path_fit, estimate),
        adequacy=adequacy,
        sections={} if ok_path_disc is None else {"path_discovery": ok_path_disc},
        truth=dict(loaded.truth),
        source=source,
        warnings=[str(p) for p in loaded.problems] + run.notes,
        stages=run.stages.status,
    )
    views = _views_data(loaded, run, result, path_out, (shown_fit, shown_shift))
    return replace(result, artifacts={PATH_INPUTS: path_out[0] if path_out else None, VIEWS: views})


def _note_integrator(run: _Run) -> None:
    """A note when the compiled integrator is not built (the analysis is about 5x slower)."""
    from calib.tractor_trailer.models.hitch_rk4 import compiled_available

    if not compiled_available():
        run.notes.append(
            "the compiled integrator (calib/tractor_trailer/models/_hitch_rk4.c) is not "
            "built here; analysed on its numpy loop, about 5x slower (pip install . "
            "builds it)"
        )


def _with_steering_geometry(
    loaded: LoadedLog, run: _Run
) -> tuple[LoadedLog, SteeringGeometry | None]:
    """The steering geometry the log determines, and the log with a curvature command derived
    from it where it has only a steering command."""
    geometry = _steering_geometry(loaded, run.stages, run.progress, run.notes)
    if geometry is not None:
        loaded = _with_kappa_cmd_from_steering(loaded, geometry, run.notes)
    return loaded, geometry


def _usable_frame(loaded: LoadedLog) -> tuple[pl.DataFrame, np.ndarray]:
    """The rows with a finite joint angle (and curvature, where the log has one) and their
    times (s) from the first."""
    has_kappa = "kappa" in loaded.frame.columns
    frame = _usable_rows(loaded.frame, ("psi", "kappa") if has_kappa else ("psi",))
    t_s = (frame["t_ns"].to_numpy() - frame["t_ns"][0]) / 1e9 if frame.height else np.zeros(0)
    return frame, t_s


def _segmentation(frame: pl.DataFrame, t_s: np.ndarray, run: _Run) -> list[Segment]:
    """The log's segments by command type (none without a curvature command or rows)."""
    run.progress("segmenting by command type")
    if "kappa_cmd" not in frame.columns:
        run.stages.skip("segmentation", "no curvature command (kappa_cmd) in the log")
        return []
    if frame.height < 10:
        run.stages.skip("segmentation", f"{frame.height} usable rows; need 10")
        return []
    return run.stages.run("segmentation", lambda: _segments(t_s, frame)) or []


def _transient_fit_along_path(
    loaded: LoadedLog, run: _Run
) -> tuple[PathInputs, PathTransientFit] | None:
    """The transient fit along the log's path and its inputs (None: the stage says why)."""
    run.progress(_PATH_STAGE)
    path_out = run.stages.run(_PATH_STAGE, lambda: _path_fit(loaded))
    if path_out:
        run.notes += path_out[0].notes + path_out[1].notes_
    return path_out


def _calibrations(
    loaded: LoadedLog,
    frame: pl.DataFrame,
    t_s: np.ndarray,
    segments: list[Segment],
    path_fit: PathTransientFit | None,
    run: _Run,
) -> _Calibrations:
    """The no-slip regression on the trailer pose, the least-squares methods and the
    steady-state and time-domain estimators (skipped, with why, when the robot did not move or
    there is no measured curvature), and the fit along the path's own method row."""
    methods: list[MethodResult] = []
    noslip = None
    if {"x2", "y2", "yaw2"} <= set(loaded.signals.signals):
        run.progress(_NOSLIP_STAGE)
        noslip = run.stages.run(_NOSLIP_STAGE, lambda: _noslip_fit(loaded))
        if noslip is not None:
            methods.append(noslip.method_result_)
    still = run.stages.errors.get(_PATH_STAGE)
    did_not_move = str(still) if isinstance(still, RobotDidNotMoveError) else None
    eiv = None
    skip = _why_no_steady_state(frame, did_not_move is not None)
    if skip is not None:
        run.stages.skip("least-squares methods", skip)
        run.stages.skip("steady-state and time-domain estimators", skip)
    else:
        more, eiv = _steady_state(frame, t_s, segments, run)
        methods += more
    if path_fit is not None:
        methods.append(path_fit.method_result_)
    return _Calibrations(methods, noslip, eiv, did_not_move)


def _why_no_steady_state(frame: pl.DataFrame, did_not_move: bool) -> str | None:
    """Why the least-squares methods and steady-state estimators cannot run (None: they can)."""
    if did_not_move:
        return "the robot did not move"
    if "kappa" not in frame.columns:
        return "no measured curvature (kappa needs v and omega, or a pose path)"
    if frame.height < 10:
        return f"{frame.height} rows have both psi and kappa; need 10"
    return None


def _steady_state(
    frame: pl.DataFrame, t_s: np.ndarray, segments: list[Segment], run: _Run
) -> tuple[list[MethodResult], CalibrationResult | None]:
    """The patent's least-squares methods and the steady-state and time-domain estimators on
    the measured curvature: their method rows and the EIV estimate (None when it is not the
    one recommended among them)."""
    from calib.tractor_trailer.estimators.recommend import calibrate_link_lengths

    kappa = frame["kappa"].to_numpy()
    psi = frame["psi"].to_numpy()
    v = frame["v"].to_numpy() if "v" in frame.columns else None
    methods: list[MethodResult] = []
    tables = run.stages.run(
        "least-squares methods",
        lambda: _method_tables(kappa, psi, segments, run.cfg, run.rng, run.progress),
    )
    if tables:
        methods += tables[0]
        run.notes += tables[1]
    run.progress("steady-state and time-domain estimators")
    own = run.stages.run(
        "steady-state and time-domain estimators",
        lambda: calibrate_link_lengths(t_s, kappa, psi, v, segments=segments, rng=run.rng),
    )
    eiv = None
    if own:
        eiv = own[0] if own[0].method == "EIV-ML" else None
        methods += list(own[1])
    return methods, eiv


def _stage_failure(stages: Stages, stage: str) -> str | None:
    """Why ``stage`` did not end "ok" (None: it did, or it did not run)."""
    failed = [s for s in stages.status if s.stage == stage and s.status != "ok"]
    return failed[0].reason if failed else None


def _command_discovery(
    loaded: LoadedLog,
    frame: pl.DataFrame,
    segments: list[Segment],
    estimate: CalibrationResult | None,
    run: _Run,
) -> Any:
    """Discovery against the curvature command from the recommended link lengths (None, with
    the stage skipped, when switched off, without an estimate or without a command)."""
    if not run.cfg.discovery:
        run.stages.skip("discovery", "switched off (--no-discovery)")
        return None
    if estimate is None:
        run.stages.skip(_COMMAND_STAGE, "no calibrated link lengths to start from")
        return None
    if "kappa_cmd" not in frame.columns:
        run.stages.skip(
            _COMMAND_STAGE,
            "discovery compares against the curvature command; the log has none (kappa_cmd)",
        )
        return None
    return _run_command_discovery(loaded, frame, segments, estimate, run)


def _run_command_discovery(
    loaded: LoadedLog,
    frame: pl.DataFrame,
    segments: list[Segment],
    estimate: CalibrationResult,
    run: _Run,
) -> Any:
    """The command-driven discovery stage; a result that did not run is None (its stage
    skipped with discovery's reason), one that ran partly keeps its status in the stage."""
    from calib.tractor_trailer.discovery import discover
    from calib.tractor_trailer.discovery.windows import DEFAULT_MAX_SPAN_S

    run.progress("model-mismatch discovery")
    opts = run.cfg.options(TractorTrailerOptions)
    span = DEFAULT_MAX_SPAN_S if opts.discovery_span_s is None else opts.discovery_span_s
    L1 = estimate.parameters["L1"].value
    L2 = estimate.parameters["L2"].value
    discovery = run.stages.run(
        _COMMAND_STAGE,
        lambda: discover(
            frame,
            L1,
            L2,
            baseline="steady" if opts.baseline == "steady" else "transient",
            segments=segments,
            rng=run.rng,
            signals=loaded.signals.signals,
            max_span_s=span,
        ),
    )
    status = getattr(discovery, "status", "ok")
    if discovery is not None and status != "ok":
        run.stages.status[-1] = StageStatus(
            _COMMAND_STAGE,
            "skipped" if status == "not_run" else "ok",
            f"{status}: {discovery.reason}" if discovery.reason else status,
        )
        if status == "not_run":
            return None
    return discovery


def _joint_refit(
    loaded: LoadedLog,
    estimate: CalibrationResult | None,
    path_fit: PathTransientFit | None,
    folded: FoldedEffects,
    run: _Run,
) -> tuple[CalibrationResult | None, PathTransientFit | None, float]:
    """The fit along the path refitted with the sensor effects command-driven discovery named
    (when there are any and the refit is sound): the estimate, and the fit and joint-angle
    clock shift whose prediction the views draw."""
    if not folded.labels or path_fit is None:
        return estimate, path_fit, 0.0
    run.progress("refit with the effects discovery named")
    joint = run.stages.run(
        "joint refit with discovered sensor effects",
        lambda: _path_fit(loaded, psi_offset=folded.psi_offset, psi_shift_s=folded.psi_shift_s)[1],
    )
    if joint is None or not joint.sound_:
        return estimate, path_fit, 0.0
    res = joint.result_
    model = f"{res.method} + " + " + ".join(folded.labels)
    joint_estimate = replace(
        res,
        method=model,
        details={**res.details, "model": model, "effects_included": folded.labels},
    )
    return joint_estimate, joint, folded.psi_shift_s


def _judgement(
    loaded: LoadedLog,
    estimate: CalibrationResult | None,
    path_fit: PathTransientFit | None,
    path_disc: PathDiscovery | None,
    discovery: object,
    folded: FoldedEffects,
    run: _Run,
) -> tuple[CalibrationResult | None, Adequacy]:
    """The estimate judged after both discoveries (:mod:`calib.tractor_trailer.judgement`):
    along the path, spanning the confounded explanations the path does not reject (the refits
    made here), not determined where the joint angle keeps unexplained structure."""
    estimate, adequacy, notes = judge_along_path(estimate, path_disc, path_fit, folded.labels)
    run.notes += notes
    if folded.spans and path_fit is not None and estimate is not None:
        estimate = _spanning_confounds(loaded, estimate, path_fit, folded.spans, run)
    path_ran = path_disc is not None and path_disc.status == "ok"
    return judge_unexplained(estimate, adequacy, discovery, path_fit, path_ran)


def _spanning_confounds(
    loaded: LoadedLog,
    estimate: CalibrationResult,
    path_fit: PathTransientFit,
    spans: tuple[SpanChoice, ...],
    run: _Run,
) -> CalibrationResult:
    """The estimate spanning the confounded explanations the measured path does not reject,
    when it is the fit along the path (the refits made here, the judgement calib's)."""
    if not follows_path(estimate, path_fit):
        return estimate
    run.progress("refits for the confounded explanations")
    refits = _confound_refits(loaded, spans, run.stages)
    estimate, notes = span_confounds(estimate, path_fit, refits, spans)
    run.notes += notes
    return estimate


def _nominal_not_drawn(path_disc: PathDiscovery | None, estimate: CalibrationResult | None) -> bool:
    """Whether path discovery's accepted effects replace the nominal fit as the estimate (the
    views then do not draw the nominal fit's prediction)."""
    return (
        path_disc is not None
        and path_disc.solution is not None
        and estimate is not None
        and (estimate.method.startswith(PathTransientFit.name) and bool(path_disc.accepted))
    )


def _source(
    loaded: LoadedLog,
    frame: pl.DataFrame,
    t_s: np.ndarray,
    path_out: tuple[PathInputs, PathTransientFit] | None,
    geometry: SteeringGeometry | None,
) -> dict[str, Any]:
    """What the analysis read: the log, its usable samples and duration, the signals' topics,
    the path's source and the steering geometry."""
    source: dict[str, Any] = {
        "path": str(loaded.path),
        "samples": frame.height,
        "duration_s": float(t_s[-1]) if t_s.size else 0.0,
        "signals": {k: f"{s.topic}:{s.field}" for k, s in loaded.signals.sources.items()},
    }
    if path_out:
        source["path_source"] = path_out[0].path.source
    if geometry is not None:
        source["steering_geometry"] = geometry.to_dict()
    return source


def _discovery_shown(
    path_disc: PathDiscovery | None,
    discovery: object,
    adequacy: Adequacy,
    path_fit: PathTransientFit | None,
    estimate: CalibrationResult | None,
) -> Any:
    """The discovery report in the shared shape, from discovery along the path (``path_disc``)
    and command-driven discovery; None when neither engine ran (--no-discovery, or nothing to
    start from)."""
    command = discovery if isinstance(discovery, DiscoveryResult) else None
    if (path_disc is None or path_disc.status != "ok") and command is None:
        return None
    nominal = path_fit.result_ if path_fit is not None else None
    return tractor_discovery_report(path_disc, command, adequacy, nominal, estimate)


def _transient_drawn(
    path_out: tuple[PathInputs, PathTransientFit] | None,
    shown_fit: PathTransientFit | None,
    shown_shift: float,
    estimate: CalibrationResult | None,
) -> Any:
    """The recommended transient fit's own prediction for the views, when it is one."""
    from calib.tractor_trailer.views_data import transient_prediction

    if not path_out or shown_fit is None or estimate is None:
        return None
    if not estimate.method.startswith(shown_fit.name):
        return None
    return transient_prediction(shown_fit, path_out[0].t0_ns, shown_shift)


def _views_data(
    loaded: LoadedLog,
    run: _Run,
    result: AnalysisResult,
    path_out: tuple[PathInputs, PathTransientFit] | None,
    shown: tuple[PathTransientFit | None, float],
) -> Any:
    """The drawing data of the views (``shown``: the fit whose prediction they draw and its
    joint-angle clock shift); a failure stays inside its own stage ("views data"), except a
    ``--method`` that names no method of this analysis (exit 2)."""
    from calib.tractor_trailer.views_data import tractor_views_data

    columns: dict[str, np.ndarray] = {
        c: loaded.frame[c].cast(pl.Float64).fill_null(np.nan).to_numpy()
        for c in ("x", "y", "yaw", "psi", "kappa", "omega", "v")
        if c in loaded.frame.columns
    }
    method = run.cfg.options(TractorTrailerOptions).method_for_psi
    try:
        transient = _transient_drawn(path_out, shown[0], shown[1], result.estimate)
        return tractor_views_data(columns, result, method_for_psi=method, transient=transient)
    except KeyError as err:  # the user's --method names no method of this analysis: exit 2
        raise LogcalInputError(f"--method {method!r}: {err.args[0]}") from None
    except Exception as err:  # drawing data: a failure stays inside its own stage
        if run.cfg.debug:
            raise
        run.stages.status.append(
            StageStatus("views data", "failed", f"{type(err).__name__}: {err}")
        )
        return {}


def pool_tractor_trailer(
    runs: Sequence[tuple[LoadedLog, AnalysisResult]],
    config: AnalysisConfig,
    progress: Progress,
) -> AnalysisResult:
    """One transient fit along all the runs' paths (``estimate``); each run's own analysis is
    kept in ``runs`` (the plugin's ``pool``)."""
    results = [res for _, res in runs]
    inputs: list[PathInputs] = [
        res.artifacts[PATH_INPUTS] for res in results if res.artifacts.get(PATH_INPUTS) is not None
    ]  # a run without path inputs says why in its own stages
    stages = Stages(config.debug)
    progress("pooled transient fit along every run's path")
    pooled = stages.run("pooled transient fit", lambda: _pooled_fit(inputs))
    estimate = None
    methods: list[MethodResult] = []
    if pooled is not None:
        methods.append(replace(pooled.method_result_, segment="pooled"))
        estimate = replace(
            pooled.result_,
            method=f"{pooled.result_.method} pooled over {len(inputs)} runs",
        )
    truth = results[0].truth if all(r.truth == results[0].truth for r in results) else {}
    warnings: list[str] = []
    if len(inputs) < len(results):
        warnings.append(f"{len(results) - len(inputs)} runs have no usable path and are not pooled")
    return AnalysisResult(
        robot=results[0].robot,
        segments=[],
        methods=methods,
        estimate=estimate,
        truth=dict(truth),
        source={
            "runs": [r.source.get("path", "") for r in results],
            "runs_pooled": len(inputs),
        },
        warnings=warnings,
        stages=stages.status,
        runs=list(results),
    )


def _pooled_fit(inputs: list[PathInputs]) -> PathTransientFit:
    from calib.errors import InsufficientDataError
    from calib.tractor_trailer.estimators.drive_path import pool_runs

    if not inputs:
        raise InsufficientDataError("no run has both a moving path and joint-angle samples")
    path, t, psi, gaps, _ = pool_runs([(i.path, i.t_psi_s, i.psi_rad, i.gaps) for i in inputs])
    return PathTransientFit().fit(path, t, psi, gaps=gaps)
