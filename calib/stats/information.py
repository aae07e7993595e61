"""Information criteria at an effective sample size: the evidence a model's residuals hold
counted at the rate of independent samples, so that correlated samples (a 500 Hz torque, 10 Hz
residuals of a smooth misfit) do not make every candidate effect clear its margin.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

__all__ = ["bic_channels", "bic_gaussian"]


def bic_gaussian(sse: float, n: int, k: int, n_eff: float | None = None) -> float:
    """n_eff ln(sse / n) + k ln(n_eff) (n_eff: at most n; default n); +inf for no samples,
    -inf for a perfect fit."""
    if n <= 0 or not sse > 0:
        return math.inf if n <= 0 else -math.inf
    m = min(float(n), n_eff) if n_eff and n_eff > 0 else float(n)
    return m * math.log(sse / n) + k * math.log(m)


def bic_channels(rss: Mapping[str, float], n: int, factors: Mapping[str, float], k: int) -> float:
    """BIC of several channels with unknown noise variances each: sum_c n_eff,c ln(RSS_c / n)
    + k ln(sum_c n_eff,c), n_eff,c = n x ``factors[c]`` (the per-channel variances are common
    to every model and left out)."""
    total = 0.0
    n_eff_sum = 0.0
    for c, s in rss.items():
        ne = n * factors[c]
        n_eff_sum += ne
        total += ne * math.log(max(s, 1e-300) / n)
    return total + k * math.log(max(n_eff_sum, 2.0))
