"""Coverage of the recommended 95 % intervals on logs from the INDEPENDENT generator.

Each log is drawn by ``tests/indgen.random_scenario`` (rate 5-200 Hz, common or per topic,
jitter, dropouts, stalls, quantisation, speed profiles with stops and reversing, L1/(L1+L2)
from -0.05 to 0.6, noise x0 to x3, seven command shapes, optional topics absent), written to a
file in a random format (MCAP JSON, MCAP ROS 2, CSV) by indgen's own writers, and analysed
end to end with ``logtools.analyze.analyze_log`` (reader, alignment, path, fit; discovery off).

Printed: for L1, L2 and L1 + L2, how often the 95 % interval holds the truth, per condition
cell, over the logs where the quantity was reported as determined, with a Wilson 95 % band of
that proportion; and how often each was "not determined". Run from the repository root:

    python bench/path_coverage_study.py --n 500 --jobs 2 --out /tmp/coverage.json
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT))

QUANTITIES = ("L1", "L2", "sum_L1_L2")


def _scenario_cells(scn: Any) -> dict[str, str]:
    rates = [t.rate_hz for t in scn.topics.values()]
    r = min(rates)
    ratio = scn.L1 / (scn.L1 + scn.L2)
    noise = max((max(t.noise.values(), default=0.0) for t in scn.topics.values()), default=0.0)
    return {
        "rate": "5-20 Hz" if r < 20 else ("20-60 Hz" if r < 60 else "60-200 Hz"),
        "per_topic_rates": str(len({round(x, 6) for x in rates}) > 1),
        "speed": str(scn.speed.kind if hasattr(scn.speed, "kind") else "?"),
        "command": str(scn.command.kind),
        "split": "L1<=0" if ratio <= 0 else ("0-0.3" if ratio < 0.3 else "0.3-0.6"),
        "noise": "none" if noise == 0 else ("low" if noise < 0.01 else "high"),
        "pose": str("pose" in scn.topics),
        "odom": str("odom" in scn.topics),
        "stalls": str(scn.n_stalls > 0),
    }


def one(i: int, seed: int) -> dict[str, Any]:
    import indgen

    from logtools.analyze import AnalysisConfig, analyze_log

    rng = np.random.default_rng([seed, i])
    scn = indgen.random_scenario(rng)
    gen = indgen.generate(scn, seed=int(rng.integers(2**31)))
    fmt = str(rng.choice(["json", "ros2", "csv"]))
    cfg = AnalysisConfig(repeats=1, discovery=False, per_segment=False)
    row: dict[str, Any] = {
        "i": i,
        "format": fmt,
        "cells": _scenario_cells(scn),
        "truth": {"L1": scn.L1, "L2": scn.L2, "sum_L1_L2": scn.L1 + scn.L2},
    }
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / ("log.csv" if fmt == "csv" else "log.mcap")
        {"json": indgen.write_mcap_json, "ros2": indgen.write_mcap_ros2, "csv": indgen.write_csv}[
            fmt
        ](path, gen)
        t0 = time.perf_counter()
        try:
            _, res = analyze_log(path, config=cfg)
        except Exception as err:  # recorded: a study counts failures, it does not stop on them
            row["error"] = f"{type(err).__name__}: {err}"
            return row
        row["seconds"] = time.perf_counter() - t0
    est = res.estimate
    row["method"] = est.method if est else None
    row["path_source"] = res.source.get("path_source")
    if est is not None:
        row["misfit"] = est.details.get("misfit")
        row["stages"] = {s.stage: s.status for s in res.stages}
    if est is not None:
        for q in QUANTITIES:
            e = est.derived[q] if q == "sum_L1_L2" else est.parameters[q]
            row[q] = {"value": e.value, "ci95": list(e.ci95), "determined": e.identifiable}
    return row


def wilson(k: int, n: int) -> tuple[float, float]:
    """Wilson 95 % interval of a proportion k / n."""
    if n == 0:
        return (math.nan, math.nan)
    z = 1.959963984540054
    p = k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (c - h, c + h)


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {"logs": len(rows), "errors": [r for r in rows if "error" in r]}
    ok = [r for r in rows if "error" not in r]
    out["no_estimate"] = sum(1 for r in ok if r.get("method") is None)
    table: dict[str, dict[str, list[int]]] = defaultdict(lambda: defaultdict(lambda: [0, 0, 0]))
    for r in ok:
        if r.get("method") is None:
            continue
        cells = {"all": "all", **r["cells"], "path_source": str(r.get("path_source"))}
        for q in QUANTITIES:
            e = r[q]
            lo, hi = e["ci95"]
            t = r["truth"][q]
            for cell, val in cells.items():
                acc = table[q][f"{cell}={val}"]
                if e["determined"]:
                    acc[0] += 1
                    acc[1] += int(lo is not None and hi is not None and lo <= t <= hi)
                else:
                    acc[2] += 1
    out["coverage"] = {
        q: {
            cell: {
                "determined": n,
                "covered": k,
                "not_determined": nd,
                "coverage": k / n if n else None,
                "wilson95": wilson(k, n),
            }
            for cell, (n, k, nd) in sorted(cells.items())
        }
        for q, cells in table.items()
    }
    secs = [r["seconds"] for r in ok if "seconds" in r]
    out["seconds_median"] = float(np.median(secs)) if secs else None
    return out


def print_summary(s: dict[str, Any]) -> None:
    print(
        f"logs: {s['logs']}  errors: {len(s['errors'])}  no estimate: {s['no_estimate']}  "
        f"median analysis time: {s['seconds_median']}"
    )
    for e in s["errors"][:10]:
        print("  error:", e["i"], e["error"][:200])
    for q, cells in s["coverage"].items():
        print(f"\n{q}: cell | determined | covered | coverage [Wilson 95 %] | not determined")
        for cell, c in cells.items():
            cov = "-" if c["coverage"] is None else f"{c['coverage']:.3f}"
            lo, hi = c["wilson95"]
            band = "" if c["coverage"] is None else f"[{lo:.3f}, {hi:.3f}]"
            print(
                f"  {cell:28s} {c['determined']:5d} {c['covered']:5d}  {cov:>6s} {band:16s}"
                f" {c['not_determined']:5d}"
            )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=500, help="number of logs")
    ap.add_argument("--seed", type=int, default=2026, help="study seed")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes")
    ap.add_argument("--out", type=Path, default=None, help="write rows and summary (JSON)")
    a = ap.parse_args(argv)
    t0 = time.perf_counter()
    rows = []
    with ProcessPoolExecutor(max(1, a.jobs)) as ex:
        for k, row in enumerate(ex.map(one, range(a.n), [a.seed] * a.n), 1):
            rows.append(row)
            if k % 10 == 0 or k == a.n:
                print(f"{k}/{a.n} logs, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
            if a.out and k % 50 == 0:  # partial results survive an interrupted study
                a.out.write_text(json.dumps({"rows": rows}, default=str))
    s = summarise(rows)
    print_summary(s)
    print(f"\nwall time {time.perf_counter() - t0:.0f} s")
    if a.out:
        a.out.write_text(json.dumps({"rows": rows, "summary": s}, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
