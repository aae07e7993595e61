"""One estimate per robot and parameter across its logs: inverse-variance weighting, with
Cochran's Q test of whether the logs agree within their stated uncertainty.

Why not the robot plugin's own pool (``RobotPlugin.pool``, e.g. the tractor-trailer's joint
refit of every run)? It needs every loaded log in one process, which a batch spread over
processes or machines does not have; the per-log estimates and their standard errors are enough
for the classical meta-analysis below. Each parameter is pooled on its own (correlations
between parameters of one log, e.g. L1 and L2, are not used).

- Logs whose estimate is not determined (``identifiable`` false, or no finite positive std) are
  left out and named.
- Fixed effect: w_i = 1/s_i^2, value = sum w_i x_i / sum w_i, std = 1/sqrt(sum w_i).
- Heterogeneity: Q = sum w_i (x_i - value)^2 ~ chi^2(k-1) when every log measures the same
  value with its stated std; I^2 = max(0, (Q - (k-1))/Q). When p(Q) < ``HETEROGENEITY_ALPHA``
  the logs disagree (a part that changed, a std that is too small): the reported value is then
  the DerSimonian-Laird random-effects mean (weights 1/(s_i^2 + tau^2)), whose interval
  includes the between-log spread, and ``heterogeneous`` is set; look at the drift analysis.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from calib.results import Estimate, json_safe

__all__ = ["HETEROGENEITY_ALPHA", "PooledEstimate", "pool_estimates"]

HETEROGENEITY_ALPHA = 0.05
"""Level of Cochran's Q test above which the logs count as agreeing."""


@dataclass(frozen=True)
class PooledEstimate:
    """A parameter pooled over one robot's logs.

    Attributes:
        estimate: the pooled value with std and 95 % interval (not determined: no log
            determined it).
        method: ``single log``, ``inverse-variance (fixed effect)`` or ``random effects
            (DerSimonian-Laird)`` (used when the logs disagree).
        n_logs: logs pooled.
        left_out: logs whose estimate was not determined, with why.
        q, df, p_heterogeneity: Cochran's Q, its degrees of freedom and p-value (None: fewer
            than two logs).
        i2: share of the spread beyond the stated uncertainties (0..1).
        tau: between-log standard deviation (random-effects; 0 when they agree).
        heterogeneous: p_heterogeneity < HETEROGENEITY_ALPHA.
    """

    estimate: Estimate
    method: str
    n_logs: int
    left_out: list[str] = field(default_factory=list)
    q: float | None = None
    df: int | None = None
    p_heterogeneity: float | None = None
    i2: float | None = None
    tau: float | None = None
    heterogeneous: bool = False

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "estimate": self.estimate.to_dict(),
                "method": self.method,
                "n_logs": self.n_logs,
                "left_out": self.left_out,
                "q": self.q,
                "df": self.df,
                "p_heterogeneity": self.p_heterogeneity,
                "i2": self.i2,
                "tau": self.tau,
                "heterogeneous": self.heterogeneous,
            }
        )


def _usable(value: float | None, std: float | None, identifiable: bool | None) -> bool:
    return (
        identifiable is not False
        and value is not None
        and std is not None
        and math.isfinite(value)
        and math.isfinite(std)
        and std > 0
    )


def pool_estimates(
    name: str,
    unit: str,
    logs: Sequence[str],
    values: Sequence[float | None],
    stds: Sequence[float | None],
    identifiable: Sequence[bool | None],
) -> PooledEstimate:
    """Pool one parameter over logs (see the module docstring)."""
    keep = [i for i in range(len(logs)) if _usable(values[i], stds[i], identifiable[i])]
    left_out = [f"{logs[i]}: not determined by this log" for i in range(len(logs)) if i not in keep]
    if not keep:
        return PooledEstimate(
            Estimate(
                name,
                math.nan,
                math.nan,
                (math.nan, math.nan),
                identifiable=False,
                unit=unit,
                note="no log determines it",
            ),
            "none",
            0,
            left_out,
        )
    x = np.array([values[i] for i in keep], dtype=float)
    s = np.array([stds[i] for i in keep], dtype=float)
    w = 1.0 / s**2
    mean = float(np.sum(w * x) / np.sum(w))
    std = float(1.0 / math.sqrt(np.sum(w)))
    k = len(keep)
    if k == 1:
        return PooledEstimate(
            Estimate(
                name, mean, std, (mean - 1.96 * std, mean + 1.96 * std), unit=unit, note="one log"
            ),
            "single log",
            1,
            left_out,
        )
    q = float(np.sum(w * (x - mean) ** 2))
    df = k - 1
    p = float(stats.chi2.sf(q, df))
    i2 = max(0.0, (q - df) / q) if q > 0 else 0.0
    c = float(np.sum(w) - np.sum(w**2) / np.sum(w))
    tau2 = max(0.0, (q - df) / c) if c > 0 else 0.0
    heterogeneous = p < HETEROGENEITY_ALPHA
    method = "inverse-variance (fixed effect)"
    note = f"{k} logs agree within their stated uncertainty (Cochran's Q p = {p:.2g})"
    if heterogeneous:
        wr = 1.0 / (s**2 + tau2)
        mean = float(np.sum(wr * x) / np.sum(wr))
        std = float(1.0 / math.sqrt(np.sum(wr)))
        method = "random effects (DerSimonian-Laird)"
        note = (
            f"the {k} logs disagree beyond their stated uncertainty (Cochran's Q "
            f"p = {p:.2g}, I2 = {100 * i2:.0f} %, between-log std {math.sqrt(tau2):.3g} "
            f"{unit}): a part that changed or wore? see the drift over time"
        )
    return PooledEstimate(
        Estimate(name, mean, std, (mean - 1.96 * std, mean + 1.96 * std), unit=unit, note=note),
        method,
        k,
        left_out,
        q,
        df,
        p,
        i2,
        math.sqrt(tau2),
        heterogeneous,
    )
