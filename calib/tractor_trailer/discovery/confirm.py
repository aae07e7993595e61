"""Confirmation of the effects that forward selection accepted, as a set.

Two passes after the greedy rounds (``selection``):

1. Equivalent explanations (``equivalences``: what the catalogue's effects declare,
   ``Effect.equivalents``). Some effects, or sets of effects, change the recordings in (nearly)
   the same way: an actuator dead time delays the yaw rate and the joint angle against the
   command exactly as the same clock offset on every measured topic would (they differ only
   through speed changes within the delay); at constant speed understeer scales the curvature
   by 1 / (1 + K v^2), which the yaw rate shows as a gain error and the joint angle as slightly
   different link lengths; a first-order steering lag delays slow commands like a dead time of
   its time constant. The declaring effect says which keys are on either side and how one
   side's parameters convert into the other's starting values; this module knows no effect by
   its key. For each such pair whose one side is in the accepted set, the other side is fitted
   in its place (jointly with the link lengths and the other effects, on the training blocks).
   If it is better by more than ``EQUIVALENCE_MARGIN`` BIC units and no worse on the held-out
   blocks, it replaces the accepted side; if the two are within the margin (or their held-out
   RMS differ by less than ``data.RESOLUTION``), the explanation with fewer effects (one
   physical cause rather than two) is reported, on equal counts the lower BIC (a replacement's
   held-out error at most ``TIE_HOLDOUT_SLACK`` times larger), and the other is listed as an
   alternative. An alternative is listed only if its own parameters are significant.
2. Each remaining effect must earn its place in the final model: its 95 % interval (Fisher,
   on the final joint fit over all valid rows; a time shift's includes the time resolution)
   excludes the value at which it does nothing, and removing it (refitting the rest on the
   training blocks) makes the noise-weighted held-out error larger and the held-out RMS of one
   of its channels larger. Effects that fail are dropped one at a time (the weakest evidence
   first) and the rest refitted, until all pass.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from calib.tractor_trailer.discovery.data import RESOLUTION, DiscoveryData
from calib.tractor_trailer.discovery.effects import Effect
from calib.tractor_trailer.discovery.effects.base import Equivalent
from calib.tractor_trailer.discovery.fit import (
    CommandFit,
    bic,
    covariance,
    fit_model,
    holdout_rms,
    param_std,
)
from calib.tractor_trailer.discovery.model import ModelSpec, Vector
from calib.tractor_trailer.discovery.result import AlternativeExplanation
from calib.tractor_trailer.discovery.selection import (
    CommandRules,
    is_material,
    weighted_holdout,
    z_scores,
)

__all__ = [
    "EQUIVALENCE_MARGIN",
    "Confirmed",
    "Evidence",
    "confirm_effects",
    "effect_ci95",
    "effect_values",
    "equivalences",
    "fit_set",
]

FloatArray = NDArray[np.float64]
Values = dict[str, dict[str, float]]

# BIC units within which two explanations count as equivalent (the same threshold as strong
# evidence for an effect in ``CommandRules.max_delta_bic``).
EQUIVALENCE_MARGIN = 10.0
# a tied replacement may have at most this much larger noise-weighted held-out error
TIE_HOLDOUT_SLACK = 1.05


def equivalences(pool: Sequence[Effect], channels: Sequence[str]) -> list[Equivalent]:
    """The equivalences between effects that the effects of ``pool`` declare for a log of
    ``channels`` (``Effect.equivalents``), each rule once: the exact ones first, then the
    approximate ones, each in catalogue order (an exact equivalent names a cause before an
    approximate one is tried in its place)."""
    seen: dict[str, Equivalent] = {}
    for e in pool:
        for eq in e.equivalents(tuple(channels)):
            if not eq.of_parameters and eq.rule not in seen:
                seen[eq.rule] = eq
    return sorted(seen.values(), key=lambda eq: not eq.exact)


@dataclass(frozen=True)
class Evidence:
    """Held-out RMS without and with one effect (the others kept, refitted) and the BIC change
    of adding it to the rest (negative favours the effect)."""

    rms_without: dict[str, float]
    rms_with: dict[str, float]
    delta_bic: float
    ci_excludes_null: bool
    improves_holdout: bool

    @property
    def passes(self) -> bool:
        return self.ci_excludes_null and self.improves_holdout


@dataclass(frozen=True)
class Confirmed:
    """The confirmed effects, their training fit, the final joint fit over all valid rows
    (``final``, ``cov``), the evidence per effect key, alternatives and what was dropped.

    ``close``: equivalent explanations that BIC separated by more than the margin but whose
    held-out errors differ immaterially (neither is better than the other by ``min_gain`` on
    any output, ``selection.is_material``), and a dead time against clock offsets that agree
    with each other (within ``COMMON_SHIFT_Z`` combined standard errors: one shift of every
    measured topic, the dead time's signature): not listed as alternatives (BIC decides the
    name), but candidates for confounds of the link lengths (``confounds``); each with why
    the log does not tell them apart."""

    effects: list[Effect]
    train: CommandFit
    final: CommandFit
    cov: FloatArray
    evidence: dict[str, Evidence]
    alternatives: list[AlternativeExplanation] = field(default_factory=list)
    dropped: list[dict[str, object]] = field(default_factory=list)
    swaps: list[dict[str, object]] = field(default_factory=list)
    close: list[tuple[AlternativeExplanation, str]] = field(default_factory=list)


def effect_values(fit: CommandFit) -> Values:
    """Fitted parameter values per effect key."""
    _, _, per = fit.spec.split(fit.theta)
    return {e.key: dict(p) for e, p in zip(fit.spec.effects, per, strict=True)}


def _theta(spec: ModelSpec, L: Vector, values: Mapping[str, Mapping[str, float]]) -> list[float]:
    out = [float(L[0]), float(L[1])]
    for e in spec.effects:
        for p in e.params:
            v = values.get(e.key, {}).get(p.name, p.init)
            out.append(float(min(max(v, p.lower), p.upper)) if math.isfinite(v) else p.init)
    return out


def fit_set(
    baseline: ModelSpec,
    effects: Sequence[Effect],
    data: DiscoveryData,
    L: Vector,
    values: Mapping[str, Mapping[str, float]],
    mask: NDArray[np.bool_],
    *,
    fine: bool = False,
) -> CommandFit:
    """``effects`` added to ``baseline``, fitted with L1, L2 on ``mask`` from the lengths ``L``
    and the effects' ``values`` (their initial values where missing)."""
    spec = ModelSpec(baseline.baseline, (*baseline.effects, *effects))
    return fit_model(spec, data, _theta(spec, L, values), mask, fine=fine, tol=1e-6)


