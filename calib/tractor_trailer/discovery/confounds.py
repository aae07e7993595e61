"""Confounds of the link lengths: explanations a log does not tell apart that imply different
L1, L2, and what a fit of the link lengths may take in from discovery.

Discovery names one explanation of a misfit; where another one fits (nearly) as well, it lists
it (``AlternativeExplanation``). For the model's own use that is enough. For the link lengths
it is not: an actuator dead time and the same clock offset on every measured topic change the
recordings alike, but only the second says the joint-angle topic is stamped late, and a fit of
L1, L2 along the measured path that takes in that time shift gives other link lengths than one
that does not (issue: a 0.3 s dead time taken for two clock offsets moved L1 from 1.25 m to
1.56 m with an interval excluding the truth). A joint-angle gain is worse: at small angles
psi ~ kappa (L1 + L2), so a sensor reading 5 % high is taken in by L1 + L2 (L1 +16 % on a
trailer with L1 = 1.25 m, L2 = 2.48 m), and the log cannot tell.

``find_confounds`` fits each explanation that is within ``confirm.EQUIVALENCE_MARGIN`` BIC of
the reported one (``alternatives``), or that BIC separates but whose held-out errors differ
immaterially (``Confirmed.close``), jointly with L1, L2 on every valid row, and keeps those
whose link lengths differ by more than one combined standard error or whose joint-angle
corrections differ. It also fits the reported model with a free joint-angle gain: if that
widens the interval of L1 or L2 by more than ``GAIN_STD_RATIO`` (the log does not pin the
gain), the gain is a confound of the link lengths (unless discovery named it).

``sensor_effects_for_fit`` turns a result into what the recommended estimate may take in
(``fold``) and what it must span (refit with each option and take the union of the
intervals) or leave "not determined".
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from calib.tractor_trailer.discovery.confirm import (
    EQUIVALENCE_MARGIN,
    Confirmed,
    effect_ci95,
    effect_values,
    fit_set,
)
from calib.tractor_trailer.discovery.data import DiscoveryData
from calib.tractor_trailer.discovery.effects import Effect
from calib.tractor_trailer.discovery.fit import ModelFit, covariance
from calib.tractor_trailer.discovery.model import ModelSpec
from calib.tractor_trailer.discovery.result import (
    AlternativeExplanation,
    Confound,
    DiscoveryResult,
    ExplanationFit,
    SensorCorrections,
)

__all__ = [
    "GAIN_KEY",
    "GAIN_RULE",
    "GAIN_STD_RATIO",
    "MAX_SPAN_GAIN",
    "SensorEffectsForFit",
    "SpanChoice",
    "corrections_of",
    "find_confounds",
    "sensor_effects_for_fit",
]

GAIN_KEY = "sensor_scale(psi)"
GAIN_RULE = "joint_angle_gain_vs_link_lengths"
# a free joint-angle gain that widens the standard error of L1 or L2 by more than this factor
# is not pinned by the log: it is a confound of the link lengths
GAIN_STD_RATIO = 1.5
# a gain confound is spanned (refit at the ends of the gain's interval) only when that interval
# lies within 1 +/- this; wider, the link lengths are not determined by the log
MAX_SPAN_GAIN = 0.1
_OFFSET_KEY = "sensor_offset(psi)"
_SHIFT_KEYS = ("clock_offset(hitch)", "clock_offset(psi)")
_PSI_KEYS = (_OFFSET_KEY, *_SHIFT_KEYS, GAIN_KEY)


def corrections_of(values: Mapping[str, Mapping[str, float]]) -> SensorCorrections:
    """The joint-angle corrections of a set of effects (key -> parameter values)."""
    shift = 0.0
    for k in _SHIFT_KEYS:
        if k in values:
            shift = float(values[k]["offset"])
    scale = float(values[GAIN_KEY]["scale"]) if GAIN_KEY in values else 1.0
    return SensorCorrections(
        psi_offset=_OFFSET_KEY in values,
        psi_shift_s=shift,
        psi_scale=scale,
        labels=tuple(k for k in values if k in _PSI_KEYS),
    )


def _explanation(fit: ModelFit, cov: np.ndarray, data: DiscoveryData) -> ExplanationFit:
    vals = {n: float(fit.theta[i]) for i, n in enumerate(("L1", "L2"))}
    sd = {}
    for i, n in enumerate(("L1", "L2")):
        v = math.sqrt(max(float(cov[i, i]), 0.0))
        sd[n] = v if v > 0 and math.isfinite(v) else math.nan
    ev = effect_values(fit)
    return ExplanationFit(
        effects=tuple(e.key for e in fit.spec.effects),
        parameters=vals,
        std=sd,
        ci95={n: (vals[n] - 1.96 * sd[n], vals[n] + 1.96 * sd[n]) for n in vals},
        effect_parameters=ev,
        effect_ci95=effect_ci95(fit, data, cov),
        corrections=corrections_of(ev),
    )


def _lengths_differ(a: ExplanationFit, b: ExplanationFit) -> bool:
    """L1 or L2 differ by more than one combined standard error (or one is not finite)."""
    for k in ("L1", "L2"):
        d = abs(a.parameters[k] - b.parameters[k])
        s = math.hypot(a.std[k], b.std[k])
        if not math.isfinite(s) or d > s:
            return True
    return False


def _alternative_confound(
    data: DiscoveryData,
    baseline: ModelSpec,
    conf: Confirmed,
    by_key: Mapping[str, Effect],
    reported: ExplanationFit,
    alt: AlternativeExplanation,
    close: str,
) -> Confound | None:
    """``alt`` as a confound if it implies other link lengths or joint-angle corrections;
    ``close``: why BIC's choice does not settle it (empty: ``alt`` is within the margin)."""
    if not all(k in by_key for k in alt.alternative):
        return None
    effects = [e for e in conf.effects if e.key not in alt.reported]
    effects += [by_key[k] for k in alt.alternative]
    start = {k: v for k, v in effect_values(conf.final).items() if k not in alt.reported}
    start.update({k: dict(v) for k, v in alt.parameters.items()})
    g = fit_set(baseline, effects, data, conf.final.theta[:2], start, data.valid, fine=True)
    other = _explanation(g, covariance(g, data), data)
    lengths = _lengths_differ(reported, other)
    corr = not reported.corrections.same_as(other.corrections, shift_tol_s=data.time_resolution_s)
    if not (lengths or corr):
        return None
    if close:
        why = f"BIC prefers {' + '.join(alt.reported)} by {alt.delta_bic:.1f}, but {close}"
    else:
        why = (
            f"the two fit within {EQUIVALENCE_MARGIN:g} BIC units (alternative "
            f"{alt.delta_bic:+.1f})"
        )
    what = []
    if lengths:
        what.append("they imply link lengths that differ by more than their standard errors")
    if corr:
        what.append("they correct the joint-angle sensor differently")
    return Confound(
        rule=alt.rule,
        reported=reported,
        alternative=other,
        delta_bic=alt.delta_bic,
        why=f"{why}; {' and '.join(what)}",
        lengths_differ=lengths,
        corrections_differ=corr,
    )


