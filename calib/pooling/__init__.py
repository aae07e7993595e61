"""Pooling of estimates across pieces (time windows of a log, runs, a fleet's logs): the one
pooling engine of the tree.

- :mod:`calib.pooling.gls`: a parameter vector pooled by its covariances (generalised least
  squares, multivariate heterogeneity, random effects).
- :mod:`calib.pooling.meta`: one parameter pooled over logs by inverse variance with Cochran's
  Q (the batch's meta-analysis).
- :mod:`calib.pooling.drift`: one parameter over a robot's logs in time order: a step change
  and a linear trend, tested with the per-log standard errors (the batch's drift).
- :mod:`calib.pooling.estimates`: calibration results of pieces pooled into one result (jointly
  by covariance, else each parameter on its own), what windowed and multi-run analysis report.
"""

from calib.pooling.drift import DriftResult, detect_drift
from calib.pooling.gls import RCOND, Pooled, piece_precision, pool_gls, pool_univariate
from calib.pooling.meta import HETEROGENEITY_ALPHA, PooledEstimate, pool_estimates

__all__ = [
    "HETEROGENEITY_ALPHA",
    "RCOND",
    "DriftResult",
    "Pooled",
    "PooledEstimate",
    "detect_drift",
    "piece_precision",
    "pool_estimates",
    "pool_gls",
    "pool_univariate",
]
