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
corrections differ. It also fits the reported model with each effect that declares an
equivalence with the link lengths (``Effect.equivalents``: the joint-angle gain) left free: if
that widens the interval of L1 or L2 by more than ``UNPINNED_STD_RATIO`` (the log does not pin
the effect), the effect is a confound of the link lengths (unless discovery named it).

What an explanation says about the joint-angle sensor (``corrections_of``) is what its effects
declare (``Effect.joint_angle_correction``); this module knows no effect by its key.

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
from calib.tractor_trailer.discovery.effects import Effect, catalogue
from calib.tractor_trailer.discovery.effects.base import Equivalent
from calib.tractor_trailer.discovery.fit import CommandFit, covariance
from calib.tractor_trailer.discovery.model import ModelSpec
from calib.tractor_trailer.discovery.result import (
    AlternativeExplanation,
    DiscoveryResult,
    ExplanationFit,
    LengthConfound,
    SensorCorrections,
)

__all__ = [
    "UNPINNED_STD_RATIO",
    "SensorEffectsForFit",
    "SpanChoice",
    "corrections_of",
    "find_confounds",
    "sensor_effects_for_fit",
]

# a free effect (declared equivalent to the link lengths) that widens the standard error of L1
# or L2 by more than this factor is not pinned by the log: it is a confound of the link lengths
UNPINNED_STD_RATIO = 1.5
CHANNELS = ("omega", "psi")  # every output an effect may act on


def _catalogue() -> dict[str, Effect]:
    """Every effect of the catalogue (built-in and registered, against either baseline) by
    key."""
    return {e.key: e for b in ("steady", "transient") for e in catalogue(b, CHANNELS)}


def corrections_of(
    values: Mapping[str, Mapping[str, float]], effects: Mapping[str, Effect] | None = None
) -> SensorCorrections:
    """The joint-angle corrections of a set of effects (key -> parameter values): what each
    declares (``Effect.joint_angle_correction``), combined in the order of ``values``.
    ``effects``: the effects by key (default: the catalogue's); a key not among them says
    nothing about the joint angle."""
    by_key = _catalogue() if effects is None else effects
    out = SensorCorrections()
    for k, p in values.items():
        e = by_key.get(k)
        c = e.joint_angle_correction(p) if e is not None else None
        if c is not None:
            out = out.combined(c)
    return out


def _parameter_rules(
    effects: Sequence[Effect], channels: tuple[str, ...]
) -> list[tuple[Effect, Equivalent]]:
    """The equivalences with robot parameters that ``effects`` declare (each rule once)."""
    out: list[tuple[Effect, Equivalent]] = []
    for e in effects:
        for eq in e.equivalents(channels):
            if eq.of_parameters and all(eq.rule != q.rule for _, q in out):
                out.append((e, eq))
    return out


def _explanation(fit: CommandFit, cov: np.ndarray, data: DiscoveryData) -> ExplanationFit:
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
        corrections=corrections_of(ev, {e.key: e for e in fit.spec.effects}),
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
) -> LengthConfound | None:
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
    return LengthConfound(
        rule=alt.rule,
        reported=reported,
        alternative=other,
        delta_bic=alt.delta_bic,
        why=f"{why}; {' and '.join(what)}",
        lengths_differ=lengths,
        corrections_differ=corr,
    )


def _unpinned_confound(
    data: DiscoveryData,
    baseline: ModelSpec,
    conf: Confirmed,
    effect: Effect,
    eq: Equivalent,
    reported: ExplanationFit,
) -> LengthConfound | None:
    """``effect``, declared equivalent to robot parameters by ``eq``, as a confound of them if
    left free beside the reported effects it widens their intervals by more than
    ``UNPINNED_STD_RATIO`` (the log does not pin it)."""
    if effect.key in {e.key for e in conf.effects}:
        return None  # named: the lengths were fitted with it
    g = fit_set(
        baseline,
        [*conf.effects, effect],
        data,
        conf.final.theta[:2],
        effect_values(conf.final),
        data.valid,
        fine=True,
    )
    free = _explanation(g, covariance(g, data), data)
    ratio = max(
        (free.std[k] / reported.std[k] if reported.std[k] > 0 else math.inf) for k in eq.parameters
    )
    if math.isfinite(ratio) and ratio <= UNPINNED_STD_RATIO:
        return None  # the log pins the effect: the link lengths do not depend on it
    left = ", ".join(
        f"{v:.3f} [95 %: {free.effect_ci95[effect.key][n][0]:.3f}, "
        f"{free.effect_ci95[effect.key][n][1]:.3f}]"
        for n, v in free.effect_parameters[effect.key].items()
    )
    return LengthConfound(
        rule=eq.rule,
        reported=reported,
        alternative=free,
        delta_bic=math.nan,
        why=(
            f"{eq.note}: left free it is {left} and the intervals of the link lengths grow "
            f"{ratio:.1f}x; the reported lengths hold only for {eq.assumes}"
        ),
        lengths_differ=True,
        corrections_differ=True,
    )


