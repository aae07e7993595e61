"""Linear least squares with condition numbers: OLS1 (output error), OLS2 (input error), TLS.

Estimator style: ``OLS1().fit(A, y).beta_``; all share ``LeastSquares`` and differ in ``_solve``.
"""

from calib.lsq.base import LeastSquares, Solution, triangular_factor, triangular_factor_by_rows
from calib.lsq.ols import OLS1, OLS2
from calib.lsq.tls import TLS, tls_condition_number

__all__ = [
    "OLS1",
    "OLS2",
    "TLS",
    "LeastSquares",
    "Solution",
    "tls_condition_number",
    "triangular_factor",
    "triangular_factor_by_rows",
]
