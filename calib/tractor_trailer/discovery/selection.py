"""The command-driven model as a fitter of the shared forward selection
(:func:`calib.discovery.select_effects`), with this model's rules.

Each round fits every remaining candidate added to the current model (training blocks, link
lengths refitted jointly, started from the current model's solution), measures the RMS on the
held-out blocks and the BIC change, and accepts, among the candidates that pass all the rules
below, the one with the lowest noise-weighted held-out error (every catalogue effect has one
parameter):

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
(the engine's pair rounds): an effect can look inconstant while another it interacts with is
missing. A pair is accepted under the same rules (BIC <= 2 x ``max_delta_bic``, both effects
significant, interior and constant) and recorded as two consecutive rounds.

The engine owns the rounds; this module owns what is the tractor-trailer's: the fit of a set of
effects (:class:`CommandFitter`), materiality on the channels an effect acts on
(:func:`is_material`), the ranking by noise-weighted held-out error and the constancy check on
halves of the log (:func:`_stability`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.discovery import (
    CandidateFailedError,
    Checks,
    EffectSpec,
    Round,
    Selection,
    SelectionRules,
)
from calib.discovery import ModelFit as EngineFit
from calib.discovery import select_effects as engine_select
from calib.errors import SolverError
from calib.results import Estimate
from calib.tractor_trailer.discovery.data import RESOLUTION, DiscoveryData, block_mean
from calib.tractor_trailer.discovery.effects import Effect
from calib.tractor_trailer.discovery.fit import (
    CommandFit,
    bic,
    covariance,
    fit_model,
    holdout_rms,
    neff_factors,
    param_std,
)
from calib.tractor_trailer.discovery.model import BASE_PARAMS, ModelSpec, Vector

__all__ = [
    "CommandFitter",
    "CommandRules",
    "accepted_effects",
    "is_material",
    "select_effects",
    "trial_record",
    "weighted_holdout",
    "z_scores",
]


PAIR_SEEDS = 2


@dataclass(frozen=True)
class CommandRules:
    """Thresholds of the acceptance rules (see the module docstring)."""

    min_gain: float = 0.10
    max_delta_bic: float = -10.0
    min_z: float = 3.0
    max_split_z: float = 3.0
    max_split_rel: float = 0.25
    max_effects: int = 4

    def engine(self) -> SelectionRules:
        """The shared engine's rules for these thresholds."""
        return SelectionRules(
            max_effects=self.max_effects,
            bic_margin=-self.max_delta_bic,
            min_z=self.min_z,
            require_interior=True,
            pairs=True,
            pair_seeds=PAIR_SEEDS,
        )


def z_scores(fit: CommandFit, effect: Effect, data: DiscoveryData) -> dict[str, float]:
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
    f: CommandFit, e: Effect, data: DiscoveryData, rules: CommandRules
) -> tuple[bool, dict[str, list[float]]]:
    """Refit ``f``'s model on each half of each split; True if the effect ``e`` is constant."""
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


def _interior(fit: CommandFit, rel: float = 1e-3) -> bool:
    """True if no effect parameter is within ``rel`` of its range from a bound."""
    specs = fit.spec.param_specs[len(BASE_PARAMS) :]
    vals = fit.theta[len(BASE_PARAMS) :]
    return all(
        p.lower + rel * (p.upper - p.lower) < v < p.upper - rel * (p.upper - p.lower)
        for p, v in zip(specs, vals, strict=True)
    )


def weighted_holdout(hold: Mapping[str, float], data: DiscoveryData) -> float:
    """Held-out error of all outputs, each in units of its noise level on the fitting grid."""
    return sum((r / data.sigma_d[c]) ** 2 for c, r in hold.items())


