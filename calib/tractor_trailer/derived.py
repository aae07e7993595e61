"""The tractor-trailer's derived quantities on a ``CalibrationResult``: the sum of the link
lengths L1 + L2 (usually far better determined than the split), under its JSON key
``"sum_L1_L2"``. The shared result type knows no robot; this module is where the tractor's
code puts and finds its sum."""

from __future__ import annotations

from collections.abc import Mapping

from calib.results import CalibrationResult, Estimate

__all__ = ["SUM_KEY", "derived_sum", "link_sum"]

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
