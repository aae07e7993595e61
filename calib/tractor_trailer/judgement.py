"""The tractor-trailer's judgement of its estimates: which estimate to recommend, which sensor
effects discovery named enter the fit along the path, which confounded explanations the
measured path rejects and which the estimate spans, when the link lengths are not determined
(structure discovery finds that no catalogued effect explains, implausible values).

Why here and not in the pipeline (``logtools.robots.tractor_trailer.pipeline``): these are
statistical decisions over calib's own results (fits, discovery results, adequacy), so the
pipeline only reads the log, runs the stages and reports. Pure functions: no frames, no
stages, no progress; the refits a decision needs are made by the caller and passed in.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from calib.adequacy import (
    Adequacy,
    implausible,
    mark_implausible,
    not_assessed,
    span,
)
from calib.results import CalibrationResult
from calib.stats import effective_samples
from calib.tractor_trailer.derived import derived_sum, link_sum
from calib.tractor_trailer.discovery.confounds import SpanChoice
from calib.tractor_trailer.discovery.effects.base import SensorCorrections
from calib.tractor_trailer.discovery.result import DiscoveryResult
from calib.tractor_trailer.estimators.identifiability import undetermined
from calib.tractor_trailer.estimators.noslip import NoSlipRegression
from calib.tractor_trailer.estimators.path_transient import PathTransientFit
from calib.tractor_trailer.path_discovery import PathDiscovery, adopt_effects, recommended
from calib.tractor_trailer.plausible import RANGES

__all__ = [
    "NOISY_POSE_BIAS",
    "REJECT_CHI2",
    "FoldedEffects",
    "actuator_note",
    "confound_explanations",
    "folded_effects",
    "follows_path",
    "judge_along_path",
    "judge_plausible",
    "judge_unexplained",
    "more_precise",
    "pose_too_noisy",
    "recommend",
    "recommended_estimate",
    "span_confounds",
]

REJECT_CHI2 = 10.83
"""An explanation whose joint-angle corrections raise the path fit's sum of squares over the
best of them by more than this (chi-square, one degree of freedom, p = 0.001, counted at the
residual's effective sample size) is rejected by the measured path: the path sees the joint
angle's clock and offset directly, so the command-driven confound is resolved there, and the
report says so."""


@dataclass(frozen=True)
class FoldedEffects:
    """What the fit along the path takes in from command-driven discovery: fit a joint-angle
    offset (``psi_offset``), the joint angle's clock offset (``psi_shift_s``, s), the labels
    of the effects used, and the confounds the estimate must span (``spans``)."""

    psi_offset: bool = False
    psi_shift_s: float = 0.0
    labels: list[str] = field(default_factory=list)
    spans: tuple[SpanChoice, ...] = ()


def folded_effects(discovery: object) -> FoldedEffects:
    """From command-driven discovery: the sensor effects the fit along the path takes in. Only
    the joint-angle effects that no confound involves are folded into the fit
    (``calib.tractor_trailer.discovery.sensor_effects_for_fit``);
    an actuator dead time that the log cannot tell from clock offsets is spanned, never folded
    as offsets. An effect confounded with the link lengths themselves (the joint-angle gain,
    ``SpanChoice.free_effect``) is judged along the measured path (path discovery), so the
    command side's confound of it is left to it. Effects on the actuator do not enter a
    path-driven fit."""
    from calib.tractor_trailer.discovery import sensor_effects_for_fit

    if not isinstance(discovery, DiscoveryResult):
        return FoldedEffects()
    plan = sensor_effects_for_fit(discovery)
    offset, shift, labels = plan.fold.as_tuple()
    spans = tuple(ch for ch in plan.span if not ch.free_effect)
    return FoldedEffects(offset, shift, list(labels), spans)


NOISY_POSE_BIAS = 0.01
"""A fit along a pose path whose noise-bias correction of the joint angle exceeds this fraction
of |L1| + |L2| is compared with the fit along odometry: the pose may be too noisy."""


def pose_too_noisy(fit: PathTransientFit) -> bool:
    """Whether ``fit`` (along a pose path) needs so large a noise-bias correction
    (``NOISY_POSE_BIAS``) that the fit along odometry should be compared with it."""
    return bool(
        np.max(np.abs(fit.bias_correction_)) > NOISY_POSE_BIAS * (abs(fit.L1_) + abs(fit.L2_))
    )


def more_precise(fit: PathTransientFit, than: PathTransientFit) -> bool:
    """Whether ``fit`` determines L1, L2 more precisely than ``than`` (a smaller trace of
    their covariance)."""
    return bool(np.trace(fit.cov_[:2, :2]) < np.trace(than.cov_[:2, :2]))


def follows_path(estimate: CalibrationResult | None, path_fit: PathTransientFit | None) -> bool:
    """Whether ``estimate`` is the fit along the path (possibly with effects folded in)."""
    return (
        estimate is not None and path_fit is not None and estimate.method.startswith(path_fit.name)
    )


def recommend(
    path_fit: PathTransientFit | None,
    eiv: CalibrationResult | None,
    path_failure: str | None,
) -> tuple[CalibrationResult | None, list[str]]:
    """The path-driven transient fit when it is sound, else the steady-state estimate with the
    reason in its verdict. ``path_failure``: why the fit along the path failed (its stage's
    reason), None when it did not fail or when it is not known."""
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
        reason = "transient fit along the path not possible" + (
            f": {path_failure}" if path_failure is not None else ""
        )
    if eiv is None:
        if path_fit is not None:
            res = path_fit.result_
            return replace(res, verdict=res.verdict + f" ({reason}.)"), [reason]
        return None, [reason]
    notes.append(reason)
    return replace(eiv, verdict=f"{eiv.verdict} ({reason}.)"), notes


def recommended_estimate(
    did_not_move: str | None,
    noslip: NoSlipRegression | None,
    path_fit: PathTransientFit | None,
    eiv: CalibrationResult | None,
    path_failure: str | None,
) -> tuple[CalibrationResult | None, list[str]]:
    """The estimate to recommend before discovery, and the notes that say why: none when the
    robot did not move (``did_not_move``: why); the no-slip regression on the trailer pose when
    there is no sound fit along a measured tractor path; else :func:`recommend`."""
    if did_not_move is not None:
        return None, [did_not_move]
    if noslip is not None and (path_fit is None or not path_fit.sound_):
        res = noslip.result_
        return replace(
            res,
            verdict=res.verdict + " (No measured tractor path: the trailer pose and the joint "
            "angle give this estimate.)",
        ), []
    return recommend(path_fit, eiv, path_failure)


def confound_explanations(spans: Sequence[SpanChoice]) -> list[tuple[str, SensorCorrections]]:
    """Each explanation of the confounds the estimate must span: (its label, the joint-angle
    corrections a refit along the path takes in)."""
    return [
        (" + ".join(option.labels) or "no joint-angle correction", option)
        for choice in spans
        for option in choice.options
    ]


def span_confounds(
    estimate: CalibrationResult,
    path_fit: PathTransientFit,
    refits: Sequence[tuple[str, PathTransientFit | None]],
    spans: Sequence[SpanChoice],
) -> tuple[CalibrationResult, list[str]]:
    """The estimate spanning explanations command-driven discovery cannot tell apart (e.g. an
    actuator dead time vs the same clock offset on the command topics), and the notes that say
    so. ``refits``: the path fit refitted with each explanation's joint-angle corrections
    (:func:`confound_explanations`; None where the refit failed); those the measured path does
    not reject (``REJECT_CHI2``) are spanned (the union of the intervals)."""
    fits = [(label, f) for label, f in refits if f is not None and f.sound_]
    if not fits:
        return estimate, []
    best = min([path_fit.residual_rms_, *(f.residual_rms_ for _, f in fits)])
    n_eff = effective_samples(np.asarray(path_fit.residual_, dtype=float))

    def rejected_by_path(f: PathTransientFit) -> bool:
        return bool(n_eff * ((f.residual_rms_ / best) ** 2 - 1.0) > REJECT_CHI2)

    kept = [(lab, f.result_) for lab, f in fits if not rejected_by_path(f)]
    rejected = [(lab, f.residual_rms_ / best) for lab, f in fits if rejected_by_path(f)]
    notes = [choice.confound.report() for choice in spans]
    if rejected:
        notes.append(
            "the measured path rejects "
            + "; ".join(f"{lab} (joint-angle residual {r:.3g}x the best)" for lab, r in rejected)
            + ": the confound is resolved by the path, not spanned"
        )
    alts = [(lab, res) for lab, res in kept if _moves_parameters(res, estimate)]
    if not alts:
        return estimate, notes
    return _spanning(estimate, alts), notes


def _moves_parameters(alternative: CalibrationResult, estimate: CalibrationResult) -> bool:
    """Whether ``alternative`` gives some parameter of ``estimate`` another value."""
    return any(
        abs(alternative.parameters[k].value - e.value) > 1e-12
        for k, e in estimate.parameters.items()
        if k in alternative.parameters
    )


def _spanning(
    estimate: CalibrationResult, alts: Sequence[tuple[str, CalibrationResult]]
) -> CalibrationResult:
    """``estimate`` with every parameter and the link sum spanning the alternatives'."""
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


def judge_unexplained(
    estimate: CalibrationResult | None,
    adequacy: Adequacy,
    discovery: object,
    path_fit: PathTransientFit | None,
    path_discovery_ran: bool,
) -> tuple[CalibrationResult | None, Adequacy]:
    """The estimate and adequacy after command-driven discovery's residual model, when the
    path's did not run (``path_discovery_ran``: the path's residual model judges the joint
    angle when it ran): not determined, with a note in the adequacy, where the joint angle keeps
    structure no catalogued effect explains."""
    if path_discovery_ran:
        return estimate, adequacy
    judged = estimate
    estimate = _unexplained(estimate, discovery, path_fit)
    if estimate is not judged and adequacy.channels:
        described = discovery.residual_model.describe()  # type: ignore[attr-defined]
        adequacy = adequacy.with_(
            notes=(
                *adequacy.notes,
                (
                    "command-driven discovery finds structure in the joint angle that no "
                    f"catalogued effect explains ({described}); the estimate is not determined"
                ),
            )
        )
    return estimate, adequacy


def _path_keys(labels: list[str]) -> list[str]:
    """The effects command-driven discovery named (``labels``) that the path discovery also
    catalogues (same key), less those its hooks leave to the path to judge (``tolerated``: the
    joint-angle gain)."""
    from calib.tractor_trailer.path_effects import catalogue

    path = {e.key: e for e in catalogue()}
    return [k for k in labels if k in path and getattr(path[k].model, "tolerated", None) is None]


def judge_along_path(
    estimate: CalibrationResult | None,
    disc: PathDiscovery | None,
    path_fit: PathTransientFit | None,
    used: list[str],
) -> tuple[CalibrationResult | None, Adequacy, list[str]]:
    """The recommended estimate after discovery along the path (the sensor effects either
    engine accepted, confounds spanned, widened and not determined under a misfit or a change
    mid-log), the adequacy of its model and notes. ``used``: the effects command-driven
    discovery named and the estimate folded in."""
    if estimate is None:
        return None, not_assessed("none", "no estimate"), []
    if path_fit is None or not estimate.method.startswith(path_fit.name):
        return (
            estimate,
            not_assessed(
                estimate.method,
                "the recommended estimate is not the fit along the path; its residual is not "
                "judged",
            ),
            [],
        )
    if disc is None or disc.adequacy is None:
        return (
            estimate,
            not_assessed(
                estimate.method,
                disc.reason
                if disc is not None
                else "discovery along the path failed (see the stages)",
            ),
            [],
        )
    notes: list[str] = []
    command_keys = _path_keys(used)
    keys = list(dict.fromkeys([e.key for e in disc.accepted] + command_keys))
    if disc.status == "ok" and disc.change is None and set(keys) != {e.key for e in disc.accepted}:
        adopt_effects(disc, keys)
    elif disc.status == "ok" and command_keys and not disc.accepted and disc.estimate is None:
        notes.append(
            "the joint-angle effects command-driven discovery named are kept in the estimate"
        )
    base = estimate if not disc.accepted else path_fit.result_
    return recommended(base, disc), disc.adequacy, notes


def actuator_note(
    estimate: CalibrationResult | None, path_fit: PathTransientFit | None, discovery: object
) -> str | None:
    """When the estimate follows the measured path, the note that the actuator effects
    command-driven discovery named do not bias it (None: no such effect, or another
    estimate)."""
    if not follows_path(estimate, path_fit):
        return None
    actuator = [e.label for e in getattr(discovery, "effects", []) or [] if e.kind == "actuator"]
    if not actuator:
        return None
    return (
        "the recommended estimate follows the measured path, so the actuator effects "
        f"discovery named ({', '.join(actuator)}) do not bias it"
    )


def judge_plausible(
    estimate: CalibrationResult | None, adequacy: Adequacy | None
) -> tuple[CalibrationResult | None, list[str]]:
    """The estimate marked where its link lengths lie outside what machines of the kind have
    (:data:`calib.tractor_trailer.plausible.RANGES`), and the notes naming what."""
    found = implausible(estimate, adequacy, RANGES)
    if not found or estimate is None:
        return estimate, []
    return mark_implausible(estimate, found), [f"implausible: {f.text}" for f in found]
