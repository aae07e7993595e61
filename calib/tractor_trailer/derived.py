"""The tractor-trailer's derived quantities on a ``CalibrationResult``: the sum of the link
lengths L1 + L2 (usually far better determined than the split), under its JSON key
``"sum_L1_L2"``. The shared result type knows no robot; this module is where the tractor's
code puts and finds its sum, and computes it for a pooled estimate (:func:`pooled_derived`, the
tractor's ``RobotPlugin.derive_pooled``)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from calib.results import CalibrationResult, Estimate

__all__ = ["SUM_KEY", "derived_sum", "link_sum", "pooled_derived"]

SUM_KEY = "sum_L1_L2"
"""The key of L1 + L2 in ``CalibrationResult.derived`` and in the result's JSON."""


def derived_sum(
    total: Estimate | None, derived: Mapping[str, Estimate] | None = None
) -> dict[str, Estimate]:
    """The derived quantities ``derived`` (none by default) with L1 + L2 set to ``total``
    (left out when ``total`` is None)."""
    out = {k: e for k, e in (derived or {}).items() if k != SUM_KEY}
    if total is not None:
        out[SUM_KEY] = total
    return out


def link_sum(result: CalibrationResult) -> Estimate | None:
    """The L1 + L2 of ``result`` (None when it has none)."""
    return result.derived.get(SUM_KEY)


def pooled_derived(
    pooled: CalibrationResult, pieces: Sequence[CalibrationResult]
) -> dict[str, Estimate]:
    """The derived quantities of ``pooled`` (an estimate pooled over ``pieces``: windows or
    runs) with L1 + L2 from its L1, L2 and their covariance: value L1 + L2, variance
    var(L1) + var(L2) + 2 cov(L1, L2), a Wald 95 % interval. Determined where some piece
    determined its own sum and the pooled variance is finite (as the pooled parameters follow
    the pieces that determine them); no sum without L1, L2 and a covariance."""
    names = pooled.parameter_names
    if pooled.covariance is None or not {"L1", "L2"} <= set(names):
        return derived_sum(None, pooled.derived)
    i, j = names.index("L1"), names.index("L2")
    c = pooled.covariance
    var = c[i][i] + c[j][j] + 2.0 * c[i][j]
    value = pooled.parameters["L1"].value + pooled.parameters["L2"].value
    std = math.sqrt(var) if math.isfinite(var) and var >= 0 else math.nan
    ok = math.isfinite(std) and any(
        (s := link_sum(p)) is not None and s.identifiable for p in pieces
    )
    if not math.isfinite(std):
        total = Estimate(
            "L1+L2",
            value,
            math.nan,
            (-math.inf, math.inf),
            False,
            "m",
            "not determined by the pooled L1 and L2",
        )
    else:
        half = 1.959963984540054 * std
        total = Estimate(
            "L1+L2",
            value,
            std,
            (value - half, value + half),
            ok,
            "m",
            "from the pooled L1, L2 and their covariance",
        )
    return derived_sum(total, pooled.derived)
