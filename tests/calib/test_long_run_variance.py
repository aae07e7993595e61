"""calib.stats.long_run_variance_ratio against statsmodels' Bartlett HAC (a test-only
reference): the same long-run variance over the plain variance, on correlated and on
alternating series, and 1.0 where there is too little to say."""

from __future__ import annotations

import numpy as np
import pytest
from statsmodels.stats.sandwich_covariance import S_hac_simple

from calib.stats import long_run_variance_ratio


def _ar1(phi: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0]
    for i in range(1, n):
        x[i] = phi * x[i - 1] + e[i]
    return x - x.mean()


@pytest.mark.parametrize(("phi", "n", "seed"), [(0.6, 500, 0), (-0.5, 300, 1), (0.0, 64, 2)])
def test_matches_statsmodels_bartlett_hac(phi: float, n: int, seed: int) -> None:
    x = _ar1(phi, n, seed)
    lag = max(1, round(n ** (1 / 3)))
    reference = float(S_hac_simple(x[:, None], nlags=lag)[0, 0]) / n / (float(x @ x) / n)
    assert long_run_variance_ratio(x) == pytest.approx(reference, rel=1e-12)


def test_positively_correlated_above_one_alternating_below() -> None:
    assert long_run_variance_ratio(_ar1(0.6, 500, 0)) > 1.5
    assert long_run_variance_ratio(_ar1(-0.5, 500, 1)) < 0.7


def test_too_short_or_zero_is_one() -> None:
    assert long_run_variance_ratio(np.arange(7.0) - 3.0) == 1.0
    assert long_run_variance_ratio(np.zeros(50)) == 1.0
