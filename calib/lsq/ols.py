"""Ordinary least squares: OLS1 puts the fitting error on the output, OLS2 on one input."""

from __future__ import annotations

import numpy as np

from calib.errors import InsufficientDataError, SolverError
from calib.lsq.base import FloatArray, LeastSquares, Solution, ols_on_factor

__all__ = ["OLS1", "OLS2"]


def _ols_condition(sv: FloatArray) -> float:
    """μ1/μn; for one column the patent's observability index is μ1 itself."""
    return float(sv[0]) if sv.size == 1 else float(sv[0] / sv[-1])


class OLS1(LeastSquares):
    """Output-error least squares, β = (AᵀA)⁻¹Aᵀy (patent eq. 3-8).

    ``condition_number_`` is μ1/μn of A; with one column (μ1/μ1 = 1 says nothing) it is μ1, the
    singular value the patent prints for PM1.
    """

    name = "OLS1"

    def _solve(self, M: FloatArray) -> Solution:
        beta, sv = ols_on_factor(M, self.name)
        return Solution(beta, _ols_condition(sv), sv)


class OLS2(LeastSquares):
    """Input-error least squares: regress one input on the others and the output, then invert.

    For the line y = a x + b (A = [x 1]) it is the patent's OLS2: x = y/a − b/a is fitted as
    β' = [1/a, −b/a] and inverted. In general, with ``column`` = j, A_j is regressed on
    [y, A_others]: A_j = (1/β_j) y − Σ_k (β_k/β_j) A_k, giving β' = [1/β_j, −β_k/β_j ...].
    ``condition_number_`` is that of the swapped regressor matrix (μ1/μn, or μ1 for one column).
    ``extra_["beta_prime"]`` holds β'.

    Args:
        column: index of the input carrying the error (default 0, the line's x).
    """

    name = "OLS2"

    def __init__(self, column: int = 0) -> None:
        self.column = column

    def _solve(self, M: FloatArray) -> Solution:
        n = M.shape[1] - 1
        j = self.column
        if not 0 <= j < n:
            raise InsufficientDataError(f"OLS2: column {j} out of range for {n} regressors")
        others = [k for k in range(n) if k != j]
        swapped = M[:, [n, *others, j]]
        beta_p, sv = ols_on_factor(swapped, self.name)
        if beta_p[0] == 0.0:
            raise SolverError("OLS2: the output does not explain the input (1/β_j = 0)")
        beta = np.empty(n)
        beta[j] = 1.0 / beta_p[0]
        beta[others] = -beta_p[1:] * beta[j]
        return Solution(beta, _ols_condition(sv), sv, {"beta_prime": beta_p})

    def __repr__(self) -> str:
        return f"OLS2(column={self.column})"