def _gain_confound(
    data: DiscoveryData,
    baseline: ModelSpec,
    conf: Confirmed,
    by_key: Mapping[str, Effect],
    reported: ExplanationFit,
) -> Confound | None:
    keys = {e.key for e in conf.effects}
    if "psi" not in data.channels or GAIN_KEY in keys or GAIN_KEY not in by_key:
        return None
    g = fit_set(
        baseline,
        [*conf.effects, by_key[GAIN_KEY]],
        data,
        conf.final.theta[:2],
        effect_values(conf.final),
        data.valid,
        fine=True,
    )
    free = _explanation(g, covariance(g, data), data)
    ratio = max(
        (free.std[k] / reported.std[k] if reported.std[k] > 0 else math.inf) for k in ("L1", "L2")
    )
    if math.isfinite(ratio) and ratio <= GAIN_STD_RATIO:
        return None  # the log pins the gain: the link lengths do not depend on it
    lo, hi = free.effect_ci95[GAIN_KEY]["scale"]
    s = free.effect_parameters[GAIN_KEY]["scale"]
    return Confound(
        rule=GAIN_RULE,
        reported=reported,
        alternative=free,
        delta_bic=math.nan,
        why=(
            f"a gain of the joint-angle sensor is taken in by L1 + L2 (psi ~ kappa (L1 + L2) "
            f"at small angles): left free it is {s:.3f} [95 %: {lo:.3f}, {hi:.3f}] and the "
            f"intervals of the link lengths grow {ratio:.1f}x; the reported lengths hold only "
            "for a gain of exactly 1"
        ),
        lengths_differ=True,
        corrections_differ=True,
    )


def find_confounds(
    data: DiscoveryData,
    baseline: ModelSpec,
    conf: Confirmed,
    pool: Sequence[Effect],
) -> list[Confound]:
    """The confounds of the link lengths in a confirmed result (module docstring): each
    alternative and close explanation that implies other link lengths or other joint-angle
    corrections, then the joint-angle gain if the log does not pin it."""
    by_key = {e.key: e for e in pool}
    reported = _explanation(conf.final, conf.cov, data)
    out: list[Confound] = []
    seen: set[tuple[str, ...]] = set()
    for alt, close in [(a, "") for a in conf.alternatives] + list(conf.close):
        if alt.alternative in seen:
            continue
        seen.add(alt.alternative)
        c = _alternative_confound(data, baseline, conf, by_key, reported, alt, close)
        if c is not None:
            out.append(c)
    gain = _gain_confound(data, baseline, conf, by_key, reported)
    if gain is not None:
        out.append(gain)
    return out


