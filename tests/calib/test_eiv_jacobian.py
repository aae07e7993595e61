"""The steady-state EIV fit's analytic Jacobian is the derivative of its profiled residual."""

from __future__ import annotations

import numpy as np

from calib.tractor_trailer.estimators.eiv import _g, _profiled_jacobian, project_onto_curve


def test_profiled_jacobian_matches_central_differences() -> None:
    rng = np.random.default_rng(4)
    L1, L2, sk, sp = 1.1, 2.6, 0.004, 0.01
    psi_true = rng.uniform(-0.8, 0.8, 400)
    g, _, _ = _g(psi_true, L1, L2)
    k = g + sk * rng.normal(size=g.size)
    p = psi_true + sp * rng.normal(size=g.size)

    def resid(theta: np.ndarray) -> np.ndarray:
        ph = project_onto_curve(k, p, theta[0], theta[1], sk, sp, n_iter=200)
        gg, _, _ = _g(ph, theta[0], theta[1])
        return np.concatenate([(k - gg) / sk, (p - ph) / sp])

    theta = np.array([1.0, 2.7])
    ph = project_onto_curve(k, p, theta[0], theta[1], sk, sp, n_iter=200)
    J = _profiled_jacobian(k, p, ph, theta[0], theta[1], sk, sp)
    eps = 1e-6
    for j in range(2):
        d = np.eye(2)[j] * eps
        fd = (resid(theta + d) - resid(theta - d)) / (2 * eps)
        np.testing.assert_allclose(J[:, j], fd, rtol=1e-4, atol=1e-4 * np.abs(fd).max())


def test_projection_finds_each_points_closest_curve_point() -> None:
    """Newton's projection against a bounded scalar minimisation of the same per-point cost,
    for points near the curve and far from it (a model far from the data, L2 tiny)."""
    from scipy.optimize import minimize_scalar

    rng = np.random.default_rng(9)
    sk, sp = 0.004, 0.01
    psi_true = rng.uniform(-1.0, 1.0, 60)
    g, _, _ = _g(psi_true, 1.2, 2.5)
    k = g + sk * rng.normal(size=g.size)
    p = psi_true + sp * rng.normal(size=g.size)
    for L1, L2 in ((1.1, 2.6), (4.0, 0.001)):
        ph = project_onto_curve(k, p, L1, L2, sk, sp, n_iter=100)
        for i in range(k.size):

            def cost(q: float, i: int = i, L1: float = L1, L2: float = L2) -> float:
                gq = np.sin(q) / (L2 + L1 * np.cos(q))
                return float(((k[i] - gq) / sk) ** 2 + ((p[i] - q) / sp) ** 2)

            best = minimize_scalar(
                cost, bounds=(-1.5, 1.5), method="bounded", options={"xatol": 1e-12}
            )
            assert cost(float(ph[i])) <= best.fun * (1 + 1e-9) + 1e-12