def effect_ci95(
    fit: CommandFit, data: DiscoveryData, cov: FloatArray | None = None
) -> dict[str, dict[str, tuple[float, float]]]:
    """95 % intervals of the effects' parameters of ``fit`` (``cov``: its covariance, computed
    if not given)."""
    cov = covariance(fit, data) if cov is None else cov
    out: dict[str, dict[str, tuple[float, float]]] = {}
    vals = effect_values(fit)
    for e in fit.spec.effects:
        out[e.key] = {}
        for p in e.params:
            sd = param_std(fit, cov, f"{e.key}.{p.name}", p.time_shift, data.time_resolution_s)
            v = vals[e.key][p.name]
            out[e.key][p.name] = (v - 1.96 * sd, v + 1.96 * sd)
    return out


def _equivalences(
    data: DiscoveryData,
    baseline: ModelSpec,
    effects: list[Effect],
    train: CommandFit,
    pool: Sequence[Effect],
    factors: Mapping[str, float],
    rules: CommandRules,
) -> tuple[
    list[Effect],
    CommandFit,
    list[AlternativeExplanation],
    list[dict[str, object]],
    list[tuple[AlternativeExplanation, str]],
]:
    by_key = {e.key: e for e in pool}
    mask = data.train_mask()
    alternatives: list[AlternativeExplanation] = []
    close: list[tuple[AlternativeExplanation, str]] = []
    swaps: list[dict[str, object]] = []
    for eq in equivalences(pool, data.channels):
        sides = (eq.mine, eq.theirs)
        convert = (eq.to_theirs, eq.to_mine)
        keys = [e.key for e in effects]
        if all(side and set(side) <= set(keys) for side in sides):
            # both explanations at once: one of them is redundant unless the log clearly
            # needs both (BIC worse by more than the margin without either)
            vals = effect_values(train)
            best_fit, best_side, best_d = None, None, math.inf
            for side in sorted(sides, key=len, reverse=True):
                kept = [e for e in effects if e.key not in side]
                g = fit_set(baseline, kept, data, train.theta[:2], vals, mask)
                d = bic(g, factors) - bic(train, factors)
                if d < best_d:
                    best_fit, best_side, best_d = g, side, d
            if best_fit is not None and best_side is not None and best_d <= EQUIVALENCE_MARGIN:
                swaps.append(
                    {
                        "rule": eq.rule,
                        "from": list(keys),
                        "dropped": list(best_side),
                        "why": f"redundant with its equivalent (BIC {best_d:+.1f} without it)",
                    }
                )
                effects = [e for e in effects if e.key not in best_side]
                train = best_fit
            continue
        for i in (0, 1):
            have, want = sides[i], sides[1 - i]
            keys = [e.key for e in effects]
            if not have or not want or not set(have) <= set(keys) or set(want) & set(keys):
                continue
            if not all(k in by_key for k in want):
                continue
            vals = effect_values(train)
            start = {k: v for k, v in vals.items() if k not in have}
            to_want = convert[i]
            if to_want is not None:  # else from their initial values
                start.update(to_want(vals, data))
            kept = [e for e in effects if e.key not in have]
            new = kept + [by_key[k] for k in want]
            g = fit_set(baseline, new, data, train.theta[:2], start, mask)
            z = {k: z_scores(g, by_key[k], data) for k in want}
            if not all(v >= rules.min_z for zz in z.values() for v in zz.values()):
                continue
            d_bic = bic(g, factors) - bic(train, factors)
            fewer = len(want) < len(have)
            same = len(want) == len(have)
            # held-out error of the replacement: not worse (BIC-better), or within 5 % (a tie)
            test = data.test_mask()
            h_new = holdout_rms(g.spec, g.theta, data, test)
            h_cur = holdout_rms(train.spec, train.theta, data, test)
            w_new, w_cur = weighted_holdout(h_new, data), weighted_holdout(h_cur, data)
            # they differ on the held-out blocks by less than the resolution (the finest misfit
            # worth explaining, as in ``is_material``): this log cannot tell them apart (on a
            # noise-free log BIC differences of numerical error are large)
            below = all(
                math.sqrt(abs(h_new[c] ** 2 - h_cur[c] ** 2)) < RESOLUTION[c] for c in h_cur
            )
            tie = abs(d_bic) <= EQUIVALENCE_MARGIN or below
            # neither is materially better on the held-out blocks (selection's own test of a
            # gain): BIC may name one, but the log does not tell their consequences apart
            close_why = ""
            if not is_material(
                data.channels, h_new, h_cur, data, rules.min_gain
            ) and not is_material(data.channels, h_cur, h_new, data, rules.min_gain):
                close_why = (
                    f"neither fits the held-out data better by {100 * rules.min_gain:.0f} % "
                    "on any output"
                )
            elif eq.agree:
                # their parameters agreeing is what the declaring side looks like (one offset
                # on every topic's clock: a dead time): only speed changes within it (and the
                # model's accuracy) tell them apart
                theirs = (g, want) if i == 0 else (train, have)
                if _agree(theirs[0], [by_key[k] for k in theirs[1]], eq.agree, data):
                    close_why = eq.agree_note
            better = d_bic < -EQUIVALENCE_MARGIN and w_new <= w_cur and not below
            switch = better or (
                tie and (fewer or (same and d_bic < 0)) and w_new <= TIE_HOLDOUT_SLACK * w_cur
            )
            if switch:
                why = (
                    f"BIC lower by {-d_bic:.1f}"
                    if d_bic < -EQUIVALENCE_MARGIN
                    else "one physical cause rather than two"
                    if fewer
                    else f"BIC lower by {-d_bic:.1f}"
                )
                swaps.append({"rule": eq.rule, "from": list(have), "to": list(want), "why": why})
                if tie:  # the replaced side stays as the alternative
                    alternatives.append(_alternative(eq, want, have, train, data, -d_bic, why))
                elif close_why:
                    close.append(
                        (_alternative(eq, want, have, train, data, -d_bic, why), close_why)
                    )
                effects, train = new, g
            elif tie:
                why = (
                    "one physical cause rather than two"
                    if len(have) < len(want)
                    else f"BIC lower by {d_bic:.1f}"
                )
                alternatives.append(_alternative(eq, have, want, g, data, d_bic, why))
            elif close_why:
                close.append(
                    (_alternative(eq, have, want, g, data, d_bic, f"BIC {-d_bic:+.1f}"), close_why)
                )
            break  # one side was in the set and the other tried: done with this pair
    return effects, train, alternatives, swaps, close


