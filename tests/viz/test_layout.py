"""Plot limits and forest-plot layout: the bulk of the data stays readable despite outliers."""

from __future__ import annotations

import math

import numpy as np

from calib.results import MethodResult
from viz._frame import robust_limits
from viz.methods import forest_layout


def test_robust_limits_ignore_a_spike():
    kappa = np.sin(np.linspace(0, 20, 2000)) * 0.2
    kappa[0] = -110.0  # omega / v at standstill
    lo, hi = robust_limits(kappa, np.array([np.nan]))
    assert -0.3 < lo < -0.2
    assert 0.2 < hi < 0.3
    assert robust_limits(np.array([np.nan, 1.0])) is None


def test_forest_layout_keeps_truth_and_bulk_in_view():
    vals = [1.24, 1.25, 1.26, 1.27, 1.23, 1.25, 1.26, 1.24, 1.25, 812.0]
    rows = [
        MethodResult(f"M{i}", "CLS", "all", v, 2.5, 0.01, 0.02, math.nan)
        for i, v in enumerate(vals)
    ]
    lay = forest_layout(rows, "L1", truth=1.25)
    lo, hi = lay.x_range
    assert lo < 1.22
    assert 1.28 < hi < 2.0  # the outlier 812 m is left out of view
    assert lay.y_range == (-lay.dy, len(rows) * lay.dy)
    lay = forest_layout(rows[:3], "L1", truth=2.0)
    assert lay.x_range[1] > 2.0
