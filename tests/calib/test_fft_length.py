"""calib.stats: the FFT length and the autocorrelation built on it."""

from __future__ import annotations

import numpy as np

from calib.stats import autocorrelation, fft_length


def _smooth(m: int) -> bool:
    for p in (2, 3, 5):
        while m % p == 0:
            m //= p
    return m == 1


def test_fft_length_is_the_smallest_5_smooth_length_at_least_n() -> None:
    for n in range(1, 3000):
        m = fft_length(n)
        assert m >= n
        assert _smooth(m)
        assert not any(_smooth(k) for k in range(n, m))


def test_autocorrelation_equals_the_direct_sums() -> None:
    r = np.random.default_rng(3).normal(size=997).cumsum()
    rho = autocorrelation(r, 40)
    c = r - r.mean()
    direct = np.array([c[lag:] @ c[: c.size - lag] for lag in range(41)]) / (c @ c)
    np.testing.assert_allclose(rho, direct, rtol=1e-10, atol=1e-12)
    assert np.all(autocorrelation(np.ones(50), 5) == 0.0)