COMMON_SHIFT_Z = 2.0


def _agree(fit: CommandFit, effects: Sequence[Effect], name: str, data: DiscoveryData) -> bool:
    """The parameter ``name`` of ``effects`` (two or more) in ``fit`` agrees within
    ``COMMON_SHIFT_Z`` combined standard errors (e.g. clock offsets: one shift of every measured
    topic)."""
    if len(effects) < 2:
        return False
    cov = covariance(fit, data)
    vals = effect_values(fit)
    res = data.time_resolution_s
    pts = []
    for e in effects:
        p = next(p for p in e.params if p.name == name)
        sd = param_std(fit, cov, f"{e.key}.{name}", p.time_shift, res)
        pts.append((vals[e.key][name], sd))
    for a in range(len(pts)):
        for b in range(a + 1, len(pts)):
            s = math.hypot(pts[a][1], pts[b][1])
            if not (math.isfinite(s) and abs(pts[a][0] - pts[b][0]) <= COMMON_SHIFT_Z * s):
                return False
    return True


def _alternative(
    eq: Equivalent,
    reported: Sequence[str],
    alt: Sequence[str],
    alt_fit: CommandFit,
    data: DiscoveryData,
    d_bic_alt: float,
    why: str,
) -> AlternativeExplanation:
    """``d_bic_alt``: BIC(alternative) - BIC(reported)."""
    vals = effect_values(alt_fit)
    ci = effect_ci95(alt_fit, data)
    return AlternativeExplanation(
        reported=tuple(reported),
        alternative=tuple(alt),
        parameters={k: vals[k] for k in alt},
        ci95={k: ci[k] for k in alt},
        delta_bic=float(d_bic_alt),
        rule=eq.rule,
        note=f"{eq.note}; reported: {' + '.join(reported)} ({why})",
    )


