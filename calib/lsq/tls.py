"""Total least squares (orthogonal distance) via the SVD of C = [A y]."""

from __future__ import annotations

import numpy as np

from calib.errors import SolverError
from calib.lsq.base import FloatArray, LeastSquares, Solution

__all__ = ["TLS", "tls_condition_number"]


def tls_condition_number(sv: FloatArray, V: FloatArray, beta: FloatArray) -> float:
    """Jia & Li (arXiv:1101.2342) condition number of the TLS problem.

    ‖V11⁻ᵀ diag(s_1..s_n)‖₂ · √(‖β‖² + 1), s_i = √(μ_i² + μ_{n+1}²) / (μ_i² − μ_{n+1}²), with μ
    the singular values of C and V11 the leading n x n block of its right singular vectors.
    An absolute condition number: it grows as 1/√p with fewer samples p. The patent prints μ_1
    and no squares in the denominator; this form reproduces its Fig. 8 (METHODS.md).

    Args:
        sv: singular values of C, descending, length n + 1.
        V: right singular vectors of C as columns, (n + 1) x (n + 1).
        beta: the TLS solution, length n.
    """
    n = sv.size - 1
    mu_last2 = sv[-1] ** 2
    denom = sv[:n] ** 2 - mu_last2
    if np.any(denom <= 0.0):
        return float("inf")
    s = np.sqrt(sv[:n] ** 2 + mu_last2) / denom
    V11 = V[:n, :n]
    try:
        K = np.linalg.solve(V11.T, np.diag(s))
    except np.linalg.LinAlgError:
        return float("inf")
    return float(np.linalg.norm(K, 2) * np.sqrt(beta @ beta + 1.0))


class TLS(LeastSquares):
    """Total least squares: β = −V12 V22⁻¹ from C = [A y] = U Σ Vᵀ (patent eq. 14-16).

    ``condition_number_`` is the Jia–Li form (``tls_condition_number``); ``singular_values_``
    are those of C.
    """

    name = "TLS"

    def _solve(self, M: FloatArray) -> Solution:
        _, sv, Vt = np.linalg.svd(M)
        V = Vt.T
        n = M.shape[1] - 1
        v22 = V[n, n]
        if abs(v22) <= np.finfo(float).eps * 16 or (sv.size > 1 and sv[-2] == sv[-1]):
            raise SolverError(
                "TLS: no unique solution (V22 is singular or the smallest singular value of "
                f"[A y] is repeated; singular values {sv.tolist()})"
            )
        beta = -V[:n, n] / v22
        return Solution(beta, tls_condition_number(sv, V, beta), sv)
