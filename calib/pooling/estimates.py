"""Pooling of several pieces' calibration results (time windows of a log, runs of a robot) into
one: every parameter jointly by its covariance (:func:`calib.pooling.gls.pool_gls`), or each on
its own by inverse-variance weighting (:func:`calib.pooling.meta.pool_estimates`) when some piece
has no covariance; the pooled estimate not determined where the pooled model does not explain
the pieces. The statistics of ``logtools.windows`` (which reads the windows and calls these), in
calib so that there is one pooling engine; labels and results in, results out, no robot.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from calib.adequacy import under_misfit
from calib.adequacy.verdict import Adequacy
from calib.pooling.gls import Pooled, pool_gls, pool_univariate
from calib.pooling.meta import pool_estimates
from calib.results import CalibrationResult, Estimate, as_matrix, correlations_of, json_safe

__all__ = [
    "DeriveFn",
    "one_method",
    "piece_covariance",
    "pool_each",
    "pool_jointly",
    "pool_pieces",
    "pooled_estimate",
]

DeriveFn = Callable[[CalibrationResult, Sequence[CalibrationResult]], Mapping[str, Estimate]]
"""A robot's derived quantities of a pooled estimate (``RobotPlugin.derive_pooled``): given the
pooled result (parameters and covariance) and the pieces' own results, the quantities under
their keys."""


def pool_each(
    estimates: Sequence[CalibrationResult],
    labels: Sequence[str],
    kind: str,
    what: str = "windows",
) -> tuple[dict[str, Estimate], dict[str, dict[str, Any]], list[str]]:
    """Each parameter (``kind`` "parameters") or derived quantity ("derived") pooled on its own
    over the windows' ``estimates`` (``what``: "windows" or "runs"; ``labels`` name them): the
    estimates, the meta-analysis per name, and warnings for names whose windows disagree."""
    names: list[str] = []
    for r in estimates:
        for n in getattr(r, kind, {}):
            if n not in names:
                names.append(n)
    out: dict[str, Estimate] = {}
    stats: dict[str, dict[str, Any]] = {}
    warnings: list[str] = []
    for n in names:
        ests = [getattr(r, kind, {}).get(n) for r in estimates]
        first = next(e for e in ests if e is not None)
        unit = first.unit
        # every window with a finite std takes part, a not determined one with the wide
        # interval its own analysis gave it (so it weighs little); whether the pooled value
        # is determined follows the windows that determine it
        pe = pool_estimates(
            n,
            unit,
            list(labels),
            [e.value if e else None for e in ests],
            [e.std if e else None for e in ests],
            [True] * len(ests),
        )
        determined = [e for e in ests if e is not None and e.identifiable]
        k = pe.n_logs
        if k == 0:
            note = f"no {what[:-1]} determines it"
        elif pe.heterogeneous:
            note = (
                f"the {k} {what} disagree beyond their errors (Cochran's Q p = "
                f"{pe.p_heterogeneity:.2g}, I2 = {100 * (pe.i2 or 0):.0f} %, between-"
                f"{what[:-1]} std {pe.tau:.3g} {unit}): random-effects interval, which "
                "includes the spread"
            )
            warnings.append(
                f"{n} differs between the windows of the log beyond their errors "
                f"(Cochran's Q p = {pe.p_heterogeneity:.2g}): a part that changed "
                "or wore, or physics the model leaves out; each window's own "
                "estimate is in runs"
            )
        else:
            note = f"{k} {what} agree within their errors" + (
                f" (Cochran's Q p = {pe.p_heterogeneity:.2g})"
                if pe.p_heterogeneity is not None
                else ""
            )
        e = pe.estimate
        out[n] = Estimate(
            first.name, e.value, e.std, e.ci95, bool(determined) and k > 0, unit, note
        )
        stats[n] = pe.to_dict()
    return out, stats, warnings


def piece_covariance(est: CalibrationResult, names: Sequence[str]) -> np.ndarray:
    """``est``'s covariance over ``names`` with its correlations and its reported standard
    errors (NaN for a name it lacks or does not determine to a finite std)."""
    own = list(est.parameters)
    corr = np.array(correlations_of(as_matrix(est.covariance or ())), dtype=float)
    p = len(names)
    sd = np.array(
        [est.parameters[n].std if n in est.parameters else math.nan for n in names], dtype=float
    )
    cov = np.full((p, p), math.nan)
    for a, na in enumerate(names):
        for b, nb in enumerate(names):
            if a == b:
                cov[a, a] = sd[a] ** 2
            elif na in est.parameters and nb in est.parameters:
                cov[a, b] = corr[own.index(na), own.index(nb)] * sd[a] * sd[b]
    return cov


def pool_jointly(
    estimates: Sequence[CalibrationResult],
    labels: Sequence[str],
    names: Sequence[str],
    what: str,
) -> tuple[dict[str, Estimate], np.ndarray, dict[str, dict[str, Any]], list[str]]:
    """The parameters ``names`` pooled jointly over the pieces' ``estimates`` (each with a
    covariance; ``labels`` name them) by :func:`calib.pooling.gls.pool_gls`: the estimates,
    the pooled covariance, the pooling per name and warnings where the pieces disagree."""
    ests = list(estimates)
    vals = np.array(
        [[e.parameters[n].value if n in e.parameters else math.nan for n in names] for e in ests],
        dtype=float,
    )
    covs = np.array([piece_covariance(e, names) for e in ests])
    pooled = pool_gls(vals, covs)
    one = what[:-1]
    het = pooled.heterogeneous
    i2 = max(0.0, (pooled.q - pooled.df) / pooled.q) if pooled.q > 0 else 0.0
    test = (
        f"generalised Cochran's Q over {', '.join(names)} p = {pooled.p_value:.2g}, df {pooled.df}"
        if pooled.df > 0
        else ""
    )
    out: dict[str, Estimate] = {}
    stats: dict[str, dict[str, Any]] = {}
    warnings: list[str] = []
    marginal_bad: list[str] = []
    for j, n in enumerate(names):
        own = [e.parameters.get(n) for e in ests]
        first = next(e for e in own if e is not None)
        informing = [
            i
            for i in range(len(ests))
            if math.isfinite(covs[i, j, j]) and covs[i, j, j] > 0 and math.isfinite(vals[i, j])
        ]
        k = int(pooled.pieces[j])
        sd = pooled.cov[j, j] ** 0.5 if math.isfinite(pooled.cov[j, j]) else math.nan
        value = float(pooled.value[j])
        marginal = pool_univariate(vals[:, j], np.sqrt(covs[:, j, j]), random="never")
        if marginal.heterogeneous:
            marginal_bad.append(n)
        note = _joint_note(pooled, k, sd, len(ests), what, test, i2)
        determined = any(e is not None and e.identifiable for e in own)
        half = 1.959963984540054 * sd
        out[n] = Estimate(
            first.name,
            value,
            sd,
            (value - half, value + half),
            determined and k > 0 and math.isfinite(sd),
            first.unit,
            note,
        )
        stats[n] = json_safe(
            {
                "estimate": out[n].to_dict(),
                "method": pooled.method,
                "n_logs": k,
                "left_out": [
                    f"{lab}: not determined by this {one}"
                    for i, lab in enumerate(labels)
                    if i not in informing
                ],
                "joint": list(names),
                "q": pooled.q,
                "df": pooled.df,
                "p_heterogeneity": pooled.p_value,
                "i2": i2,
                "heterogeneous": het,
                "inflation": pooled.inflation,
                "parameter_q": marginal.q,
                "parameter_p_heterogeneity": marginal.p_value,
            }
        )
    if het:
        warnings = _joint_warnings(names, marginal_bad, stats, what, test)
    return out, pooled.cov, stats, warnings


def _joint_note(
    pooled: Pooled, k: int, sd: float, n_pieces: int, what: str, test: str, i2: float
) -> str:
    """How one parameter was pooled jointly (``k`` pieces inform it, ``sd`` its pooled std,
    ``test`` the heterogeneity test's words), for its estimate's note."""
    if k == 0 or not math.isfinite(sd):
        return f"no {what[:-1]} determines it"
    if pooled.heterogeneous:
        return (
            f"the {n_pieces} {what} disagree beyond their errors ({test}, I2 = "
            f"{100 * i2:.0f} %): {pooled.method}, an interval that includes the spread"
        )
    if pooled.df > 0 and pooled.inflation > 1.0:
        return (
            f"{k} {what} agree within their errors ({test}); {pooled.method}: the "
            f"spread between them widens the variances up to x{pooled.inflation:.3g}"
        )
    if pooled.df > 0:
        return f"{k} {what} agree within their errors ({test}); {pooled.method}"
    return f"one {what[:-1]}"


def _joint_warnings(
    names: Sequence[str],
    marginal_bad: Sequence[str],
    stats: Mapping[str, Mapping[str, Any]],
    what: str,
    test: str,
) -> list[str]:
    """The warnings when the pieces disagree jointly: each parameter that differs on its own
    (``marginal_bad``), else the parameters together."""
    one = what[:-1]
    among = "the windows of the log" if what == "windows" else f"the {what}"
    warnings = []
    for n in marginal_bad:
        p_n = stats[n]["parameter_p_heterogeneity"]
        warnings.append(
            f"{n} differs between {among} beyond their errors (Cochran's Q "
            f"p = {p_n:.2g}): a part that changed or wore, or physics the "
            f"model leaves out; each {one}'s own estimate is in runs"
        )
    if not marginal_bad:
        warnings.append(
            f"{', '.join(names)} differ jointly between {among} beyond "
            f"their errors ({test}), though none does on its own: a part that "
            f"changed or wore, or physics the model leaves out; each {one}'s "
            "own estimate is in runs"
        )
    return warnings


def pool_pieces(
    estimates: Sequence[CalibrationResult],
    labels: Sequence[str],
    what: str,
    derive: DeriveFn | None,
) -> tuple[dict[str, Estimate], dict[str, Estimate], np.ndarray | None, dict[str, Any], list[str]]:
    """The parameters and derived quantities of the pieces' ``estimates`` (``labels`` name
    them) pooled:
    jointly with the pooled covariance when every piece has a covariance, the derived ones then
    recomputed by ``derive`` (the robot's; without it, pooled on their own); else each on its
    own, with no covariance. Returns parameters, derived, covariance, pooling per name and
    warnings."""
    ests = list(estimates)
    if len(ests) == 1:  # nothing to pool: the piece's own estimates, intervals as it gave them
        one = ests[0]
        cov = None if one.covariance is None else np.asarray(one.covariance, dtype=float)
        return (
            dict(one.parameters),
            dict(one.derived),
            cov,
            {
                n: {"method": f"the only {what[:-1]}'s own estimate"}
                for n in (*one.parameters, *one.derived)
            },
            [],
        )
    names: list[str] = []
    for e in ests:
        names += [n for n in e.parameters if n not in names]
    if not names or any(e.covariance is None for e in ests):
        params, stats, warns = pool_each(ests, labels, "parameters", what)
        derived, dstats, dwarns = pool_each(ests, labels, "derived", what)
        return params, derived, None, {**stats, **dstats}, warns + dwarns
    params, cov, stats, warns = pool_jointly(ests, labels, names, what)
    if derive is None:
        derived, dstats, dwarns = pool_each(ests, labels, "derived", what)
        return params, derived, cov, {**stats, **dstats}, warns + dwarns
    base = CalibrationResult(
        method="pooled", parameters=params, verdict="", covariance=as_matrix(cov)
    )
    derived = dict(derive(base, ests))
    for n, d in derived.items():
        stats[n] = json_safe(
            {
                "estimate": d.to_dict(),
                "method": "computed by the robot from the pooled parameters and their covariance",
            }
        )
    return params, derived, cov, stats, warns


def _not_determined(
    estimates: Mapping[str, Estimate], adequacy: Adequacy, pieces: Sequence[Mapping[str, Estimate]]
) -> dict[str, Estimate]:
    """The pooled estimates when the model does not explain the pieces: not determined, widened
    as a whole log's are (:func:`calib.adequacy.under_misfit`: the standard error by the
    misfit factor, combined with the spread of the pieces' own values). Pooling divides the
    pieces' errors by their number, but a misfit that biases every piece alike does not
    average out; the spread and the factor keep the interval from narrowing over it."""
    out = {}
    for n, e in estimates.items():
        values = [p[n].value for p in pieces if n in p and math.isfinite(p[n].value)]
        out[n] = under_misfit(e, adequacy, pieces=values, why=adequacy.summary)
    return out


def _how(cov: np.ndarray | None, what: str) -> str:
    """How the pooled estimate was obtained, for its verdict."""
    if cov is None:
        return (
            f"each parameter by inverse-variance weighting (random effects where the {what} "
            "disagree); correlations between parameters are not pooled (some "
            f"{what[:-1]} has no covariance)."
        )
    return (
        "all parameters jointly by generalised least squares over their covariances "
        f"(random effects where the {what} disagree)."
    )


def one_method(estimates: Sequence[CalibrationResult], several: str) -> str:
    """The method every piece's estimate used, or ``several`` when they differ."""
    methods = {r.method for r in estimates}
    return next(iter(methods)) if len(methods) == 1 else several


def pooled_estimate(
    params: dict[str, Estimate],
    derived: dict[str, Estimate],
    cov: np.ndarray | None,
    estimates: Sequence[CalibrationResult],
    n_total: int,
    adequacy: Adequacy,
    model: str,
    what: str,
) -> CalibrationResult:
    """The pooled estimate of the pieces' ``estimates`` (of ``n_total`` windows or runs,
    ``what``): not determined where the pooled model does not explain them, with the
    assumptions every piece's intervals make."""
    verdict = (
        f"{len(estimates)} of {n_total} {what}s pooled, " + _how(cov, f"{what}s")
        if len(estimates) > 1
        else f"1 of {n_total} {what}s with an estimate: its own estimate, not pooled."
    )
    if adequacy.channels and not adequacy.explains:
        ests = list(estimates)
        params = _not_determined(params, adequacy, [e.parameters for e in ests])
        derived = _not_determined(derived, adequacy, [e.derived for e in ests])
        verdict += " " + adequacy.summary
    assumed = _shared_assumptions(list(estimates))
    if any(e.identifiable for e in params.values()):
        verdict = _assuming(verdict, assumed, what)
    return CalibrationResult(
        method=f"{model} pooled over {len(estimates)} {what}s",
        parameters=params,
        derived=derived,
        verdict=verdict,
        covariance=None if cov is None else as_matrix(cov),
        assumptions=assumed,
    )


def _shared_assumptions(pieces: Sequence[CalibrationResult]) -> tuple[str, ...]:
    """The assumptions every piece's estimate makes (in the first piece's order)."""
    if not pieces:
        return ()
    return tuple(a for a in pieces[0].assumptions if all(a in p.assumptions for p in pieces))


def _assuming(verdict: str, assumptions: Sequence[str], what: str) -> str:
    """``verdict`` and, when there are any, the assumptions each piece's intervals made."""
    if not assumptions:
        return verdict
    return f"{verdict} These intervals assume {'; '.join(assumptions)}, as each {what}'s do."
