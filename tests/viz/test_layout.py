"""Plot limits and forest-plot layout: the bulk of the data stays readable despite outliers."""

from __future__ import annotations

import math

import numpy as np

from calib.tractor_trailer.results import MethodResult
from viz._frame import robust_limits
from viz.tractor_trailer.methods import forest_rows, nice_ticks, robust_range, zoom_range


def test_robust_limits_ignore_a_spike():
    kappa = np.sin(np.linspace(0, 20, 2000)) * 0.2
    kappa[0] = -110.0  # omega / v at standstill
    lo, hi = robust_limits(kappa, np.array([np.nan]))
    assert -0.3 < lo < -0.2
    assert 0.2 < hi < 0.3
    assert robust_limits(np.array([np.nan, 1.0])) is None


def test_robust_range_keeps_truth_and_bulk_in_view():
    vals = [1.24, 1.25, 1.26, 1.27, 1.23, 1.25, 1.26, 1.24, 1.25, 812.0]
    lo, hi = robust_range(vals, truth=1.25)
    assert lo < 1.23
    assert 1.27 < hi < 2.0  # the outlier 812 m is left out of view
    assert robust_range(vals[:3], truth=2.0)[1] > 2.0


def _row(name, fam, l1, l2=2.5, s1=0.01, s2=0.02, cond=10.0, flags=None):
    return MethodResult(name, fam, "all", l1, l2, s1, s2, cond, flags=flags or {})


def test_forest_rows_merge_equal_runs_and_set_apart_the_split():
    rows = forest_rows(
        [
            _row("M13", "CLS", 1.194),
            _row("M14", "CLS", 1.194),
            _row("M15", "CLS", 1.3),
            _row("OLS1(EM1)", "EMLS", 1.2),
            _row("PM", "PMLS", math.nan, math.nan),
            _row("EIV-ML", "EIV", 0.2, flags={"split_determined": False}),
            _row("TLS", "EMLS", 1.21, cond=1e9),
            _row("Transient-path", "TRANSIENT", 1.25),
        ]
    )
    assert [r.label for r in rows] == [
        "OLS1(EM1)",
        "Transient-path",
        "M13–M14",
        "M15",
        "PM",
        "EIV-ML",
        "TLS",
    ]
    assert [r.apart is None for r in rows] == [True, True] + [False] * 5
    assert rows[2].names == ("M13", "M14")
    assert rows[2].label == "M13–M14"
    assert rows[2].apart.startswith("CLS")
    reasons = {r.label: r.apart for r in rows}
    assert reasons["PM"] == "not determined"
    assert reasons["EIV-ML"] == "split not determined"
    assert reasons["TLS"].startswith("ill-conditioned")


def test_zoom_range_shows_a_near_miss_and_the_truth():
    rows = forest_rows([_row("A", "EMLS", 1.253, s1=0.002), _row("B", "EIV", 1.26)])
    lo, hi = zoom_range(1.253, 0.0025, 1.25, rows, "L1")
    assert lo < 1.25 < 1.253 < 1.26 + 0.01 < hi
    assert hi - lo < 0.2  # far narrower than the full range of wild methods
    assert nice_ticks(lo, hi)
    assert all(lo <= t <= hi for t in nice_ticks(lo, hi))