def find_confounds(
    data: DiscoveryData,
    baseline: ModelSpec,
    conf: Confirmed,
    pool: Sequence[Effect],
) -> list[LengthConfound]:
    """The confounds of the link lengths in a confirmed result (module docstring): each
    alternative and close explanation that implies other link lengths or other joint-angle
    corrections, then each effect of ``pool`` declared equivalent to the link lengths (the
    joint-angle gain) if the log does not pin it."""
    by_key = {e.key: e for e in pool}
    reported = _explanation(conf.final, conf.cov, data)
    out: list[LengthConfound] = []
    seen: set[tuple[str, ...]] = set()
    for alt, close in [(a, "") for a in conf.alternatives] + list(conf.close):
        if alt.alternative in seen:
            continue
        seen.add(alt.alternative)
        c = _alternative_confound(data, baseline, conf, by_key, reported, alt, close)
        if c is not None:
            out.append(c)
    for effect, eq in _parameter_rules(pool, data.channels):
        c = _unpinned_confound(data, baseline, conf, effect, eq, reported)
        if c is not None:
            out.append(c)
    return out


@dataclass(frozen=True)
class SpanChoice:
    """One confound the estimate must span: refit with each of ``options`` (the complete
    joint-angle corrections of one explanation) and take the union of the intervals.
    ``lengths``: discovery's own union of the sides' 95 % intervals of L1, L2 (m), for a
    consumer that cannot refit. ``spannable``: False when the options do not cover what the
    log allows (an effect whose interval reaches beyond what its equivalence declares
    spannable, ``Equivalent.span_within``: a joint-angle gain beyond 1 +/- 0.1): the estimate
    is then not determined (``SensorEffectsForFit.undetermined``). ``free_effect``: for a
    confound of one effect with the link lengths (the joint-angle gain), that effect's key
    (the options put its parameter at the ends of its interval); empty for two explanations."""

    confound: LengthConfound
    options: tuple[SensorCorrections, ...]
    lengths: Mapping[str, tuple[float, float]]
    spannable: bool
    free_effect: str = ""


@dataclass(frozen=True)
class SensorEffectsForFit:
    """What a fit of the link lengths may take in from a discovery result.

    ``fold``: joint-angle corrections of named effects no confound involves: fit them jointly
    into the recommended estimate (``fold.as_tuple()`` is (psi offset?, psi clock shift s,
    labels), the shape of the ``calib.tractor_trailer.judgement.folded_effects``; ``psi_scale``
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


def _free_options(
    c: LengthConfound, effect: Effect, eq: Equivalent, tolerance: float | None
) -> tuple[tuple[SensorCorrections, ...], bool, tuple[float, float]]:
    """The reported explanation's corrections as they are and with ``effect``'s parameter at
    each end of its interval (cut to its null +/- ``tolerance``); whether that spans what the
    log allows (within null +/- ``eq.span_within``); the interval."""
    base = c.reported.corrections
    p = effect.params[0]
    ci = lo, hi = c.alternative.effect_ci95[effect.key][p.name]
    spannable = math.isfinite(lo) and math.isfinite(hi)
    if tolerance is not None:
        lo, hi = max(lo, p.null - tolerance), min(hi, p.null + tolerance)
        lo, hi = min(lo, p.null), max(hi, p.null)
    else:
        spannable = spannable and lo >= p.null - eq.span_within and hi <= p.null + eq.span_within
    opts = []
    for s in (lo, hi):
        corr = effect.joint_angle_correction({p.name: float(s)}) if math.isfinite(s) else None
        if corr is not None:
            opts.append(base.combined(corr))
    return (base, *opts), spannable, ci


def sensor_effects_for_fit(
    result: DiscoveryResult, *, psi_gain_tolerance: float | None = None
) -> SensorEffectsForFit:
    """What the recommended estimate of L1, L2 may take in from ``result`` and what it must span.

    ``fold``: the joint-angle offset, clock shift and gain of the named effects that no
    confound involves. For each confound (``result.confounds``) a ``SpanChoice``: refit with
    each option and report the union of the intervals (or "not determined" when they
    disagree beyond it). An effect declared equivalent to the link lengths that the log does
    not pin (the joint-angle gain) is spanned by refitting at the ends of its 95 % interval,
    given ``psi_gain_tolerance`` (its parameter is known to its null +/- it, the sensor's gain
    to 1 +/- it: the interval is cut to that) or when that interval lies within what its
    equivalence declares (``Equivalent.span_within``: 1 +/- 0.1 for the gain); otherwise the
    link lengths are not determined by the log (``undetermined``). A result without effects or
    confounds gives an empty ``fold`` and nothing to span.
    """
    named = {e.label: dict(e.parameters) for e in result.effects}
    involved: set[str] = set()
    for c in result.confounds:
        a, b = set(c.reported.effects), set(c.alternative.effects)
        involved |= a ^ b
    effects = _catalogue()
    fold = corrections_of({k: v for k, v in named.items() if k not in involved}, effects)
    free = {eq.rule: (e, eq) for e, eq in _parameter_rules(list(effects.values()), CHANNELS)}
    span: list[SpanChoice] = []
    undetermined: list[str] = []
    for c in result.confounds:
        if c.rule in free:
            effect, eq = free[c.rule]
            options, ok, (lo, hi) = _free_options(c, effect, eq, psi_gain_tolerance)
            if not ok:
                undetermined.append(
                    f"{eq.what} is not pinned by this log (95 %: {lo:.3f} to {hi:.3f}) and "
                    f"trades off against {' + '.join(eq.parameters)}"
                )
            span.append(SpanChoice(c, options, c.span(), ok, effect.key))
        else:
            options = (c.reported.corrections, c.alternative.corrections)
            span.append(SpanChoice(c, options, c.span(), True))
    return SensorEffectsForFit(fold, tuple(span), tuple(undetermined))
