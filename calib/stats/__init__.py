"""Shared statistics, one name and one meaning across the tree: noise levels read off the data
(``noise``), effective sample sizes (``samples``), autocorrelation-robust covariances
(``hac``), information criteria (``information``), held-out folds (``holdout``). Every
robot's estimators and the discovery engine use these; no room keeps a private copy.
"""

from calib.stats.hac import (
    bartlett_bandwidth,
    bartlett_long_run,
    cube_root_lag,
    hac_covariance,
    long_run_variance_ratio,
    newey_west_rule_lag,
    sandwich,
)
from calib.stats.holdout import alternate_blocks
from calib.stats.information import bic_channels, bic_gaussian
from calib.stats.noise import (
    MAD_TO_STD,
    detect_quantum,
    hf_noise_std,
    hf_noise_std_t,
    local_line_errors,
    mad_std,
)
from calib.stats.samples import (
    autocorrelation,
    effective_samples,
    fft_length,
    lag1_autocorrelation,
    lag1_factor,
)

Z95 = 1.959963984540054
"""The two-sided 95 % quantile of the standard normal distribution."""

__all__ = [
    "MAD_TO_STD",
    "Z95",
    "alternate_blocks",
    "autocorrelation",
    "bartlett_bandwidth",
    "bartlett_long_run",
    "bic_channels",
    "bic_gaussian",
    "cube_root_lag",
    "detect_quantum",
    "effective_samples",
    "fft_length",
    "hac_covariance",
    "hf_noise_std",
    "hf_noise_std_t",
    "lag1_autocorrelation",
    "lag1_factor",
    "local_line_errors",
    "long_run_variance_ratio",
    "mad_std",
    "newey_west_rule_lag",
    "sandwich",
]
