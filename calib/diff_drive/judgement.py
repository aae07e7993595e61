"""The differential drive's judgement of its calibration: which stuck encoder spans are left
out, the label of the model judged, the radii's pieces across a radius change, the estimate as
a model that does not explain the log allows it (spanning discovery's explanations, else
widened), the log's verdict with the samples left out and the slip named, and plausibility.

Why here and not in the pipeline (``logtools.robots.diff_drive.pipeline``): these are decisions
over calib's own results (fits, adequacy, discovery's selection), so the pipeline only reads the
log, runs the stages and reports. Pure functions: no stages, no progress.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

from calib.adequacy import (
    NOT_EXPLAINED,
    Adequacy,
    Location,
    ParameterChange,
    implausible,
    mark_implausible,
    under_misfit,
)
from calib.diff_drive.adequacy import PIECE_NAMES, StuckSpan, piece_fits
from calib.diff_drive.data import DriveRun
from calib.diff_drive.effects import DiffDriveSelection, stuck_spec
from calib.diff_drive.explain import span_explanations
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.plausible import RANGES
from calib.diff_drive.slip import SlipFit
from calib.results import CalibrationResult

__all__ = [
    "LSQ_MODEL",
    "excluded_stuck_spans",
    "judge_plausible",
    "judged_estimate",
    "log_verdict",
    "model_label",
    "radius_pieces",
    "widen",
]

LSQ_MODEL = "LSQ (r_R, r_L, b)"
"""The label of the constant-parameter odometry model the least squares fit."""


def excluded_stuck_spans(
    spans: Sequence[StuckSpan], disc: DiffDriveSelection | None
) -> list[StuckSpan]:
    """The stuck encoder spans left out of the calibration: those discovery named (accepted),
    or every span detected when discovery is off or failed (the detection alone decides)."""
    named_keys = {e.key for e in disc.accepted} if disc is not None else set()
    excluded = [s for s in spans if stuck_spec(s).key in named_keys]
    if disc is None and spans:
        excluded = list(spans)
    return excluded


def radius_pieces(
    runs: Sequence[DriveRun], params: DiffDriveParams, offset: complex | None
) -> dict[str, list[float]]:
    """Each wheel radius on consecutive pieces of the runs (from the pieces' mean and difference
    of the radii), the spread a misfit's interval takes in."""
    pieces: dict[str, list[float]] = {}
    for pf in piece_fits(runs, params, offset=offset):
        mean, diff = (pf.values[n] for n in PIECE_NAMES)
        pieces.setdefault("wheel_radius_right", []).append(mean + 0.5 * diff)
        pieces.setdefault("wheel_radius_left", []).append(mean - 0.5 * diff)
    return pieces


def widen(
    result: CalibrationResult, adequacy: Adequacy, pieces: Mapping[str, Sequence[float]]
) -> CalibrationResult:
    """``result`` with every radius and the track as a model that does not explain the log
    allows (:func:`calib.adequacy.under_misfit`)."""
    if adequacy.explains or not adequacy.channels:
        return result
    params = {
        k: under_misfit(e, adequacy, pieces=pieces.get(k, ())) for k, e in result.parameters.items()
    }
    return dataclasses.replace(
        result,
        parameters=params,
        verdict=result.verdict + "; the model does not explain the log: intervals widened, "
        "not determined",
    )


def model_label(excluded: Sequence[StuckSpan]) -> str:
    if not excluded:
        return LSQ_MODEL
    return LSQ_MODEL + ", samples of " + ", ".join(s.label for s in excluded) + " excluded"


def log_verdict(
    adequacy: Adequacy, first: Adequacy, excluded: Sequence[StuckSpan], slip: SlipFit | None
) -> Adequacy:
    """The log's verdict: samples left out (a stuck encoder) or a named slip mean that the
    constant-parameter odometry model does not explain the log as recorded, even when the model
    with them explains the rest; the places are named. The estimates were judged (and widened)
    on the model with them, before this."""
    if not excluded and slip is None:
        return adequacy
    ch = {c.channel: c for c in (first.channels or adequacy.channels)}
    head = ch.get("heading increment")
    along = ch.get("along-track displacement")
    locs: list[Location] = []
    total = max((float(c.n) for c in ch.values()), default=1.0)
    for s in excluded:
        floor = head.noise_floor if head is not None and head.noise_floor > 0 else math.nan
        locs.append(
            Location(
                "heading increment",
                "time",
                f"stuck encoder {s.label}",
                s.t0_s,
                s.t1_s,
                abs(s.heading_rad),
                abs(s.heading_rad) / floor,
                1.0,
                min(1.0, (s.t1_s - s.t0_s) / max(total * 0.5, 1e-9)),
            )
        )
    if slip is not None and along is not None:
        locs.append(
            Location(
                "along-track displacement",
                "speed (m/s)",
                f"speed-dependent slip (k = {slip.k.value:.3g} s/m)",
                0.0,
                math.inf,
                along.residual_rms,
                along.ratio,
                1.0,
                1.0,
            )
        )
    what = [f"{len(excluded)} stuck encoder span(s) left out"] if excluded else []
    what += ["speed-dependent wheel slip named"] if slip is not None else []
    notes = (
        *adequacy.notes,
        "the constant-parameter odometry model does not explain the log "
        "as recorded (" + "; ".join(what) + f"); with them: {adequacy.verdict}",
    )
    return adequacy.with_(
        verdict=NOT_EXPLAINED,
        located=(*locs, *adequacy.located),
        notes=notes,
        unexplained=adequacy.unexplained or ", ".join(what),
    )


def judged_estimate(
    result: CalibrationResult,
    disc: DiffDriveSelection | None,
    change: ParameterChange | None,
    adequacy: Adequacy,
    pieces: Mapping[str, Sequence[float]],
    recorded: list[DriveRun],
    seed: int,
) -> CalibrationResult:
    """The estimate after the final adequacy: spanning the explanations discovery's selection
    cannot tell apart (each calibrated on the ``recorded`` runs) when there is no radius
    change, else widened as the misfit allows (:func:`widen`)."""
    if disc is not None and disc.selection is not None and change is None:
        misfit = None if adequacy.explains else adequacy.misfit_factor
        spanned = span_explanations(result, disc, recorded, seed, misfit=misfit)
        if spanned is not None:
            return spanned
    return widen(result, adequacy, pieces)


def judge_plausible(
    result: CalibrationResult, adequacy: Adequacy
) -> tuple[CalibrationResult, list[str]]:
    """The estimate marked where a radius or the track lies outside what drives of the kind
    have (:data:`calib.diff_drive.plausible.RANGES`), and the notes naming what."""
    found = implausible(result, adequacy, RANGES)
    if not found:
        return result, []
    return mark_implausible(result, found), [f"implausible: {f.text}" for f in found]
