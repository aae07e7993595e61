"""The tractor-trailer's analysis: steering geometry -> segmentation -> path-driven transient
fit -> no-slip regression -> the patent's least-squares methods -> steady-state and time-domain
estimators -> discovery -> joint refit with the sensor effects discovery named; and the pooled
transient fit over several runs.

The library never prints: progress goes to the callback ``progress(stage: str)``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import polars as pl

from calib.adequacy import implausible, mark_implausible
from calib.errors import CalibError
from calib.kinematics.bicycle import SteeringGeometry
from calib.results import AnalysisResult, CalibrationResult, StageStatus
from calib.tractor_trailer.derived import derived_sum, link_sum
from calib.tractor_trailer.discovery.result import DiscoveryResult
from calib.tractor_trailer.estimators.noslip import NoSlipRegression
from calib.tractor_trailer.estimators.path_transient import PathTransientFit
from calib.tractor_trailer.explain import tractor_discovery_report
from calib.tractor_trailer.path_discovery import PathDiscovery
from calib.tractor_trailer.plausible import RANGES as TRACTOR_RANGES
from calib.tractor_trailer.results import CommandType, MethodResult, Segment
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
    if np.max(np.abs(fit.bias_correction_)) > 0.01 * (abs(fit.L1_) + abs(fit.L2_)):
        other = path_inputs(loaded, prefer="odometry")
        if other.path.source == "odometry":
            alt = run(other)
            if np.trace(alt.cov_[:2, :2]) < np.trace(fit.cov_[:2, :2]):
                alt.notes_.append(
                    "the pose is noisy (a large bias correction): odometry gave "
                    "the more precise fit and is used"
                )
                inp, fit = other, alt
    return inp, fit


def _sensor_effects(discovery: object) -> tuple[bool, float, list[str], tuple[Any, ...]]:
    """From command-driven discovery: (fit a joint-angle offset, joint-angle clock offset (s),
    labels used, the confounds the estimate must span). Only the joint-angle effects that no
    confound involves are folded into the fit
    (``calib.tractor_trailer.discovery.sensor_effects_for_fit``);
    an actuator dead time that the log cannot tell from clock offsets is spanned, never folded
    as offsets. An effect confounded with the link lengths themselves (the joint-angle gain,
    ``SpanChoice.free_effect``) is judged along the measured path (path discovery), so the
    command side's confound of it is left to it. Effects on the actuator do not enter a
    path-driven fit."""
    from calib.tractor_trailer.discovery import DiscoveryResult, sensor_effects_for_fit

    if not isinstance(discovery, DiscoveryResult):
        return False, 0.0, [], ()
    plan = sensor_effects_for_fit(discovery)
    offset, shift, labels = plan.fold.as_tuple()
    spans = tuple(ch for ch in plan.span if not ch.free_effect)
    return offset, shift, list(labels), spans


REJECT_CHI2 = 10.83
"""An explanation whose joint-angle corrections raise the path fit's sum of squares over the
best of them by more than this (chi-square, one degree of freedom, p = 0.001, counted at the
residual's effective sample size) is rejected by the measured path: the path sees the joint
angle's clock and offset directly, so the command-driven confound is resolved there, and the
report says so."""


def _span_confounds(
    loaded: LoadedLog,
    estimate: CalibrationResult,
    path_fit: PathTransientFit,
    spans: tuple[Any, ...],
    notes: list[str],
    stages: Stages,
) -> CalibrationResult:
    """The estimate spanning explanations command-driven discovery cannot tell apart (e.g. an
    actuator dead time vs the same clock offset on the command topics): the path fit refitted
    with each explanation's joint-angle corrections; those the measured path does not reject
    (``REJECT_RMS_RATIO``) are spanned (the union of the intervals)."""
    from calib.adequacy import span
    from calib.stats import effective_samples

    fits: list[tuple[str, PathTransientFit]] = []
    for choice in spans:
        for option in choice.options:
            label = " + ".join(option.labels) or "no joint-angle correction"

            def fit(o: Any = option) -> PathTransientFit:
                return _path_fit(loaded, psi_offset=o.psi_offset, psi_shift_s=o.psi_shift_s)[1]

            refit = stages.run(f"refit for the confound ({label})", fit)
            if refit is not None and refit.sound_:
                fits.append((label, refit))
    if not fits:
        return estimate
    best = min([path_fit.residual_rms_, *(f.residual_rms_ for _, f in fits)])
    n_eff = effective_samples(np.asarray(path_fit.residual_, dtype=float))

    def rejected_by_path(f: PathTransientFit) -> bool:
        return bool(n_eff * ((f.residual_rms_ / best) ** 2 - 1.0) > REJECT_CHI2)

    kept = [(lab, f.result_) for lab, f in fits if not rejected_by_path(f)]
    rejected = [(lab, f.residual_rms_ / best) for lab, f in fits if rejected_by_path(f)]
    for choice in spans:
        notes.append(choice.confound.report())
    if rejected:
        notes.append(
            "the measured path rejects "
            + "; ".join(f"{lab} (joint-angle residual {r:.3g}x the best)" for lab, r in rejected)
            + ": the confound is resolved by the path, not spanned"
        )
    alts = [
        (lab, res)
        for lab, res in kept
        if any(
            abs(res.parameters[k].value - e.value) > 1e-12
            for k, e in estimate.parameters.items()
            if k in res.parameters
        )
    ]
    if not alts:
        return estimate
    params = {
        k: span(
            [e, *(a.parameters[k] for _, a in alts if k in a.parameters)],
            [estimate.method, *(lab for lab, a in alts if k in a.parameters)],
            rel_tol=0.1,
            scale=0.05,
        )
        for k, e in estimate.parameters.items()
    }
    total = link_sum(estimate)
    if total is not None:
        sums = [(lab, s) for lab, a in alts if (s := link_sum(a)) is not None]
        total = span(
            [total, *(s for _, s in sums)],
            [estimate.method, *(lab for lab, _ in sums)],
            rel_tol=0.1,
            scale=0.05,
        )
    return replace(
        estimate,
        parameters=params,
        derived=derived_sum(total, estimate.derived),
        verdict=estimate.verdict + " Discovery cannot tell apart explanations that imply "
        "different link lengths; the intervals span them (see the notes).",
    )


def _recommend(
    path_fit: PathTransientFit | None,
    eiv: CalibrationResult | None,
    stages: Stages,
) -> tuple[CalibrationResult | None, list[str]]:
    """The path-driven transient fit when it is sound, else the steady-state estimate with the
    reason in its verdict."""
    notes: list[str] = []
    reason = ""
    if path_fit is not None:
        res = path_fit.result_
        if path_fit.sound_:
            return res, notes
        why = []
        if not path_fit.converged_:
            why.append("the optimiser did not converge")
        if path_fit.on_bound_:
            why.append("estimate on a bound of " + ", ".join(path_fit.on_bound_))
        reason = "transient fit along the path not used: " + (
            "; ".join(why) or "no finite covariance"
        )
    else:
        failed = [s for s in stages.status if s.stage == _PATH_STAGE and s.status != "ok"]
        reason = "transient fit along the path not possible" + (
            f": {failed[0].reason}" if failed else ""
        )
    if eiv is None:
        if path_fit is not None:
            res = path_fit.result_
            return replace(res, verdict=res.verdict + f" ({reason}.)"), [reason]
        return None, [reason]
    notes.append(reason)
    return replace(eiv, verdict=f"{eiv.verdict} ({reason}.)"), notes


def _unexplained(
    estimate: CalibrationResult | None, discovery: object, path_fit: PathTransientFit | None
) -> CalibrationResult | None:
    """Not determined when discovery finds structure in the joint angle's residual that no
    effect of its catalogue explains: the model then leaves out physics that biases L1, L2."""
    model = getattr(discovery, "residual_model", None)
    if estimate is None or path_fit is None or model is None or model.channel != "psi":
        return estimate
    if not estimate.method.startswith(path_fit.name):
        return estimate
    from calib.tractor_trailer.estimators.identifiability import undetermined

    why = (
        "the joint angle keeps structure no catalogued effect explains "
        f"({model.describe()}); the model leaves out physics that biases L1 and L2"
    )
    short = "the model leaves out physics discovery finds in the joint angle (see below)"
    params = {k: undetermined(e, short) for k, e in estimate.parameters.items()}
    fitted = ", ".join(f"{k} = {e.value:.3f} m" for k, e in estimate.parameters.items())
    verdict = (
        f"Not determined: {why}. (The fit alone says {fitted}; model what discovery describes "
        "before trusting it.)"
    )
    return replace(
        estimate,
        parameters=params,
        derived={k: undetermined(e, short) for k, e in estimate.derived.items()},
        verdict=verdict,
        details={**estimate.details, "unexplained_structure": model.describe()},
    )


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


def _path_keys(labels: list[str]) -> list[str]:
    """The effects command-driven discovery named (``labels``) that the path discovery also
    catalogues (same key), less those its hooks leave to the path to judge (``tolerated``: the
    joint-angle gain)."""
    from calib.tractor_trailer.path_effects import catalogue

    path = {e.key: e for e in catalogue()}
    return [k for k in labels if k in path and getattr(path[k].model, "tolerated", None) is None]


def _judged(
    estimate: CalibrationResult | None,
    disc: PathDiscovery | None,
    path_fit: PathTransientFit | None,
    used: list[str],
    notes: list[str],
) -> tuple[CalibrationResult | None, Any]:
    """The recommended estimate after discovery along the path (the sensor effects either
    engine accepted, confounds spanned, widened and not determined under a misfit or a change
    mid-log) and the adequacy of its model."""
    from calib.adequacy import not_assessed
    from calib.tractor_trailer.path_discovery import adopt_effects, recommended

    if estimate is None:
        return None, not_assessed("none", "no estimate")
    if path_fit is None or not estimate.method.startswith(path_fit.name):
        return estimate, not_assessed(
            estimate.method,
            "the recommended estimate is not the fit along the path; its residual is not judged",
        )
    if disc is None or disc.adequacy is None:
        return estimate, not_assessed(
            estimate.method,
            disc.reason if disc is not None else "discovery along the path failed (see the stages)",
        )
    command_keys = _path_keys(used)
    keys = list(dict.fromkeys([e.key for e in disc.accepted] + command_keys))
    if disc.status == "ok" and disc.change is None and set(keys) != {e.key for e in disc.accepted}:
        adopt_effects(disc, keys)
    elif disc.status == "ok" and command_keys and not disc.accepted and disc.estimate is None:
        notes.append(
            "the joint-angle effects command-driven discovery named are kept in the estimate"
        )
    base = estimate if not disc.accepted else path_fit.result_
    out = recommended(base, disc)
    return out, disc.adequacy


_NOSLIP_STAGE = "no-slip regression on the trailer pose"


def _noslip_fit(loaded: LoadedLog) -> NoSlipRegression:
    t, (x2, y2, yaw2, psi) = trailer_pose_inputs(loaded)
    return NoSlipRegression().fit(t, x2, y2, yaw2, psi)


def analyze_tractor_trailer(
    loaded: LoadedLog, config: AnalysisConfig, progress: Progress
) -> AnalysisResult:
    """Analyse one tractor-trailer log (the plugin's ``analyze``); ``config`` is an
    ``AnalysisConfig``. The transient fit's path inputs are kept in
    ``artifacts[PATH_INPUTS]`` so that pooling reuses them."""
    cfg = config
    _require(loaded, ("psi",))
    stages = Stages(cfg.debug)
    rng = np.random.default_rng(cfg.seed)
    notes: list[str] = []
    from calib.tractor_trailer.models.hitch_rk4 import compiled_available

    if not compiled_available():
        notes.append(
            "the compiled integrator (calib/tractor_trailer/models/_hitch_rk4.c) is not "
            "built here; analysed on its numpy loop, about 5x slower (pip install . "
            "builds it)"
        )
    geometry = _steering_geometry(loaded, stages, progress, notes)
    if geometry is not None:
        loaded = _with_kappa_cmd_from_steering(loaded, geometry, notes)
    has_kappa = "kappa" in loaded.frame.columns
    frame = _usable_rows(loaded.frame, ("psi", "kappa") if has_kappa else ("psi",))
    t_s = (frame["t_ns"].to_numpy() - frame["t_ns"][0]) / 1e9 if frame.height else np.zeros(0)

    progress("segmenting by command type")
    segments: list[Segment] = []
    if "kappa_cmd" not in frame.columns:
        stages.skip("segmentation", "no curvature command (kappa_cmd) in the log")
    elif frame.height < 10:
        stages.skip("segmentation", f"{frame.height} usable rows; need 10")
    else:
        segments = stages.run("segmentation", lambda: _segments(t_s, frame)) or []

    progress(_PATH_STAGE)
    path_out = stages.run(_PATH_STAGE, lambda: _path_fit(loaded))
    path_fit = path_out[1] if path_out else None
    if path_out:
        notes += path_out[0].notes + path_out[1].notes_

    methods: list[MethodResult] = []
    noslip = None
    if {"x2", "y2", "yaw2"} <= set(loaded.signals.signals):
        progress(_NOSLIP_STAGE)
        noslip = stages.run(_NOSLIP_STAGE, lambda: _noslip_fit(loaded))
        if noslip is not None:
            methods.append(noslip.method_result_)
    eiv = None
    still = stages.errors.get(_PATH_STAGE)
    if not isinstance(still, RobotDidNotMoveError):
        still = None
    if still:
        stages.skip("least-squares methods", "the robot did not move")
        stages.skip("steady-state and time-domain estimators", "the robot did not move")
    elif not has_kappa:
        reason = "no measured curvature (kappa needs v and omega, or a pose path)"
        stages.skip("least-squares methods", reason)
        stages.skip("steady-state and time-domain estimators", reason)
    elif frame.height < 10:
        reason = f"{frame.height} rows have both psi and kappa; need 10"
        stages.skip("least-squares methods", reason)
        stages.skip("steady-state and time-domain estimators", reason)
    else:
        kappa = frame["kappa"].to_numpy()
        psi = frame["psi"].to_numpy()
        v = frame["v"].to_numpy() if "v" in frame.columns else None
        tables = stages.run(
            "least-squares methods",
            lambda: _method_tables(kappa, psi, segments, cfg, rng, progress),
        )
        if tables:
            methods += tables[0]
            notes += tables[1]
        from calib.tractor_trailer.estimators.recommend import calibrate_link_lengths

        progress("steady-state and time-domain estimators")
        own = stages.run(
            "steady-state and time-domain estimators",
            lambda: calibrate_link_lengths(t_s, kappa, psi, v, segments=segments, rng=rng),
        )
        if own:
            eiv = own[0] if own[0].method == "EIV-ML" else None
            methods += list(own[1])
    if path_fit is not None:
        methods.append(path_fit.method_result_)
    if still:
        estimate, why = None, [str(still)]
    elif noslip is not None and (path_fit is None or not path_fit.sound_):
        estimate = replace(
            noslip.result_,
            verdict=noslip.result_.verdict
            + (
                " (No measured tractor path: the trailer pose and the joint angle give this "
                "estimate.)"
            ),
        )
        why = []
    else:
        estimate, why = _recommend(path_fit, eiv, stages)
    notes += why

    discovery = None
    if not cfg.discovery:
        stages.skip("discovery", "switched off (--no-discovery)")
    elif estimate is None:
        stages.skip(_COMMAND_STAGE, "no calibrated link lengths to start from")
    elif "kappa_cmd" not in frame.columns:
        stages.skip(
            _COMMAND_STAGE,
            "discovery compares against the curvature command; the log has none (kappa_cmd)",
        )
    else:
        from calib.tractor_trailer.discovery import discover
        from calib.tractor_trailer.discovery.windows import DEFAULT_MAX_SPAN_S

        progress("model-mismatch discovery")
        opts = cfg.options(TractorTrailerOptions)
        span = DEFAULT_MAX_SPAN_S if opts.discovery_span_s is None else opts.discovery_span_s
        L1 = estimate.parameters["L1"].value
        L2 = estimate.parameters["L2"].value
        discovery = stages.run(
            _COMMAND_STAGE,
            lambda: discover(
                frame,
                L1,
                L2,
                baseline="steady" if opts.baseline == "steady" else "transient",
                segments=segments,
                rng=rng,
                signals=loaded.signals.signals,
                max_span_s=span,
            ),
        )
        status = getattr(discovery, "status", "ok")
        if discovery is not None and status != "ok":
            stages.status[-1] = StageStatus(
                _COMMAND_STAGE,
                "skipped" if status == "not_run" else "ok",
                f"{status}: {discovery.reason}" if discovery.reason else status,
            )
            if status == "not_run":
                discovery = None
    offset, shift, used, confounded = _sensor_effects(discovery)
    shown_fit, shown_shift = path_fit, 0.0  # the fit whose prediction the views draw
    if used and path_fit is not None:
        progress("refit with the effects discovery named")
        joint = stages.run(
            "joint refit with discovered sensor effects",
            lambda: _path_fit(loaded, psi_offset=offset, psi_shift_s=shift)[1],
        )
        if joint is not None and joint.sound_:
            shown_fit, shown_shift = joint, shift
            res = joint.result_
            model = f"{res.method} + " + " + ".join(used)
            estimate = replace(
                res,
                method=model,
                details={**res.details, "model": model, "effects_included": used},
            )
    path_disc = None
    if path_out and path_fit is not None and not still:
        path_disc = _path_discovery(path_out[0], path_fit, frame, segments, cfg, stages, progress)
    estimate, adequacy = _judged(estimate, path_disc, path_fit, used, notes)
    if (
        confounded
        and estimate is not None
        and path_fit is not None
        and (estimate.method.startswith(path_fit.name))
    ):
        progress("refits for the confounded explanations")
        estimate = _span_confounds(loaded, estimate, path_fit, confounded, notes, stages)
    judged = estimate
    if path_disc is None or path_disc.status != "ok":
        # the path's residual model judges the joint angle when it ran; else the command side
        estimate = _unexplained(estimate, discovery, path_fit)
    if estimate is not judged and adequacy is not None and adequacy.channels:
        described = discovery.residual_model.describe()  # type: ignore[union-attr]
        adequacy = adequacy.with_(
            notes=(
                *adequacy.notes,
                (
                    "command-driven discovery finds structure in the joint angle that no "
                    f"catalogued effect explains ({described}); the estimate is not determined"
                ),
            )
        )
    if (
        path_disc is not None
        and path_disc.solution is not None
        and estimate is not None
        and (estimate.method.startswith(PathTransientFit.name) and path_disc.accepted)
    ):
        shown_fit = None  # the views draw the nominal fit only where it is the estimate
    if estimate is not None and path_fit is not None and estimate.method.startswith(path_fit.name):
        actuator = [
            e.label for e in getattr(discovery, "effects", []) or [] if e.kind == "actuator"
        ]
        if actuator:
            notes.append(
                "the recommended estimate follows the measured path, so the actuator effects "
                f"discovery named ({', '.join(actuator)}) do not bias it"
            )

    source = {
        "path": str(loaded.path),
        "samples": frame.height,
        "duration_s": float(t_s[-1]) if t_s.size else 0.0,
        "signals": {k: f"{s.topic}:{s.field}" for k, s in loaded.signals.sources.items()},
    }
    if path_out:
        source["path_source"] = path_out[0].path.source
    if geometry is not None:
        source["steering_geometry"] = geometry.to_dict()
    found = implausible(estimate, adequacy, TRACTOR_RANGES)
    if found and estimate is not None:
        estimate = mark_implausible(estimate, found)
        notes += [f"implausible: {f.text}" for f in found]
    sections: dict[str, Any] = {}
    if path_disc is not None and path_disc.status == "ok":
        sections["path_discovery"] = path_disc
    command = discovery if isinstance(discovery, DiscoveryResult) else None
    shown: Any = None  # neither engine ran (--no-discovery, or nothing to start from)
    if (path_disc is not None and path_disc.status == "ok") or command is not None:
        shown = tractor_discovery_report(
            path_disc,
            command,
            adequacy,
            path_fit.result_ if path_fit is not None else None,
            estimate,
        )
    result = AnalysisResult(
        robot=str(loaded.robot),
        segments=segments,
        methods=methods,
        estimate=estimate,
        discovery=shown,
        adequacy=adequacy,
        sections=sections,
        truth=dict(loaded.truth),
        source=source,
        warnings=[str(p) for p in loaded.problems] + notes,
        stages=stages.status,
    )
    from calib.tractor_trailer.views_data import VIEWS, tractor_views_data, transient_prediction

    columns: dict[str, np.ndarray] = {
        c: loaded.frame[c].cast(pl.Float64).fill_null(np.nan).to_numpy()
        for c in ("x", "y", "yaw", "psi", "kappa", "omega", "v")
        if c in loaded.frame.columns
    }
    method = cfg.options(TractorTrailerOptions).method_for_psi
    try:
        transient = None  # the recommended transient fit's own prediction, when it is one
        if (
            path_out
            and shown_fit is not None
            and estimate is not None
            and (estimate.method.startswith(shown_fit.name))
        ):
            transient = transient_prediction(shown_fit, path_out[0].t0_ns, shown_shift)
        views = tractor_views_data(columns, result, method_for_psi=method, transient=transient)
    except KeyError as err:  # the user's --method names no method of this analysis: exit 2
        raise LogcalInputError(f"--method {method!r}: {err.args[0]}") from None
    except Exception as err:  # drawing data: a failure stays inside its own stage
        if cfg.debug:
            raise
        views = {}
        stages.status.append(StageStatus("views data", "failed", f"{type(err).__name__}: {err}"))
    return replace(result, artifacts={PATH_INPUTS: path_out[0] if path_out else None, VIEWS: views})


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
