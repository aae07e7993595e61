"""Intervals that hold across the explanations of a log.

A log may be explained comparably well by several models: the nominal one, catalogue effects
that the log does not tell apart, a described residual model, the pieces of a long log. Each
gives the robot's parameters with its own uncertainty (an autocorrelation-robust interval of
that model's fit). The reported interval must hold whichever of them is right, and no more:

- the *plausible* explanations are those the data do not reject against the best one: a BIC
  within ``BIC_MARGIN`` of the best, or a held-out sum of squares that the best does not beat
  by ``MIN_HELDOUT_GAIN`` of what the noise floor leaves to gain (neither of the selection's
  two tests would prefer the best);
- a parameter's interval is the union of its 95 % intervals under the plausible explanations
  (a profile over the nuisance of which explanation holds), its value the best explanation's;
- it is *determined* when every plausible explanation determines it and they agree: each
  pair's values within their combined 95 % (``Z95`` x the root sum of squares of their
  errors). Where they disagree, the interval still spans them and the estimate is reported not
  determined, with the values each explanation gives.

While the final model explains the log this replaces widening one model's interval by the
misfit factor: the interval is not inflated where every plausible explanation agrees. While it
does not, each explanation's interval is widened by the final model's misfit ratio (residual over
noise floor) before the union, and nothing is determined: unmodelled physics can bias every
explanation alike (the explanation study's concealed kinds did, by 2-3 %), which no union of
conditional intervals measures.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from calib.discovery.base import ModelFit
from calib.discovery.selection import BIC_MARGIN, MIN_HELDOUT_GAIN, heldout_gain
from calib.results import Estimate, json_safe
from calib.stats import Z95

__all__ = ["Explanation", "Spanned", "across", "plausible"]


@dataclass(frozen=True)
class Explanation:
    """One explanation of the log: its ``label`` ("nominal", "clock_offset(run 3)",
    "described"), its fit (for the plausibility tests), and the robot's parameters it implies
    (``parameters``: by name, with that explanation's own uncertainty; default the fit's)."""

    label: str
    fit: ModelFit
    parameters: Mapping[str, Estimate] = field(default_factory=dict)

    @property
    def estimates(self) -> Mapping[str, Estimate]:
        return self.parameters or self.fit.parameters


def plausible(explanations: Sequence[Explanation], best: Explanation) -> list[Explanation]:
    """``best`` and every explanation the data do not reject against it (module docstring)."""
    out = [best]
    for e in explanations:
        if e is best or e.label == best.label:
            continue
        close_bic = e.fit.bic - best.fit.bic < BIC_MARGIN
        close_heldout = heldout_gain(e.fit, best.fit) < MIN_HELDOUT_GAIN
        if close_bic or close_heldout:
            out.append(e)
    return out


@dataclass(frozen=True)
class Spanned:
    """A parameter across the plausible explanations: the reported ``estimate`` and each
    explanation's own (``values``: label -> estimate)."""

    estimate: Estimate
    values: Mapping[str, Estimate]
    agree: bool

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "estimate": self.estimate.to_dict(),
                "agree": self.agree,
                "explanations": {k: v.to_dict() for k, v in self.values.items()},
            }
        )


def _agree(vals: Sequence[Estimate]) -> bool:
    for i, a in enumerate(vals):
        for b in vals[i + 1 :]:
            s = math.hypot(a.std, b.std)
            if not (math.isfinite(s) and abs(a.value - b.value) <= Z95 * s):
                return False
    return True


def _widened(e: Estimate, k: float) -> Estimate:
    """``e`` with its standard error and interval scaled by ``k`` about its value."""
    lo, hi = e.ci95
    return replace(
        e, std=e.std * k, ci95=(e.value - k * (e.value - lo), e.value + k * (hi - e.value))
    )


def _span_one(
    name: str, by_label: Mapping[str, Estimate], best_label: str, misfit: float | None = None
) -> Spanned:
    if misfit is not None:
        by_label = {k: _widened(e, max(misfit, 1.0)) for k, e in by_label.items()}
    first = by_label[best_label]
    vals = list(by_label.values())
    if len(vals) == 1 and misfit is None:
        return Spanned(first, dict(by_label), True)
    lo = min(e.ci95[0] for e in vals)
    hi = max(e.ci95[1] for e in vals)
    agree = _agree(vals)
    ident = all(e.identifiable for e in vals) and agree and math.isfinite(lo - hi)
    listed = ", ".join(f"{e.value:.4g} ({k})" for k, e in by_label.items())
    if misfit is not None:
        ident = False
        note = (
            f"the final model does not explain the log (worst residual {misfit:.2g}x its "
            f"floor): not determined; the interval spans the explanations that fit it "
            f"({listed}), each widened x{max(misfit, 1.0):.2g} for the misfit"
        )
    elif agree:
        note = f"the explanations that fit this log agree ({listed}); the interval spans them"
    else:
        note = (
            f"the explanations that fit this log disagree ({listed}): not determined; the "
            "interval spans them"
        )
    half = max(hi - first.value, first.value - lo)
    std = half / Z95 if math.isfinite(half) else math.nan
    est = Estimate(first.name, first.value, std, (lo, hi), ident, first.unit, note)
    return Spanned(est, dict(by_label), agree)


def across(
    explanations: Sequence[Explanation],
    best: Explanation,
    names: Sequence[str] | None = None,
    *,
    misfit: float | None = None,
) -> dict[str, Spanned]:
    """Each parameter (``names``, default the best explanation's) spanned over the plausible
    explanations (module docstring). ``misfit``: the final model's worst residual over its
    noise floor when it does not explain the log (None while it does): each explanation's
    interval is widened by it (at least 1) and no parameter is determined (a tight interval
    over a misfit is a defect; one widened by the misfit alone is not inflated past use)."""
    keep = plausible(explanations, best)
    wanted = list(best.estimates) if names is None else list(names)
    out: dict[str, Spanned] = {}
    for name in wanted:
        by_label = {e.label: e.estimates[name] for e in keep if name in e.estimates}
        if best.label in by_label:
            out[name] = _span_one(name, by_label, best.label, misfit)
    return out
