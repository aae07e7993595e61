"""Identifiability verdicts from a covariance (or Fisher information) of link lengths.

A quantity counts as *determined* when its 95 % interval half-width is at most ``rel_tol`` of
its value. For a steady-state log the sum L1 + L2 is usually determined and the split is not
(METHODS.md, section 1); the verdict says so in a sentence people can act on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from calib.errors import SolverError
from calib.results import Estimate, JsonRecord

__all__ = ["Z95", "IdentifiabilityVerdict", "identifiability", "make_estimate", "undetermined"]


def undetermined(e: Estimate, reason: str) -> Estimate:
    """``e`` reported as not determined, for ``reason``: no interval, the value kept only as
    what the fit said."""
    return Estimate(e.name, e.value, math.nan, (-math.inf, math.inf), False, e.unit, reason)


Z95 = 1.959963984540054

_ADVICE = (
    "widen the curvature range (larger |kappa|, hence larger joint angles), lower the sensor "
    "noise, or use the transient fit (log speed and the joint angle while the curvature changes)"
)


def make_estimate(
    name: str,
    value: float,
    std: float,
    *,
    rel_tol: float,
    note: str = "",
    unit: str = "m",
    scale: float = 0.0,
    force_undetermined: bool = False,
) -> Estimate:
    """An ``Estimate`` with a Wald 95 % interval, determined when
    1.96 std <= rel_tol max(|value|, scale) (``scale``: a size below which the relative rule
    would be unfair, e.g. for a value near zero). ``force_undetermined``: e.g. on a bound; the
    interval is then reported unbounded rather than narrow."""
    half = Z95 * std
    ok = bool(np.isfinite(std) and np.isfinite(value) and half <= rel_tol * max(abs(value), scale))
    if force_undetermined:
        return Estimate(
            name,
            float(value),
            math.nan,
            (-math.inf, math.inf),
            False,
            unit,
            (note + "; " if note else "") + "on a bound of the fit: not determined",
        )
    return Estimate(name, float(value), float(std), (value - half, value + half), ok, unit, note)


@dataclass(frozen=True)
class IdentifiabilityVerdict(JsonRecord):
    """What one log determines about (L1, L2).

    Attributes:
        L1, L2, sum_L1_L2: estimates (m) with 95 % intervals and ``identifiable`` flags.
        split_determined: both L1 and L2 are determined.
        sum_determined: L1 + L2 is determined.
        correlation: correlation coefficient of the L1 and L2 estimates.
        best_direction: unit vector (a, b) of the best-determined combination a L1 + b L2.
        sentence: the verdict for people.
    """

    L1: Estimate
    L2: Estimate
    sum_L1_L2: Estimate
    split_determined: bool
    sum_determined: bool
    correlation: float
    best_direction: tuple[float, float]
    sentence: str
    details: dict[str, Any] = field(default_factory=dict)


def _pm(e: Estimate) -> str:
    return f"{e.value:.3f} m [{e.ci95[0]:.3f}, {e.ci95[1]:.3f}]"


def _interval(e: Estimate) -> str:
    lo, hi = e.ci95
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return "unbounded (the fit ran onto a bound)"
    return f"[{lo:.2f}, {hi:.2f}] m"


def _sentence(l1: Estimate, l2: Estimate, s: Estimate, advice: str) -> str:
    if l1.identifiable and l2.identifiable:
        return f"This log determines L1 = {_pm(l1)} and L2 = {_pm(l2)} (95 %); L1 + L2 = {_pm(s)}."
    if s.identifiable:
        return (
            f"This log determines L1 + L2 = {_pm(s)} (95 %); the split is not determined "
            f"(L1 anywhere in {_interval(l1)} is consistent with it): "
            f"{advice}."
        )
    return (
        f"This log determines neither L1 + L2 (95 % interval {_interval(s)}) "
        f"nor the split: {advice}."
    )


def _std_ratio(var_dir: np.ndarray) -> float:
    """Ratio of the worst to the best standard deviation over directions (inf if singular)."""
    lo = float(var_dir.min())
    return float(np.sqrt(var_dir.max() / lo)) if lo > 0 else float("inf")


def identifiability(
    fisher_or_cov: np.ndarray,
    values: tuple[float, float],
    *,
    is_fisher: bool = False,
    rel_tol: float = 0.1,
    method: str = "",
    advice: str = _ADVICE,
    scale: float = 0.0,
    not_determined: Sequence[str] = (),
) -> IdentifiabilityVerdict:
    """Verdict on (L1, L2) from their 2 x 2 covariance (m^2) or Fisher information (1/m^2).

    Args:
        fisher_or_cov: covariance of (L1, L2), or their Fisher information if ``is_fisher``.
        values: estimated (L1, L2) in m.
        is_fisher: interpret the matrix as Fisher information (a singular one means an
            undetermined direction: infinite variance along it).
        rel_tol: a quantity is determined when its 95 % half-width <= rel_tol |value|.
        method: name of the estimator, put in each estimate's note.
        advice: what to do when something is not determined (ends the sentence).
        scale: absolute size (m) for the relative rule (see ``make_estimate``): L1 near zero
            (a hitch on the axle) is judged against the robot's size, not against itself.
        not_determined: names ("L1", "L2") known not to be determined (e.g. on a bound).

    Returns:
        The verdict with estimates of L1, L2 and L1 + L2.

    Raises:
        SolverError: the matrix is not 2 x 2 or not finite.
    """
    m = np.asarray(fisher_or_cov, dtype=float)
    if m.shape != (2, 2) or not np.all(np.isfinite(m)):
        raise SolverError(f"identifiability needs a finite 2 x 2 matrix for (L1, L2), got {m!r}")
    m = 0.5 * (m + m.T)
    w, V = np.linalg.eigh(m)
    if is_fisher:
        inv_w = np.where(w > 1e-12 * max(w.max(), 1e-300), 1.0 / np.maximum(w, 1e-300), np.inf)
        var_dir = inv_w
    else:
        var_dir = np.maximum(w, 0.0)

    # variance of a^T theta = sum_k (a . v_k)^2 var_k, with inf * 0 treated as 0
    def var_of(a: np.ndarray) -> float:
        proj = (V.T @ a) ** 2
        used = proj > 1e-15
        return float(np.sum(proj[used] * var_dir[used]))

    v1, v2 = float(values[0]), float(values[1])
    sd1 = np.sqrt(var_of(np.array([1.0, 0.0])))
    sd2 = np.sqrt(var_of(np.array([0.0, 1.0])))
    sds = np.sqrt(var_of(np.array([1.0, 1.0])))
    note = f"{method}: Wald 95 % interval" if method else "Wald 95 % interval"
    nd = set(not_determined)
    l1 = make_estimate(
        "L1", v1, sd1, rel_tol=rel_tol, note=note, scale=scale, force_undetermined="L1" in nd
    )
    l2 = make_estimate(
        "L2", v2, sd2, rel_tol=rel_tol, note=note, scale=scale, force_undetermined="L2" in nd
    )
    s = make_estimate(
        "L1+L2", v1 + v2, sds, rel_tol=rel_tol, note=note, scale=scale, force_undetermined=bool(nd)
    )
    corr = float(m[0, 1] / np.sqrt(m[0, 0] * m[1, 1])) if m[0, 0] * m[1, 1] > 0 else float("nan")
    if is_fisher and np.isfinite(corr):
        corr = -corr
    best = V[:, int(np.argmin(var_dir))]
    best = best * np.sign(best[np.argmax(np.abs(best))])
    split_ok = l1.identifiable and l2.identifiable
    return IdentifiabilityVerdict(
        l1,
        l2,
        s,
        split_ok,
        s.identifiable,
        corr,
        (float(best[0]), float(best[1])),
        _sentence(l1, l2, s, advice),
        {"rel_tol": rel_tol, "std_ratio": _std_ratio(var_dir)},
    )
