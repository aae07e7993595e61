"""Fleet results: each robot's recommended parameters pooled across its logs and followed over
time (drift), from the fleet table's ``estimate`` rows.

A "robot" here is a physical one (``robot_id`` from ``logcal.toml``, default the log's top-level
folder) of one type; its logs are put in time order by their first aligned sample (ties and
logs without a time by path).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import polars as pl

from calib.pooling.drift import DriftResult, detect_drift
from calib.pooling.meta import PooledEstimate, pool_estimates

__all__ = ["ParameterSeries", "fleet_summary"]


@dataclass(frozen=True)
class ParameterSeries:
    """One parameter of one robot over its logs, pooled and tested for drift.

    Attributes:
        robot_id, robot, parameter, unit: what it is.
        logs, log_ids, start_ns, values, stds, identifiable: per log, in time order (all logs
            with an estimate of it, determined or not).
        pooled: the pooled estimate.
        drift: the drift tests on the determined logs.
    """

    robot_id: str
    robot: str
    parameter: str
    unit: str
    logs: list[str]
    log_ids: list[str]
    start_ns: list[int | None]
    values: list[float | None]
    stds: list[float | None]
    identifiable: list[bool | None]
    pooled: PooledEstimate
    drift: DriftResult

    def to_dict(self) -> dict[str, Any]:
        return {
            "robot_id": self.robot_id,
            "robot": self.robot,
            "parameter": self.parameter,
            "unit": self.unit,
            "logs": self.logs,
            "pooled": self.pooled.to_dict(),
            "drift": self.drift.to_dict(),
        }


def fleet_summary(table: pl.DataFrame) -> list[ParameterSeries]:
    """Pool and test every (robot_id, robot type, parameter) of the table's recommended
    estimates; sorted by robot_id, robot, parameter."""
    est = (
        table.filter(pl.col("kind") == "estimate")
        .with_columns(
            pl.col("start_time").dt.epoch("ns").alias("start_ns"),
            pl.col("start_time").is_null().alias("_no_time"),
        )
        .sort(["robot_id", "robot", "parameter", "_no_time", "start_ns", "log"])
    )
    out: list[ParameterSeries] = []
    for key, g in est.group_by(["robot_id", "robot", "parameter"], maintain_order=True):
        robot_id, robot, parameter = (str(k) for k in key)
        unit = next((u for u in g["unit"].to_list() if u), "")
        logs = g["log"].to_list()
        values = g["value"].to_list()
        stds = g["std"].to_list()
        ident = g["identifiable"].to_list()
        start = g["start_ns"].to_list()
        pooled = pool_estimates(parameter, unit, logs, values, stds, ident)
        use = [
            i
            for i in range(len(logs))
            if ident[i] is not False
            and values[i] is not None
            and stds[i] is not None
            and stds[i] > 0
            and start[i] is not None
        ]
        drift = detect_drift(
            [logs[i] for i in use],
            [start[i] for i in use],
            [values[i] for i in use],
            [stds[i] for i in use],
            unit,
        )
        out.append(
            ParameterSeries(
                robot_id,
                robot,
                parameter,
                unit,
                logs,
                g["log_id"].to_list(),
                start,
                values,
                stds,
                ident,
                pooled,
                drift,
            )
        )
    return out
