"""The hand-written time-series statistics against statsmodels and arch (test-only references).

logcal computes the Ljung-Box statistic, the Newey-West (Bartlett HAC) sandwich covariance and
the Politis-White block length itself (calib imports neither library at run time); here each is
checked against the library that implements the same definition.
"""

from __future__ import annotations

import numpy as np
import pytest

from calib.stats import hac_covariance
from calib.tractor_trailer.discovery.diagnostics import ljung_box
from calib.tractor_trailer.repeats import block_length

sm = pytest.importorskip("statsmodels.api")
diagnostic = pytest.importorskip("statsmodels.stats.diagnostic")
arch_bootstrap = pytest.importorskip("arch.bootstrap")


def _ar1(phi: float, n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0]
    for i in range(1, n):
        x[i] = phi * x[i - 1] + e[i]
    return x


@pytest.mark.parametrize("phi", [0.0, 0.3, 0.9])
@pytest.mark.parametrize("lags", [1, 10, 20])
def test_ljung_box_equals_statsmodels(phi: float, lags: int) -> None:
    x = _ar1(phi, 500, seed=7)
    q, p = ljung_box(x, lags)
    ref = diagnostic.acorr_ljungbox(x, lags=[lags])
    assert q == pytest.approx(float(ref["lb_stat"].iloc[0]), rel=1e-10)
    assert p == pytest.approx(float(ref["lb_pvalue"].iloc[0]), rel=1e-8, abs=1e-300)


@pytest.mark.parametrize("bandwidth", [0, 5, 12, 80])  # 80: the FFT path (>= 64 lags)
def test_hac_covariance_equals_statsmodels_newey_west(bandwidth: int) -> None:
    """OLS with AR(1) errors: our sandwich with the n/(n-p) factor is statsmodels' HAC
    covariance with Bartlett weights and ``use_correction=True``."""
    rng = np.random.default_rng(1)
    n = 400
    X = np.column_stack([np.ones(n), rng.normal(size=n), np.sin(np.arange(n) / 10)])
    y = X @ np.array([1.0, 2.0, 3.0]) + _ar1(0.7, n, seed=2)
    ref = sm.OLS(y, X).fit(cov_type="HAC", cov_kwds={"maxlags": bandwidth, "use_correction": True})
    ours = hac_covariance(X, ref.resid, bandwidth)
    np.testing.assert_allclose(ours, ref.cov_params(), rtol=1e-10)


@pytest.mark.parametrize("phi", [0.5, 0.8])
def test_block_length_agrees_with_arch_on_long_series(phi: float) -> None:
    """Politis & White (2004) with the Patton et al. (2009) correction, circular/moving-block
    constant 4/3. The two differ by design in m-hat (we take the paper's smallest m with K_N
    insignificant lags after it; arch takes the first lag of that run, a window two lags wider)
    and normalise autocorrelations differently, so on a long series (n = 5000, many lags in
    the flat-top window) they agree to within one sample, not exactly."""
    x = _ar1(phi, 5000, seed=3)
    ref = float(arch_bootstrap.optimal_block_length(x)["circular"].iloc[0])
    assert abs(block_length(x) - ref) <= 1.0


def test_block_length_of_white_noise_is_short_in_both() -> None:
    x = np.random.default_rng(4).normal(size=5000)
    ref = float(arch_bootstrap.optimal_block_length(x)["circular"].iloc[0])
    assert ref < 3
    assert block_length(x) <= 3
