"""The fleet table: one row per log x estimator x parameter, one per discovered effect, one per
failed log; one Parquet file that polars, DuckDB or pandas read.

Rows are built from each log's JSON (``AnalysisResult.to_dict()``), not from result objects, so
that logs finished by an earlier run (not re-analysed) contribute alike, and so that any robot's
result is read the same way: a parameter is any ``{"value", "std", ...}`` entry (an
``Estimate``) of the recommended estimate or of a method; the tractor-trailer's method-table rows
(``MethodResult``: ``L1``, ``L1_std``, ...) are read by their own shape, and their ``std`` is the
spread over bootstrap repeats (``std_kind`` says which).

Columns: ``log`` (path in the archive), ``log_id``, ``robot_id`` (the physical robot),
``robot`` (type), ``start_time`` (UTC, the log's first aligned sample; null when unknown),
``kind`` (``estimate`` | ``method`` | ``effect`` | ``failure``), ``estimator``, ``segment``,
``parameter``, ``value``, ``std``, ``ci95_lo``, ``ci95_hi``, ``identifiable``, ``unit``,
``std_kind``, ``note``, ``detail`` (JSON text: an effect's parameters and evidence) and
``error`` (a failed log's message). Numbers that are not finite are null, never NaN.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import polars as pl

__all__ = ["SCHEMA", "fleet_rows", "fleet_table", "parameter_rows", "write_parquet"]

SCHEMA: dict[str, Any] = {
    "log": pl.String,
    "log_id": pl.String,
    "robot_id": pl.String,
    "robot": pl.String,
    "start_time": pl.Datetime("us", "UTC"),
    "kind": pl.String,
    "estimator": pl.String,
    "segment": pl.String,
    "parameter": pl.String,
    "value": pl.Float64,
    "std": pl.Float64,
    "ci95_lo": pl.Float64,
    "ci95_hi": pl.Float64,
    "identifiable": pl.Boolean,
    "unit": pl.String,
    "std_kind": pl.String,
    "note": pl.String,
    "detail": pl.String,
    "error": pl.String,
}

_STD_ERROR = "standard error"
_SPREAD = "spread over bootstrap repeats"


def _num(x: Any) -> float | None:
    if isinstance(x, bool) or not isinstance(x, int | float):
        return None
    return float(x) if math.isfinite(x) else None


def _is_estimate(d: Any) -> bool:
    return isinstance(d, Mapping) and "value" in d and "std" in d


def _estimate_row(name: str, d: Mapping[str, Any], **extra: Any) -> dict[str, Any]:
    ci = d.get("ci95") or [None, None]
    return {
        "parameter": str(d.get("name") or name),
        "value": _num(d.get("value")),
        "std": _num(d.get("std")),
        "ci95_lo": _num(ci[0]),
        "ci95_hi": _num(ci[1]),
        "identifiable": bool(d.get("identifiable", True)),
        "unit": d.get("unit"),
        "std_kind": _STD_ERROR,
        "note": d.get("note") or None,
        **extra,
    }


def parameter_rows(result: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Rows (without the log's columns) of the recommended estimate and of every method."""
    rows: list[dict[str, Any]] = []
    est = result.get("estimate")
    if isinstance(est, Mapping):
        method = str(est.get("method") or "recommended")
        for key, d in est.items():
            if _is_estimate(d):
                rows.append(_estimate_row(key, d, kind="estimate", estimator=method, segment="all"))
    for m in result.get("methods") or []:
        if not isinstance(m, Mapping):
            continue
        name = str(m.get("name") or m.get("method") or "method")
        segment = str(m.get("segment") or "all")
        found = False
        for key, d in m.items():
            if _is_estimate(d):
                rows.append(_estimate_row(key, d, kind="method", estimator=name, segment=segment))
                found = True
        if found:
            continue
        # MethodResult (tractor-trailer's method table): "L1" with "L1_std", over repeats
        for key, v in m.items():
            if f"{key}_std" in m and key != "condition_number" and _num(v) is not None:
                std = _num(m[f"{key}_std"])
                value = _num(v)
                rows.append(
                    {
                        "kind": "method",
                        "estimator": name,
                        "segment": segment,
                        "parameter": key,
                        "value": value,
                        "std": std,
                        "ci95_lo": None,
                        "ci95_hi": None,
                        "identifiable": None,
                        "unit": "m",
                        "std_kind": _SPREAD,
                        "note": f"{m.get('family', '')} method, {m.get('n_repeats', 1)} repeat(s)",
                    }
                )
    return rows


def _effect_rows(result: Mapping[str, Any]) -> list[dict[str, Any]]:
    """One row per parameter of each effect of the discovery (the shared shape of
    ``calib.discovery.DiscoveryReport``: named and described effects alike)."""
    disc = result.get("discovery")
    if not isinstance(disc, Mapping):
        return []
    rows = []
    for e in disc.get("effects") or []:
        if not isinstance(e, Mapping):
            continue
        pars = e.get("parameters") or {}
        detail = json.dumps(
            {k: e.get(k) for k in ("status", "channel", "heldout_gain", "delta_bic", "terms")},
            sort_keys=True,
        )
        for pname, est in pars.items():
            est = est if isinstance(est, Mapping) else {}
            ci = est.get("ci95") or [None, None]
            rows.append(
                {
                    "kind": "effect",
                    "estimator": "discovery",
                    "segment": "all",
                    "parameter": f"{e.get('key') or e.get('id')}: {pname}",
                    "value": _num(est.get("value")),
                    "std": _num(est.get("std")),
                    "ci95_lo": _num(ci[0]),
                    "ci95_hi": _num(ci[1]),
                    "identifiable": bool(est.get("identifiable", True)),
                    "unit": est.get("unit"),
                    "std_kind": _STD_ERROR,
                    "note": e.get("physics") or None,
                    "detail": detail,
                }
            )
    return rows


def _start_time(start_ns: Any) -> datetime | None:
    if not isinstance(start_ns, int):
        return None
    return datetime.fromtimestamp(start_ns // 1000 / 1e6, tz=UTC)


def fleet_rows(record: Mapping[str, Any]) -> list[dict[str, Any]]:
    """All rows of one log's record (the per-log JSON the batch writes)."""
    base = {
        "log": record["log"],
        "log_id": record["id"],
        "robot_id": record.get("robot_id"),
        "robot": record.get("robot"),
        "start_time": _start_time(record.get("start_ns")),
    }
    if record.get("status") != "ok":
        return [{**base, "kind": "failure", "error": record.get("error")}]
    result = record.get("result") or {}
    return [{**base, **r} for r in parameter_rows(result) + _effect_rows(result)]


def fleet_table(records: Iterable[Mapping[str, Any]]) -> pl.DataFrame:
    """The fleet table of ``records`` (see the module docstring for the columns)."""
    rows = [r for rec in records for r in fleet_rows(rec)]
    full = [{k: r.get(k) for k in SCHEMA} for r in rows]
    return pl.DataFrame(full, schema=SCHEMA)


def write_parquet(table: pl.DataFrame, path: Path) -> None:
    """Write ``table`` to ``path`` (Parquet, zstd), through a temporary file renamed over it."""
    from logtools.outputs import write_atomically

    write_atomically(path, lambda tmp: table.write_parquet(tmp, compression="zstd"))