def is_material(
    channels: Sequence[str],
    hold: Mapping[str, float],
    hold_before: Mapping[str, float],
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


class CommandFitter:
    """The engine's :class:`~calib.discovery.Fitter` for the command-driven model: a set of
    effects fitted with L1, L2 on the training blocks, started from the fit of the same set
    without its last effect (the current model of the round), judged on the held-out blocks,
    its BIC counted at the effective sample sizes of a reference model that holds every
    candidate (so that every candidate is judged at the same rate)."""

    def __init__(
        self,
        data: DiscoveryData,
        baseline: ModelSpec,
        theta0: Vector,
        candidates: Sequence[Effect],
    ) -> None:
        self.data, self.baseline, self.theta0 = data, baseline, list(theta0)
        self.train, self.test = data.train_mask(), data.test_mask()
        ref_spec = ModelSpec(baseline.baseline, (*baseline.effects, *candidates))
        ref_theta0 = list(theta0) + [p.init for e in candidates for p in e.params]
        ref = fit_model(
            ref_spec, data, ref_theta0, self.train, tol=1e-4, max_nfev=20 * len(ref_theta0)
        )
        self.factors = neff_factors(ref)
        self.fits: dict[tuple[str, ...], CommandFit] = {}

    def _fit(self, effects: tuple[Effect, ...]) -> CommandFit:
        if not effects:
            return fit_model(self.baseline, self.data, self.theta0, self.train)
        parent = self.fits[tuple(e.key for e in effects[:-1])]
        last = effects[-1]
        th0 = list(parent.theta) + [p.init for p in last.params]
        return fit_model(parent.spec.with_effect(last), self.data, th0, self.train, tol=1e-6)

    def __call__(self, specs: tuple[EffectSpec[Effect], ...]) -> EngineFit:
        effects = tuple(_effect(s) for s in specs)
        keys = tuple(e.key for e in effects)
        try:
            f = self._fit(effects)
            hold = holdout_rms(f.spec, f.theta, self.data, self.test)
            value = bic(f, self.factors)
            pars = _effect_estimates(f, effects, self.data)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError, SolverError) as err:
            raise CandidateFailedError(f"{type(err).__name__}: {err}") from err
        if not all(math.isfinite(x) for x in (value, *hold.values())):
            raise CandidateFailedError("non-finite fit")
        self.fits[keys] = f
        n, n_test = int(f.mask.sum()), int(self.test.sum())
        sse = sum(r / self.data.sigma_d[c] ** 2 for c, r in f.rss().items())
        return EngineFit(
            specs,
            {},
            pars,
            sse,
            n_test * weighted_holdout(hold, self.data),
            n * len(hold),
            len(f.theta),
            n_heldout=n_test * len(hold),
            payload=f,
            bic_value=value,
            heldout_rms=hold,
            at_bound=not _interior(f),
        )

    def checks(self, rules: CommandRules) -> Checks:
        """This model's own tests for the engine (module docstring)."""
        data = self.data

        def material(cand: EngineFit, current: EngineFit, added: tuple[EffectSpec, ...]) -> bool:
            chans = tuple(dict.fromkeys(c for s in added for c in _effect(s).channels))
            return is_material(chans, cand.heldout_rms, current.heldout_rms, data, rules.min_gain)

        def stable(fit: EngineFit, spec: EffectSpec) -> tuple[bool, Any]:
            return _stability(fit.payload, _effect(spec), data, rules)

        return Checks(
            material=material, rank=lambda f: weighted_holdout(f.heldout_rms, data), stable=stable
        )


def _effect(spec: EffectSpec[Effect]) -> Effect:
    if spec.model is None:  # pragma: no cover - every command-driven entry is its own hook
        raise ValueError(f"command-driven effect {spec.key}: no hook")
    return spec.model


def _effect_estimates(
    f: CommandFit, effects: Sequence[Effect], data: DiscoveryData
) -> dict[str, dict[str, Estimate]]:
    """Each effect's parameters with the standard errors that are reported (a time shift's
    include the time resolution; ``fit.param_std``)."""
    cov = covariance(f, data)
    out: dict[str, dict[str, Estimate]] = {}
    for e in effects:
        out[e.key] = {}
        for p in e.params:
            name = f"{e.key}.{p.name}"
            sd = param_std(f, cov, name, p.time_shift, data.time_resolution_s)
            v = float(f.theta[f.names.index(name)])
            out[e.key][p.name] = Estimate(
                p.name, v, sd, (v - 1.96 * sd, v + 1.96 * sd), unit=p.unit
            )
    return out


def select_effects(
    data: DiscoveryData,
    baseline: ModelSpec,
    theta0: Vector,
    candidates: Sequence[Effect],
    rules: CommandRules | None = None,
) -> tuple[Selection, dict[str, float]]:
    """Greedy forward selection through the shared engine; returns its selection and the
    effective-sample factors used (SolverError when the baseline itself cannot be fitted)."""
    rules = rules or CommandRules()
    fitter = CommandFitter(data, baseline, theta0, candidates)
    sel = engine_select(
        fitter, [e.spec for e in candidates], rules=rules.engine(), checks=fitter.checks(rules)
    )
    if sel is None:
        raise SolverError("discovery: the baseline could not be fitted on the training blocks")
    return sel, fitter.factors


def trial_record(r: Round, data: DiscoveryData) -> dict[str, object]:
    """One round of the selection for the diagnostics: the held-out RMS before it, each
    candidate (its held-out RMS, BIC change, z-scores, materiality, constancy and split
    values), the accepted effect and the candidates whose fit failed."""
    trials = []
    for t in r.tried:
        fit = t.fit
        spec = next(s for s in fit.effects if s.key == t.key) if fit is not None else None
        trials.append(
            {
                "effect": t.key,
                "holdout_rms": dict(fit.heldout_rms) if fit is not None else {},
                "delta_bic": t.delta_bic,
                "z": fit.z_scores(spec) if fit is not None and spec is not None else {},
                "material": t.material,
                "accepted": t.accepted,
                "split": t.detail,
                "stable": t.stable,
            }
        )
    return {
        "holdout_before": dict(r.before.heldout_rms),
        "trials": trials,
        "accepted": None if r.accepted is None else r.accepted.key,
        "errors": dict(r.failed),
    }


def accepted_effects(sel: Selection) -> list[Effect]:
    """Effects accepted over the rounds, in order."""
    return [_effect(s) for s in sel.final.effects]
