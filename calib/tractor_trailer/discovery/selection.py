"""Greedy forward selection of catalogue effects on held-out data and BIC.

Each round fits every remaining candidate added to the current model (training blocks, link
lengths refitted jointly), measures the RMS on the held-out blocks and the BIC change, and
accepts, among the candidates that pass all the rules below, the one with the lowest
noise-weighted held-out error (every catalogue effect has one parameter):

* material: the held-out RMS of an output the effect acts on falls by at least
  ``min_gain`` (10 %) and the noise-weighted held-out error of all outputs does not grow;
* strong evidence: delta BIC <= ``max_delta_bic`` (-10), with effective sample sizes taken
  from the residual autocorrelation of a reference model that holds every candidate;
* significant: every parameter of the effect lies >= ``min_z`` (3) standard errors from the
  value at which the effect does nothing;
* interior: no effect parameter of the augmented model sits on a bound of its fit (a
  bounded optimum is no estimate; it means the effects at hand are confounded);
* constant: refitted separately on the slow and the fast half of the samples, and on the
  gentle and the sharp half (|kappa_cmd| below/above its median), its parameters agree: they
  differ by no more than ``max_split_z`` (3) combined standard errors or by no more than
  ``max_split_rel`` (25 %) of their distance from the null value. A physical effect has one
  value; a catalogue effect that only mimics something else drifts with the conditions.

When no candidate passes a round only because the strongest ones drift, pairs are tried
(``_pair_step``): an effect can look inconstant while another it interacts with is missing.
A pair is accepted under the same rules (BIC <= 2 x ``max_delta_bic``, both effects
significant, interior and constant) and recorded as two consecutive rounds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from calib.errors import SolverError
from calib.tractor_trailer.discovery.data import RESOLUTION, DiscoveryData, block_mean
from calib.tractor_trailer.discovery.effects import Effect
from calib.tractor_trailer.discovery.fit import (
    ModelFit,
    bic,
    covariance,
    fit_model,
    holdout_rms,
    neff_factors,
    param_std,
)
from calib.tractor_trailer.discovery.model import BASE_PARAMS, ModelSpec, Vector

__all__ = [
    "SelectionRules",
    "SelectionStep",
    "Trial",
    "accepted_effects",
    "is_material",
    "select_effects",
    "weighted_holdout",
    "z_scores",
]


PAIR_SEEDS = 2


@dataclass(frozen=True)
class SelectionRules:
    """Thresholds of the acceptance rules (see the module docstring)."""

    min_gain: float = 0.10
    max_delta_bic: float = -10.0
    min_z: float = 3.0
    max_split_z: float = 3.0
    max_split_rel: float = 0.25
    max_effects: int = 4


@dataclass(frozen=True)
class Trial:
    """One candidate tried in one round."""

    effect: Effect
    fit: ModelFit
    holdout: dict[str, float]
    delta_bic: float
    z: dict[str, float]
    material: bool
    accepted: bool = False
    split: dict[str, list[float]] | None = None
    stable: bool | None = None

    def to_dict(self) -> dict[str, object]:
        return {
            "effect": self.effect.key,
            "holdout_rms": dict(self.holdout),
            "delta_bic": self.delta_bic,
            "z": dict(self.z),
            "material": self.material,
            "accepted": self.accepted,
            "split": self.split,
            "stable": self.stable,
        }


@dataclass(frozen=True)
class SelectionStep:
    """One round: the model before it, its held-out RMS, the trials, the accepted effect and
    the candidates whose fit failed (``errors``, key -> reason; left out of the round)."""

    before: ModelFit
    holdout_before: dict[str, float]
    trials: list[Trial] = field(default_factory=list)
    accepted: Trial | None = None
    errors: dict[str, str] = field(default_factory=dict)


def z_scores(fit: ModelFit, effect: Effect, data: DiscoveryData) -> dict[str, float]:
    """Distance of the effect's parameters from their null values, in the standard errors that
    are reported (a time shift's include the time resolution; ``fit.param_std``)."""
    cov = covariance(fit, data)
    dt = data.time_resolution_s
    out = {}
    for p in effect.params:
        name = f"{effect.key}.{p.name}"
        sd = param_std(fit, cov, name, p.time_shift, dt)
        val = float(fit.theta[fit.names.index(name)])
        out[p.name] = abs(val - p.null) / sd if sd > 0 else 0.0
    return out


MIN_SPLIT_ROWS = 40


def _split_masks(data: DiscoveryData) -> list[tuple[NDArray[np.bool_], NDArray[np.bool_]]]:
    """(low, high) halves of the valid rows by speed and by |kappa_cmd|; a split whose halves
    are not both at least ``MIN_SPLIT_ROWS`` long (constant speed, say) is left out."""
    out = []
    for x in (np.abs(block_mean(data.v, data.m)), np.abs(block_mean(data.kappa_cmd, data.m))):
        med = float(np.median(x[data.valid]))
        lo, hi = data.valid & (x <= med), data.valid & (x > med)
        if min(int(lo.sum()), int(hi.sum())) >= MIN_SPLIT_ROWS:
            out.append((lo, hi))
    return out


def _stability(
    trial: Trial, data: DiscoveryData, rules: SelectionRules
) -> tuple[bool, dict[str, list[float]]]:
    """Refit the trial's model on each half of each split; True if the effect is constant."""
    e, f = trial.effect, trial.fit
    names = f.names
    idx = [names.index(f"{e.key}.{p.name}") for p in e.params]
    split: dict[str, list[float]] = {p.name: [] for p in e.params}
    stable = True
    for lo, hi in _split_masks(data):
        vals, sds = [], []
        for mk in (lo, hi):
            g = fit_model(f.spec, data, f.theta, mk, tol=1e-6)
            # the lag-1 (Fisher) errors: a drift between the halves must not hide in the
            # wider autocorrelation-robust ones
            cov = covariance(g, data, robust=False)
            vals.append([float(g.theta[i]) for i in idx])
            sds.append([math.sqrt(max(float(cov[i, i]), 0.0)) for i in idx])
        for j, p in enumerate(e.params):
            a, b = vals[0][j], vals[1][j]
            split[p.name] += [a, b]
            res2 = (data.time_resolution_s**2 / 6.0) if p.time_shift else 0.0
            sd = math.sqrt(sds[0][j] ** 2 + sds[1][j] ** 2 + res2)
            scale = max(abs(a - p.null), abs(b - p.null))
            if abs(a - b) > rules.max_split_z * sd and abs(a - b) > rules.max_split_rel * scale:
                stable = False
    return stable, split


def _interior(fit: ModelFit, rel: float = 1e-3) -> bool:
    """True if no effect parameter is within ``rel`` of its range from a bound."""
    specs = fit.spec.param_specs[len(BASE_PARAMS) :]
    vals = fit.theta[len(BASE_PARAMS) :]
    return all(
        p.lower + rel * (p.upper - p.lower) < v < p.upper - rel * (p.upper - p.lower)
        for p, v in zip(specs, vals, strict=True)
    )


def weighted_holdout(hold: dict[str, float], data: DiscoveryData) -> float:
    """Held-out error of all outputs, each in units of its noise level on the fitting grid."""
    return sum((r / data.sigma_d[c]) ** 2 for c, r in hold.items())


def is_material(
    channels: Sequence[str],
    hold: dict[str, float],
    hold_before: dict[str, float],
    data: DiscoveryData,
    min_gain: float,
) -> bool:
    """True if the held-out RMS of one of ``channels`` falls by at least ``min_gain`` (relative)
    and by at least the resolution floor (absolute, in quadrature), and the noise-weighted
    held-out error of all outputs does not grow."""
    for c in channels:
        if c not in hold:
            continue
        before, after = hold_before[c], hold[c]
        explained = math.sqrt(max(before**2 - after**2, 0.0))
        if after <= (1.0 - min_gain) * before and explained >= RESOLUTION[c]:
            return weighted_holdout(hold, data) <= weighted_holdout(hold_before, data)
    return False


def select_effects(
    data: DiscoveryData,
    baseline: ModelSpec,
    theta0: Vector,
    candidates: Sequence[Effect],
    rules: SelectionRules | None = None,
) -> tuple[list[SelectionStep], dict[str, float]]:
    """Greedy forward selection; returns the rounds and the effective-sample factors used."""
    rules = rules or SelectionRules()
    train, test = data.train_mask(), data.test_mask()
    ref_spec = ModelSpec(baseline.baseline, (*baseline.effects, *candidates))
    ref_theta0 = list(theta0) + [p.init for e in candidates for p in e.params]
    ref = fit_model(ref_spec, data, ref_theta0, train, tol=1e-4, max_nfev=20 * len(ref_theta0))
    factors = neff_factors(ref)
    current = fit_model(baseline, data, theta0, train)
    hold_cur = holdout_rms(baseline, current.theta, data, test)
    remaining = list(candidates)
    steps: list[SelectionStep] = []
    while remaining and len(steps) < rules.max_effects:
        trials = []
        bic_cur = bic(current, factors)
        errors: dict[str, str] = {}
        for e in remaining:
            spec = current.spec.with_effect(e)
            th0 = list(current.theta) + [p.init for p in e.params]
            try:
                f = fit_model(spec, data, th0, train, tol=1e-6)
                hold = holdout_rms(spec, f.theta, data, test)
                z = z_scores(f, e, data)
                d_bic = bic(f, factors) - bic_cur
            except (ArithmeticError, ValueError, np.linalg.LinAlgError, SolverError) as err:
                errors[e.key] = f"{type(err).__name__}: {err}"  # this candidate only
                continue
            if not all(math.isfinite(x) for x in (d_bic, *hold.values())):
                errors[e.key] = "non-finite fit"
                continue
            material = is_material(e.channels, hold, hold_cur, data, rules.min_gain)
            trials.append(Trial(e, f, hold, d_bic, z, material))
        passing = [
            t
            for t in trials
            if t.material
            and t.delta_bic <= rules.max_delta_bic
            and all(z >= rules.min_z for z in t.z.values())
            and _interior(t.fit)
        ]
        best = None
        # every candidate has one parameter: the held-out error ranks them (BIC on the
        # training blocks can favour an effect that also bends the link lengths)
        for t in sorted(passing, key=lambda t: (weighted_holdout(t.holdout, data), t.delta_bic)):
            stable, split = _stability(t, data, rules)
            checked = replace(t, split=split, stable=stable, accepted=stable)
            trials[trials.index(t)] = checked
            if stable:
                best = checked
                break
        if best is None and len(steps) + 2 <= rules.max_effects:
            pair = _pair_step(data, current, hold_cur, bic_cur, trials, remaining, factors, rules)
            if pair is not None:
                first, second, pair_trials = pair
                steps.append(SelectionStep(current, hold_cur, trials, first, errors))
                steps.append(SelectionStep(current, hold_cur, pair_trials, second))
                current, hold_cur = second.fit, second.holdout
                remaining = [e for e in remaining if e not in (first.effect, second.effect)]
                continue
        steps.append(SelectionStep(current, hold_cur, trials, best, errors))
        if best is None:
            break
        current, hold_cur = best.fit, best.holdout
        remaining = [e for e in remaining if e is not best.effect]
    return steps, factors


def _pair_step(
    data: DiscoveryData,
    current: ModelFit,
    hold_cur: dict[str, float],
    bic_cur: float,
    trials: Sequence[Trial],
    remaining: Sequence[Effect],
    factors: dict[str, float],
    rules: SelectionRules,
) -> tuple[Trial, Trial, list[Trial]] | None:
    """Two effects at once, when no single one passed a round only because it drifted with
    the conditions: an effect can look inconstant while another one it interacts with is
    missing (a yaw-rate gain and understeer, say). The (at most ``PAIR_SEEDS``) strongest
    such candidates are each paired with every other candidate; the pair with the lowest
    held-out error that passes every rule (both effects constant) is accepted.

    Returns (trial of the first effect, trial of the second, the pair trials), both trials
    holding the pair's fit, or None.
    """
    train, test = data.train_mask(), data.test_mask()
    seeds = sorted(
        (
            t
            for t in trials
            if t.stable is False
            and t.material
            and t.delta_bic <= rules.max_delta_bic
            and all(z >= rules.min_z for z in t.z.values())
        ),
        key=lambda t: weighted_holdout(t.holdout, data),
    )[:PAIR_SEEDS]
    found: list[tuple[float, Trial, Trial]] = []
    pair_trials: list[Trial] = []
    for t in seeds:
        for e2 in remaining:
            if e2 is t.effect:
                continue
            spec = t.fit.spec.with_effect(e2)
            th0 = list(t.fit.theta) + [p.init for p in e2.params]
            try:
                f = fit_model(spec, data, th0, train, tol=1e-6)
                hold = holdout_rms(spec, f.theta, data, test)
                z1, z2 = z_scores(f, t.effect, data), z_scores(f, e2, data)
                d_bic = bic(f, factors) - bic_cur
            except (ArithmeticError, ValueError, np.linalg.LinAlgError, SolverError):
                continue
            chans = tuple(dict.fromkeys((*t.effect.channels, *e2.channels)))
            material = is_material(chans, hold, hold_cur, data, rules.min_gain)
            second = Trial(e2, f, hold, d_bic, z2, material)
            pair_trials.append(second)
            if (
                material
                and d_bic <= 2 * rules.max_delta_bic
                and all(z >= rules.min_z for z in (*z1.values(), *z2.values()))
                and _interior(f)
            ):
                first = Trial(t.effect, f, hold, d_bic, z1, material)
                found.append((weighted_holdout(hold, data), first, second))
    for _, first, second in sorted(found, key=lambda x: x[0]):
        ok1, split1 = _stability(first, data, rules)
        ok2, split2 = _stability(second, data, rules) if ok1 else (False, None)
        if ok1 and ok2:
            first = replace(first, split=split1, stable=True, accepted=True)
            second = replace(second, split=split2, stable=True, accepted=True)
            pair_trials[pair_trials.index(next(p for p in pair_trials if p.fit is second.fit))] = (
                second
            )
            return first, second, pair_trials
    return None


def accepted_effects(steps: Sequence[SelectionStep]) -> list[Effect]:
    """Effects accepted over the rounds, in order."""
    return [s.accepted.effect for s in steps if s.accepted is not None]