def _evidence(
    data: DiscoveryData,
    baseline: ModelSpec,
    effects: list[Effect],
    train: CommandFit,
    final: CommandFit,
    cov: FloatArray,
    factors: Mapping[str, float],
) -> tuple[dict[str, Evidence], dict[str, CommandFit]]:
    mask, test = data.train_mask(), data.test_mask()
    hold = holdout_rms(train.spec, train.theta, data, test)
    vals = effect_values(train)
    fvals = effect_values(final)
    out: dict[str, Evidence] = {}
    without: dict[str, CommandFit] = {}
    for e in effects:
        rest = [x for x in effects if x is not e]
        g = fit_set(baseline, rest, data, train.theta[:2], vals, mask)
        hold_g = holdout_rms(g.spec, g.theta, data, test)
        ci_ok = True
        for p in e.params:
            sd = param_std(final, cov, f"{e.key}.{p.name}", p.time_shift, data.time_resolution_s)
            v = fvals[e.key][p.name]
            if not (math.isfinite(sd) and abs(v - p.null) > 1.96 * sd):
                ci_ok = False
        improves = weighted_holdout(hold, data) < weighted_holdout(hold_g, data) and any(
            hold[c] < hold_g[c] for c in e.channels if c in hold
        )
        out[e.key] = Evidence(hold_g, hold, bic(train, factors) - bic(g, factors), ci_ok, improves)
        without[e.key] = g
    return out, without