@dataclass(frozen=True)
class SpanChoice:
    """One confound the estimate must span: refit with each of ``options`` (the complete
    joint-angle corrections of one explanation) and take the union of the intervals.
    ``lengths``: discovery's own union of the sides' 95 % intervals of L1, L2 (m), for a
    consumer that cannot refit. ``spannable``: False when the options do not cover what the
    log allows (a joint-angle gain whose interval reaches beyond 1 +/- ``MAX_SPAN_GAIN``):
    the estimate is then not determined (``SensorEffectsForFit.undetermined``)."""

    confound: Confound
    options: tuple[SensorCorrections, ...]
    lengths: Mapping[str, tuple[float, float]]
    spannable: bool


@dataclass(frozen=True)
class SensorEffectsForFit:
    """What a fit of the link lengths may take in from a discovery result.

    ``fold``: joint-angle corrections of named effects no confound involves: fit them jointly
    into the recommended estimate (``fold.as_tuple()`` is (psi offset?, psi clock shift s,
    labels), the shape of the tractor-trailer pipeline's ``_sensor_effects``; ``psi_scale``
    divides the recorded joint angle). ``span``: one entry per confound (``SpanChoice``);
    each option already includes ``fold``. ``undetermined``: reasons the link lengths are not
    determined by this log whatever the fit (empty: span and report).
    """

    fold: SensorCorrections
    span: tuple[SpanChoice, ...]
    undetermined: tuple[str, ...]

    @property
    def options(self) -> tuple[SensorCorrections, ...]:
        """Every set of corrections to refit with (``fold`` first), without repeats."""
        out = [self.fold]
        for ch in self.span:
            for o in ch.options:
                if not any(o.same_as(x, shift_tol_s=1e-9) for x in out):
                    out.append(o)
        return tuple(out)

    @property
    def confounds(self) -> tuple[str, ...]:
        """One sentence per confound, for the report."""
        return tuple(ch.confound.report() for ch in self.span)


def _gain_options(
    c: Confound, tolerance: float | None
) -> tuple[tuple[SensorCorrections, ...], bool]:
    """The reported explanation's corrections as they are and with the gain at each end of
    its interval (cut to 1 +/- ``tolerance``); whether that spans what the log allows."""
    base = c.reported.corrections
    lo, hi = c.alternative.effect_ci95[GAIN_KEY]["scale"]
    spannable = math.isfinite(lo) and math.isfinite(hi)
    if tolerance is not None:
        lo, hi = max(lo, 1.0 - tolerance), min(hi, 1.0 + tolerance)
        lo, hi = min(lo, 1.0), max(hi, 1.0)
    else:
        spannable = spannable and lo >= 1.0 - MAX_SPAN_GAIN and hi <= 1.0 + MAX_SPAN_GAIN
    labels = (*base.labels, GAIN_KEY)
    opts = tuple(
        SensorCorrections(base.psi_offset, base.psi_shift_s, float(s), labels)
        for s in (lo, hi)
        if math.isfinite(s) and s > 0
    )
    return (base, *opts), spannable


def sensor_effects_for_fit(
    result: DiscoveryResult, *, psi_gain_tolerance: float | None = None
) -> SensorEffectsForFit:
    """What the recommended estimate of L1, L2 may take in from ``result`` and what it must span.

    ``fold``: the joint-angle offset, clock shift and gain of the named effects that no
    confound involves. For each confound (``result.confounds``) a ``SpanChoice``: refit with
    each option and report the union of the intervals (or "not determined" when they
    disagree beyond it). A joint-angle gain the log does not pin is spanned by refitting at
    the ends of its 95 % interval, given ``psi_gain_tolerance`` (the sensor's gain is known
    to 1 +/- it: the interval is cut to that) or when that interval lies within
    1 +/- ``MAX_SPAN_GAIN``; otherwise the link lengths are not determined by the log
    (``undetermined``). A result without effects or confounds gives an empty ``fold`` and
    nothing to span.
    """
    named = {e.label: dict(e.parameters) for e in result.effects}
    involved: set[str] = set()
    for c in result.confounds:
        a, b = set(c.reported.effects), set(c.alternative.effects)
        involved |= a ^ b
    fold = corrections_of({k: v for k, v in named.items() if k not in involved})
    span: list[SpanChoice] = []
    undetermined: list[str] = []
    for c in result.confounds:
        if c.rule == GAIN_RULE:
            options, ok = _gain_options(c, psi_gain_tolerance)
            if not ok:
                lo, hi = c.alternative.effect_ci95[GAIN_KEY]["scale"]
                undetermined.append(
                    "the joint-angle sensor's gain is not pinned by this log (95 %: "
                    f"{lo:.3f} to {hi:.3f}) and trades off against L1 + L2"
                )
        else:
            options = (c.reported.corrections, c.alternative.corrections)
            ok = True
        span.append(SpanChoice(c, options, c.span(), ok))
    return SensorEffectsForFit(fold, tuple(span), tuple(undetermined))
