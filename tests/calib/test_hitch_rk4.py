"""The compiled joint-angle RK4 loop against its numpy reference and against calculus."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from calib.tractor_trailer.discovery.effects.actuator_lag import first_order_lag
from calib.tractor_trailer.models import hitch_rk4
from calib.tractor_trailer.models.hitch_rk4 import (
    compiled_available,
    rk4_hitch,
    rk4_hitch_sensitivities,
)


def test_the_compiled_loop_is_built() -> None:
    # `pip install -e .` builds it; without it every fit runs ~25x slower on the numpy loop
    assert compiled_available(), (
        "calib/tractor_trailer/models/_hitch_rk4.c was not built: run pip install -e ."
    )


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 60),
    series=st.integers(1, 3),
    m=st.integers(1, 3),
    seed=st.integers(0, 2**31 - 1),
    every=st.integers(1, 4),
)
def test_compiled_equals_reference(n: int, series: int, m: int, seed: int, every: int) -> None:
    """Bit for bit with one parameter set (libm's sin and cos in both); several sets run
    together on the vectorised sin/cos, a few units in the last place from libm's."""
    rng = np.random.default_rng(seed)
    h = rng.uniform(0.001, 0.3, n)
    U, V = rng.normal(size=(2, series, n, 3))
    p0, p1, p2 = rng.normal(size=(3, m))
    y0 = rng.normal(size=(series, m))
    keep = list(range(every, n + 1, every))
    resets = {k: float(rng.normal()) for k in keep[::3]}
    a = rk4_hitch(h, U, V, p0, p1, p2, y0, keep=keep, resets=resets)
    b = rk4_hitch(h, U, V, p0, p1, p2, y0, keep=keep, resets=resets, reference=True)
    assert a.shape == (1 + len(keep), series, m)
    _same(a, b, exact=m == 1)
    chain = np.array([-1] + [int(rng.integers(-1, i)) for i in range(1, series)])
    ca = rk4_hitch(h, U, V, p0, p1, p2, y0, keep=keep, chain=chain)
    cb = rk4_hitch(h, U, V, p0, p1, p2, y0, keep=keep, chain=chain, reference=True)
    _same(ca, cb, exact=m == 1)


def _same(a: np.ndarray, b: np.ndarray, *, exact: bool) -> None:
    if exact:
        np.testing.assert_array_equal(a, b)
    else:
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def test_batches_beyond_the_fast_range_or_with_nan_are_redone_with_libm() -> None:
    rng = np.random.default_rng(5)
    n, m = 50, 9
    h = rng.uniform(0.01, 0.1, n)
    U, V = rng.normal(size=(2, 1, n, 3))
    p0, p1, p2 = rng.normal(size=(3, m))
    for y0 in (np.full((1, m), 3e5), np.where(np.arange(m) == 4, np.nan, 0.1)[None, :]):
        a = rk4_hitch(h, U, V, p0, p1, p2, y0)
        b = rk4_hitch(h, U, V, p0, p1, p2, y0, reference=True)
        np.testing.assert_array_equal(a, b)  # libm in both: the same bits, NaN where NaN


def test_fourth_order_on_an_exact_solution() -> None:
    # dy/dx = -sin y (U = 0, V = 1, p2 = 1): tan(y/2) = tan(y0/2) exp(-x)
    y0, x_end = 1.0, 2.0

    def error(n: int) -> float:
        h = np.full(n, x_end / n)
        y = rk4_hitch(h, np.zeros((n, 3)), np.ones((n, 3)), 0.0, 0.0, 1.0, y0)[-1, 0, 0]
        return abs(y - 2.0 * math.atan(math.tan(y0 / 2.0) * math.exp(-x_end)))

    ratio = error(20) / error(40)
    assert 14.0 < ratio < 18.0  # halving h divides the error by 2^4


def test_chained_chunks_are_one_trajectory() -> None:
    rng = np.random.default_rng(3)
    hs = rng.uniform(0.01, 0.05, 100)  # steps are shared by all series: each chunk has these
    h = np.tile(hs, 3)
    U, V = rng.normal(size=(2, 300, 3))
    whole = rk4_hitch(h, U, V, 1.0, 0.6, 0.5, 0.2)[:, 0, 0]
    # series: chunk 0, chunk 1 (continues 0), another run's chunk, chunk 2 (continues 1)
    other_u, other_v = rng.normal(size=(2, 100, 3))
    Us = np.stack([U[:100], U[100:200], other_u, U[200:]])
    Vs = np.stack([V[:100], V[100:200], other_v, V[200:]])
    y0 = np.array([[0.2], [9.0], [0.1], [9.0]])  # rows of continuing chunks are ignored
    out = rk4_hitch(hs, Us, Vs, 1.0, 0.6, 0.5, y0, chain=np.array([-1, 0, -1, 1]))
    joined = np.concatenate([out[:, 0, 0], out[1:, 1, 0], out[1:, 3, 0]])
    np.testing.assert_array_equal(joined, whole)
    alone = rk4_hitch(hs, other_u, other_v, 1.0, 0.6, 0.5, 0.1)[:, 0, 0]
    np.testing.assert_array_equal(out[:, 2, 0], alone)
    with pytest.raises(ValueError, match="chain"):
        rk4_hitch(hs, Us, Vs, 1.0, 0.6, 0.5, y0, chain=np.array([-1, 2, -1, 1]))


def test_sensitivities_are_the_derivatives_of_the_map() -> None:
    rng = np.random.default_rng(11)
    n = 240
    h = rng.uniform(0.01, 0.05, n)
    U, V = rng.normal(size=(2, 3, n, 3))
    p = [np.array([1.0, 0.8]), np.array([0.5, 0.3]), np.array([0.4, 0.6])]
    y0 = rng.normal(size=(3, 2))
    kw = {"keep": range(3, n + 1, 3), "chain": np.array([-1, 0, -1])}
    S = rk4_hitch_sensitivities(h, U, V, *p, y0, **kw)
    np.testing.assert_array_equal(S, rk4_hitch_sensitivities(h, U, V, *p, y0, **kw, reference=True))
    _same(S[..., 0], rk4_hitch(h, U, V, *p, y0, **kw), exact=False)
    eps = 1e-6
    for q in range(4):  # y0, p0, p1, p2
        d = np.eye(4)[q] * eps
        up = rk4_hitch(h, U, V, p[0] + d[1], p[1] + d[2], p[2] + d[3], y0 + d[0], **kw)
        dn = rk4_hitch(h, U, V, p[0] - d[1], p[1] - d[2], p[2] - d[3], y0 - d[0], **kw)
        np.testing.assert_allclose(S[..., q + 1], (up - dn) / (2 * eps), atol=1e-7)


def test_a_reset_sets_the_state() -> None:
    n = 10
    out = rk4_hitch(
        np.full(n, 0.1), np.ones((n, 3)), np.ones((n, 3)), 1.0, 0.0, 0.0, 0.0, resets={4: 5.0}
    )
    # dy/dx = 1: y = x until the reset after step 4, then 5 + (x - 0.4)
    np.testing.assert_allclose(out[:, 0, 0], [0, 0.1, 0.2, 0.3, 5.0, 5.1, 5.2, 5.3, 5.4, 5.5, 5.6])


def test_lag_recursion_compiled_matches_the_loop_and_the_closed_form() -> None:
    rng = np.random.default_rng(5)
    a = rng.uniform(0.0, 1.0, 500)
    u = rng.normal(size=500)
    y = hitch_rk4.lag_recursion(a, u, 0.3)
    ref = [0.3]
    for ak, uk in zip(a, u, strict=True):
        ref.append(ak * ref[-1] + uk)
    np.testing.assert_array_equal(y, ref)
    # first-order lag of a ramp x = t from y(0) = 0 is t - tau (1 - exp(-t / tau)) exactly
    t = np.cumsum(rng.uniform(0.001, 0.2, 300))
    t -= t[0]
    tau = 0.37
    np.testing.assert_allclose(
        first_order_lag(t, t, tau), t - tau * (1.0 - np.exp(-t / tau)), atol=1e-12
    )
