"""Pooling of estimates across pieces (time windows of a log, runs, a fleet's logs): the one
pooling engine of the tree.

- :mod:`calib.pooling.gls`: a parameter vector pooled by its covariances (generalised least
  squares, multivariate heterogeneity, random effects).
- :mod:`calib.pooling.meta`: one parameter pooled over logs by inverse variance with Cochran's
  Q (the batch's meta-analysis).
- :mod:`calib.pooling.estimates`: calibration results of pieces pooled into one result (jointly
  by covariance, else each parameter on its own), what windowed and multi-run analysis report.
"""

from calib.pooling.gls import RCOND, Pooled, piece_precision, pool_gls, pool_univariate
from calib.pooling.meta import HETEROGENEITY_ALPHA, PooledEstimate, pool_estimates

__all__ = [
    "HETEROGENEITY_ALPHA",
    "RCOND",
    "Pooled",
    "PooledEstimate",
    "piece_precision",
    "pool_estimates",
    "pool_gls",
    "pool_univariate",
]
