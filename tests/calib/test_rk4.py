"""The shared RK4 kernel: the classical amplification factor, recording, resets, batching."""

from __future__ import annotations

import math

import numpy as np

from calib.models.rk4 import rk4_batched, rk4_trajectory


def _decay(y: float, a: float) -> float:
    return -a * y


def test_one_step_is_the_fourth_order_taylor_factor() -> None:
    h, a = 0.3, 1.7
    z = -a * h
    factor = 1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24
    u = [(a,)] * 5
    y = rk4_trajectory(_decay, 2.0, [h] * 5, u, u, u)
    np.testing.assert_allclose(y, 2.0 * factor ** np.arange(6), rtol=1e-14)


def test_inputs_are_taken_at_start_middle_and_end() -> None:
    # y' = u(t) with u linear in t: RK4 (Simpson) integrates it exactly
    t = np.linspace(0.0, 2.0, 9)
    h = np.diff(t).tolist()
    start = [(3.0 * x + 1.0,) for x in t[:-1]]
    mid = [(3.0 * (x + 0.5 * s) + 1.0,) for x, s in zip(t[:-1], h, strict=True)]
    end = [(3.0 * x + 1.0,) for x in t[1:]]
    y = rk4_trajectory(lambda _y, u: u, 0.0, h, start, mid, end)
    np.testing.assert_allclose(y, 1.5 * t**2 + t, rtol=1e-14, atol=1e-14)


def test_keep_and_resets() -> None:
    u = [(1.0,)] * 6
    y = rk4_trajectory(_decay, 1.0, [0.1] * 6, u, u, u, keep=[2, 4, 6], resets={4: 5.0})
    assert y.shape == (4,)
    assert y[2] == 5.0
    step = 1 - 0.1 + 0.1**2 / 2 - 0.1**3 / 6 + 0.1**4 / 24
    assert math.isclose(y[1], step**2, rel_tol=1e-14)
    assert math.isclose(y[3], 5.0 * step**2, rel_tol=1e-14)


def test_batched_equals_each_trajectory() -> None:
    rates = np.array([0.5, 1.0, 3.0])
    u = [(0.2 * k,) for k in range(10)]

    def scalar(y: float, k: float, a: float) -> float:
        return -a * y + math.sin(k)

    def batched(y: np.ndarray, k: float) -> np.ndarray:
        return -rates * y + np.sin(k)

    y = rk4_batched(batched, np.ones(3), [0.1] * 10, u, u, u, keep=range(5, 11, 5))
    assert y.shape == (3, 3)
    for j, a in enumerate(rates):
        ua = [(k, a) for (k,) in u]
        one = rk4_trajectory(scalar, 1.0, [0.1] * 10, ua, ua, ua, keep=[5, 10])
        np.testing.assert_allclose(y[:, j], one, rtol=1e-15)


def test_an_undrivable_path_step_is_refused_not_integrated() -> None:
    """A heading step of 1e6 rad between two samples (a yaw in the wrong unit) would need
    millions of substeps: refused with the reason instead of exhausting time and memory."""
    import numpy as np
    import pytest

    from calib.errors import SolverError
    from calib.models.hitch_path import MAX_SUBSTEPS, rk4_substeps

    L1, L2 = np.array([1.0]), np.array([2.0])
    ok = rk4_substeps(np.full((10, 1), 0.05), np.full((10, 1), 0.1), L1, L2)
    assert 1 <= ok <= MAX_SUBSTEPS
    with pytest.raises(SolverError, match="integration substeps"):
        rk4_substeps(np.full((10, 1), 1e6), np.full((10, 1), 0.1), L1, L2)
    with pytest.raises(SolverError):
        rk4_substeps(np.full((10, 1), np.inf), np.full((10, 1), 0.1), L1, L2)
