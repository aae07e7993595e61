"""calib.smoothing.savgol_filter against scipy.signal.savgol_filter (its reference)."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import savgol_filter as scipy_savgol

from calib.smoothing import savgol_filter


@settings(max_examples=150, deadline=None)
@given(
    n=st.integers(1, 400),
    half=st.integers(0, 25),  # scipy's edge fit (unscaled np.polyfit) loses digits beyond
    polyorder=st.integers(0, 5),
    deriv=st.integers(0, 3),
    delta=st.floats(1e-3, 10.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_matches_scipy_interp_mode(
    n: int, half: int, polyorder: int, deriv: int, delta: float, seed: int
) -> None:
    window = 2 * half + 1
    if window > n or polyorder >= window:
        return
    x = np.cumsum(np.random.default_rng(seed).normal(size=n))
    ours = savgol_filter(x, window, polyorder, deriv=deriv, delta=delta)
    ref = scipy_savgol(x, window, polyorder, deriv=deriv, delta=delta)
    scale = max(float(np.max(np.abs(ref))), 1e-12)
    assert np.max(np.abs(ours - ref)) <= 1e-9 * scale


def test_long_window_edges_match_exact_least_squares() -> None:
    """A 119-point quartic fit: the edges against the fit done in exact rational arithmetic
    (scipy's own edge fit is off by ~1e-8 here: it fits on unscaled positions 0..118)."""
    n, order = 119, 4
    x = np.cumsum(np.random.default_rng(0).normal(size=n))
    A = [[Fraction(k) ** j for j in range(order + 1)] for k in range(n)]
    X = [Fraction(v) for v in x]
    gram = [
        [sum((A[k][i] * A[k][j] for k in range(n)), Fraction(0)) for j in range(order + 1)]
        for i in range(order + 1)
    ]
    rhs = [sum((A[k][i] * X[k] for k in range(n)), Fraction(0)) for i in range(order + 1)]
    coef = _solve_exact(gram, rhs)
    exact = np.array(
        [float(sum(c * Fraction(k) ** j for j, c in enumerate(coef))) for k in range(n)]
    )
    ours = savgol_filter(x, n, order)
    np.testing.assert_allclose(ours, exact, rtol=0, atol=1e-12 * np.max(np.abs(exact)))


def _solve_exact(a: list[list[Fraction]], b: list[Fraction]) -> list[Fraction]:
    m = [[*row, b[i]] for i, row in enumerate(a)]
    size = len(b)
    for i in range(size):
        for j in range(i + 1, size):
            f = m[j][i] / m[i][i]
            m[j] = [m[j][k] - f * m[i][k] for k in range(size + 1)]
    out = [Fraction(0)] * size
    for i in reversed(range(size)):
        out[i] = (m[i][size] - sum(m[i][k] * out[k] for k in range(i + 1, size))) / m[i][i]
    return out


def test_cubic_derivative_is_exact() -> None:
    t = np.arange(300) * 0.01
    x = 2.0 - t + 0.5 * t**2 - 0.25 * t**3
    d1 = savgol_filter(x, 41, 3, deriv=1, delta=0.01)
    np.testing.assert_allclose(d1, -1.0 + t - 0.75 * t**2, atol=1e-9)


@pytest.mark.parametrize(
    ("window", "polyorder", "n", "match"),
    [(4, 2, 10, "odd"), (5, 5, 10, "polyorder"), (11, 2, 10, "longer")],
)
def test_bad_arguments(window: int, polyorder: int, n: int, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        savgol_filter(np.zeros(n), window, polyorder)
