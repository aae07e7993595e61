"""The steady-state EIV fit's analytic Jacobian is the derivative of its profiled residual."""

from __future__ import annotations

import numpy as np

from calib.estimators.eiv import _g, _profiled_jacobian, project_onto_curve


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
