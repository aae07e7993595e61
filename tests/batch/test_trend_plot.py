"""The batch report's trend plot names each log on its x axis (it read "log, in time order
(0 = first)" with numbers), in time order, and keeps its legend off the data."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import polars as pl

from logtools.batch.fleet import fleet_summary
from logtools.batch.plots import log_labels, series_figure
from logtools.batch.table import SCHEMA


def _table(n: int) -> pl.DataFrame:
    t0 = datetime(2026, 1, 1, tzinfo=UTC)
    rows = [
        {
            "log": f"fleet/tt_{i:02d}.mcap",
            "log_id": f"id{i}",
            "robot_id": "r1",
            "robot": "tractor_trailer",
            "start_time": t0 + timedelta(hours=n - i),  # written in reverse time order
            "kind": "estimate",
            "parameter": "L1",
            "value": 1.25 + 0.001 * i,
            "std": 0.002,
            "identifiable": i != 2,
            "unit": "m",
        }
        for i in range(n)
    ]
    return pl.DataFrame(rows, schema_overrides=SCHEMA).select(
        [pl.col(c) if c in rows[0] else pl.lit(None, dtype=t).alias(c) for c, t in SCHEMA.items()]
    )


def test_the_x_axis_names_each_log_in_time_order() -> None:
    import matplotlib.pyplot as plt

    (series,) = fleet_summary(_table(5))
    fig = series_figure(series)
    try:
        (ax,) = fig.get_axes()
        labels = [t.get_text() for t in ax.get_xticklabels()]
        assert labels == ["tt_04", "tt_03", "tt_02", "tt_01", "tt_00"]  # oldest first
        assert ax.get_xlabel() == "log, in time order"
        assert len(ax.get_yticks()) >= 2
        legend = ax.get_legend()
        assert legend.get_bbox_to_anchor().x0 >= ax.get_window_extent().x1  # right of the data
    finally:
        plt.close(fig)


def test_many_logs_name_every_kth() -> None:
    labels = log_labels([f"a/log{i}.mcap" for i in range(50)])
    assert len(labels) == 50
    named = [x for x in labels if x]
    assert named[:2] == ["log0", "log3"]
    assert len(named) <= 24
