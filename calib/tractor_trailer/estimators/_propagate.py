"""Covariance of an output-error fit when the inputs are noisy too.

Input noise enters the simulated joint angle through the (linearised) kinematics as a
low-pass, autocorrelated error. With J the output Jacobian (n, p) and G_u, G_v the linear maps
from per-bin input errors to psi errors, the estimate's covariance is

    H^-1 (J^T S_psi J + (G_u^T J)^T S_u (G_u^T J) + (G_v^T J)^T S_v (G_v^T J)) H^-1,

H = J^T J; G^T J is computed by one backward (adjoint) recursion per parameter.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["adjoint_apply", "propagated_covariance"]

FloatArray = NDArray[np.float64]


def adjoint_apply(a: np.ndarray, b: np.ndarray, x: np.ndarray) -> FloatArray:
    """G^T x for the recursion d_{k+1} = a_k d_k + b_k e_k (d_0 = 0), psi error d = G e.

    Args:
        a: transition factors, shape (n,) (a[k] maps step k to k + 1; the last is unused).
        b: input gains, shape (n,).
        x: shape (n, p).

    Returns:
        shape (n, p): (G^T x)_i = b_i sum_{k > i} (prod_{l=i+1}^{k-1} a_l) x_k.
    """
    n, p = x.shape
    lam = np.zeros((n, p))
    acc = np.zeros(p)
    al = a.tolist()
    for i in range(n - 2, -1, -1):
        acc = x[i + 1] + al[i + 1] * acc
        lam[i] = acc
    return b[:, None] * lam


def propagated_covariance(
    jac: np.ndarray,
    a: np.ndarray,
    b_u: np.ndarray,
    b_v: np.ndarray,
    var_psi: np.ndarray,
    var_u: np.ndarray,
    var_v: np.ndarray,
) -> FloatArray:
    """Parameter covariance from white noise on psi (output) and on the inputs u and v.

    Args:
        jac: d psi_model / d theta at the n grid nodes, shape (n, p) (only the rows used in the
            fit nonzero).
        a, b_u, b_v: linearised dynamics along the fit (see ``adjoint_apply``).
        var_psi, var_u, var_v: per-node noise variances of the binned psi (rad^2), yaw rate
            ((rad/s)^2) and speed ((m/s)^2).

    Returns:
        (p, p) covariance.
    """
    H_inv = np.linalg.pinv(jac.T @ jac)
    M = jac.T @ (var_psi[:, None] * jac)
    gu = adjoint_apply(a, b_u, jac)
    gv = adjoint_apply(a, b_v, jac)
    M += gu.T @ (var_u[:, None] * gu) + gv.T @ (var_v[:, None] * gv)
    cov = H_inv @ M @ H_inv
    return 0.5 * (cov + cov.T)
