"""Build the shared result dataclasses from an estimator's values and covariance."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from calib.results import CalibrationResult, as_matrix
from calib.tractor_trailer.derived import derived_sum
from calib.tractor_trailer.estimators.identifiability import IdentifiabilityVerdict
from calib.tractor_trailer.results import Family, MethodResult

__all__ = ["calibration_result", "information_criteria", "method_result"]


def information_criteria(rss: float, n: int, k: int) -> tuple[float, float]:
    """Gaussian AIC and BIC from a residual sum of squares over ``n`` residuals, ``k`` params."""
    if n <= 0 or rss <= 0:
        return math.nan, math.nan
    ll = n * math.log(rss / n)
    return ll + 2 * k, ll + k * math.log(n)


def calibration_result(
    method: str,
    verdict: IdentifiabilityVerdict,
    cov: np.ndarray,
    *,
    converged: bool,
    aic: float = math.nan,
    bic: float = math.nan,
    details: Mapping[str, Any] | None = None,
) -> CalibrationResult:
    """A ``CalibrationResult`` for (L1, L2) with covariance ``cov`` (m^2; its leading 2 x 2
    block when the fit has more parameters) and L1 + L2 as a derived quantity."""
    c = np.asarray(cov, dtype=float)
    return CalibrationResult(
        method=method,
        parameters={"L1": verdict.L1, "L2": verdict.L2},
        derived=derived_sum(verdict.sum_L1_L2),
        verdict=verdict.sentence,
        covariance=as_matrix(c[:2, :2]),
        converged=converged,
        aic=aic,
        bic=bic,
        details=dict(details or {}),
    )


def method_result(
    name: str,
    family: Family,
    verdict: IdentifiabilityVerdict,
    *,
    condition_number: float,
    extra: Mapping[str, float] | None = None,
) -> MethodResult:
    """A table row: ``L1_std``/``L2_std`` hold the standard errors of this single fit (there
    are no repeats: ``std_kind`` "standard_error"); ``extra`` holds the sum, its standard
    error and the 95 % bounds, ``flags`` whether the split is determined."""
    e: dict[str, float] = {
        "sum_L1_L2": verdict.sum_L1_L2.value,
        "sum_L1_L2_se": verdict.sum_L1_L2.std,
        "L1_ci95_lo": verdict.L1.ci95[0],
        "L1_ci95_hi": verdict.L1.ci95[1],
        "L2_ci95_lo": verdict.L2.ci95[0],
        "L2_ci95_hi": verdict.L2.ci95[1],
    }
    e.update(extra or {})
    return MethodResult(
        name=name,
        family=family,
        segment="all",
        L1=verdict.L1.value,
        L2=verdict.L2.value,
        L1_std=verdict.L1.std,
        L2_std=verdict.L2.std,
        condition_number=condition_number,
        n_repeats=1,
        extra=e,
        flags={"split_determined": verdict.split_determined},
        std_kind="standard_error",
    )
