"""What a misfit does to each number: intervals under a model that does not explain the log,
and intervals that span explanations the log cannot tell apart.

A model-conditional interval (a sandwich, a bootstrap) is honest only while the model explains
the log. When it does not, the unexplained structure can move every parameter it overlaps,
by an amount no interval of the wrong model measures. The estimate then keeps its value, its
interval is widened by the misfit factor (residual RMS over the noise floor, and the spread of
the parameter over separate pieces of the log when the robot fitted them), and it is reported
*not determined*, with why: a tight interval over a misfit is a defect.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from calib.adequacy.verdict import Adequacy
from calib.results import Estimate
from calib.stats import Z95

__all__ = ["Z95", "span", "under_misfit", "under_misfit_all"]


def _where(adequacy: Adequacy) -> str:
    worst = max(adequacy.channels, key=lambda c: c.judged_ratio)
    where = ", ".join(list(dict.fromkeys(loc.label for loc in adequacy.located))[:2])
    return (
        f"the model ({adequacy.model}) does not explain the log: {worst.channel} residual "
        f"{worst.judged_ratio:.2g}x its noise floor" + (f" ({where})" if where else "")
    )


def under_misfit(
    est: Estimate,
    adequacy: Adequacy,
    *,
    pieces: Sequence[float] = (),
    why: str = "",
) -> Estimate:
    """``est`` as a model that does not explain the log allows: unchanged while ``adequacy``
    explains (or was not assessed); else the value kept, the standard error scaled by the misfit
    factor and combined with the spread of ``pieces`` (the parameter fitted on separate parts of
    the log), and not determined, with ``why`` (default: the verdict in words)."""
    if adequacy.explains or not adequacy.channels:
        return est
    reason = why or _where(adequacy)
    k = adequacy.misfit_factor
    spread = 0.0
    vals = [p for p in pieces if math.isfinite(p)]
    if len(vals) >= 2:
        mean = sum(vals) / len(vals)
        spread = math.sqrt(sum((v - mean) ** 2 for v in vals) / (len(vals) - 1))
    std = math.hypot(est.std * k, spread) if math.isfinite(est.std) else math.nan
    note = f"{reason}; interval widened x{k:.2g} for the misfit, not a calibrated 95 %"
    if not math.isfinite(std):
        return Estimate(
            est.name, est.value, math.nan, (-math.inf, math.inf), False, est.unit, reason
        )
    half = Z95 * std
    return Estimate(
        est.name, est.value, std, (est.value - half, est.value + half), False, est.unit, note
    )


def under_misfit_all(
    estimates: Mapping[str, Estimate],
    adequacy: Adequacy,
    *,
    movable: Sequence[str] | None = None,
    pieces: Mapping[str, Sequence[float]] | None = None,
) -> dict[str, Estimate]:
    """:func:`under_misfit` for every estimate named in ``movable`` (default: all)."""
    names = set(estimates) if movable is None else set(movable)
    pieces = pieces or {}
    return {
        k: under_misfit(e, adequacy, pieces=pieces.get(k, ())) if k in names else e
        for k, e in estimates.items()
    }


def span(
    estimates: Sequence[Estimate],
    labels: Sequence[str],
    *,
    rel_tol: float = 0.05,
    scale: float = 0.0,
) -> Estimate:
    """One estimate spanning explanations the log cannot tell apart (each of ``estimates`` is
    the same parameter under the explanation named in ``labels``): the first's value, the union
    of the intervals, determined only while that union is within ``rel_tol`` of the value
    (``scale``: a size below which the relative rule would be unfair)."""
    first = estimates[0]
    lo = min(e.ci95[0] for e in estimates)
    hi = max(e.ci95[1] for e in estimates)
    vals = ", ".join(f"{e.value:.4g} ({lab})" for e, lab in zip(estimates, labels, strict=True))
    half = max(hi - first.value, first.value - lo)
    ok = (
        all(e.identifiable for e in estimates)
        and math.isfinite(half)
        and (half <= rel_tol * max(abs(first.value), scale))
    )
    note = f"the log cannot tell apart explanations that give {vals}; the interval spans them"
    return Estimate(
        first.name,
        first.value,
        half / Z95 if math.isfinite(half) else math.nan,
        (lo, hi),
        ok,
        first.unit,
        note,
    )