def _prune(
    data: DiscoveryData,
    baseline: ModelSpec,
    effects: list[Effect],
    train: CommandFit,
    factors: Mapping[str, float],
    dropped: list[dict[str, object]],
) -> tuple[list[Effect], CommandFit, CommandFit, FloatArray, dict[str, Evidence]]:
    """Drop failing effects one at a time (weakest first) until every one passes; returns the
    effects, their training fit, the final fit over all valid rows, its covariance and the
    evidence per effect."""
    while True:
        final = fit_model(train.spec, data, train.theta, data.valid, fine=True)
        cov = covariance(final, data)
        evidence, without = _evidence(data, baseline, effects, train, final, cov, factors)
        failing = [e for e in effects if not evidence[e.key].passes]
        if not failing:
            return effects, train, final, cov, evidence
        worst = max(failing, key=lambda e: evidence[e.key].delta_bic)
        ev = evidence[worst.key]
        dropped.append(
            {
                "effect": worst.key,
                "ci95_excludes_null": ev.ci_excludes_null,
                "improves_holdout": ev.improves_holdout,
                "delta_bic": ev.delta_bic,
            }
        )
        effects = [e for e in effects if e is not worst]
        train = without[worst.key]


def _single_swaps(
    data: DiscoveryData,
    baseline: ModelSpec,
    effects: list[Effect],
    train: CommandFit,
    pool: Sequence[Effect],
    factors: Mapping[str, float],
    rules: CommandRules,
    candidates: Mapping[str, Sequence[str]],
    known: set[tuple[tuple[str, ...], tuple[str, ...]]],
) -> list[AlternativeExplanation]:
    """Each reported effect replaced in the final set by the candidates that came close to it
    in its selection round; listed if within ``EQUIVALENCE_MARGIN`` BIC with significant
    parameters."""
    by_key = {e.key: e for e in pool}
    keys = {e.key for e in effects}
    vals = effect_values(train)
    out = []
    for e in effects:
        for k in candidates.get(e.key, ()):
            if k in keys or k not in by_key or ((e.key,), (k,)) in known:
                continue
            new = [by_key[k] if x is e else x for x in effects]
            start = {x: v for x, v in vals.items() if x != e.key}
            g = fit_set(baseline, new, data, train.theta[:2], start, data.train_mask())
            if not all(z >= rules.min_z for z in z_scores(g, by_key[k], data).values()):
                continue
            d_bic = bic(g, factors) - bic(train, factors)
            if d_bic <= EQUIVALENCE_MARGIN:
                gv, ci = effect_values(g), effect_ci95(g, data)
                out.append(
                    AlternativeExplanation(
                        reported=(e.key,),
                        alternative=(k,),
                        parameters={k: gv[k]},
                        ci95={k: ci[k]},
                        delta_bic=float(d_bic),
                        rule="same_round",
                        note=(
                            "another candidate explains the misfit nearly as well in the final "
                            f"model; reported: {e.key} (it was preferred when selected)"
                        ),
                    )
                )
    return out


def confirm_effects(
    data: DiscoveryData,
    baseline: ModelSpec,
    effects: list[Effect],
    train: CommandFit,
    pool: Sequence[Effect],
    factors: Mapping[str, float],
    rules: CommandRules,
    candidates: Mapping[str, Sequence[str]] | None = None,
) -> Confirmed:
    """The per-effect checks, the equivalences, the checks again if an equivalent explanation
    replaced one, and the alternatives (module docstring).

    ``effects``/``train``: the accepted effects and their fit on the training blocks; ``pool``
    the catalogue (for the equivalent effects); ``factors`` the effective-sample factors of
    the selection's BIC; ``candidates``: per accepted effect key, the other candidates that
    came close to it in its selection round (tried in its place at the end).
    """
    dropped: list[dict[str, object]] = []
    effects, train, final, cov, evidence = _prune(
        data, baseline, list(effects), train, factors, dropped
    )
    effects2, train2, alternatives, swaps, close = _equivalences(
        data, baseline, effects, train, pool, factors, rules
    )
    if swaps:
        effects, train, final, cov, evidence = _prune(
            data, baseline, effects2, train2, factors, dropped
        )
    keys = {e.key for e in effects}
    alternatives = [a for a in alternatives if set(a.reported) <= keys]
    close = [(a, why) for a, why in close if set(a.reported) <= keys]
    known = {(a.reported, a.alternative) for a in alternatives}
    alternatives += _single_swaps(
        data, baseline, effects, train, pool, factors, rules, candidates or {}, known
    )
    return Confirmed(effects, train, final, cov, evidence, alternatives, dropped, swaps, close)
