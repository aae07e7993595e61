"""Throughput of ``logcal batch``: logs per minute, 1 worker vs 2 workers (local process pool)
vs Ray on a local 2-CPU instance, on one archive of simulated tractor-trailer logs.

    python bench/batch_throughput.py [--logs 20] [--duration 63] [--repeats 2]
                                     [--discovery] [--views] [--no-ray]

Each engine analyses the same archive into a fresh output folder (wall time includes starting
the workers or Ray, the fleet table and the HTML report). The outputs of the engines are
compared (per-log records and the Parquet table must be identical). Logs: harmonic drives of
``--duration`` s at 20 Hz, L1 = 1.25 m, L2 = 2.48 m, seeds 0..N-1.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import tempfile
import time
from pathlib import Path

import polars as pl

from calib.tractor_trailer.sim.presets import preset
from calib.tractor_trailer.sim.tractor_trailer import simulate_tractor_trailer
from logtools.batch.engines import Engine
from logtools.batch.runner import (
    read_records,
    run_batch,
    write_fleet_outputs,
)
from logtools.batch.worker import AnalysisOptions
from logtools.writers.tractor_trailer import run_metadata, write_run

DAY_NS = 86_400 * 10**9


def make_archive(root: Path, n: int, duration_s: float) -> None:
    for i in range(n):
        cfg = preset("harmonic", duration_s=duration_s, rate_hz=20.0)
        cfg = dataclasses.replace(cfg, start_time_ns=1_760_000_000 * 10**9 + i * DAY_NS)
        run = simulate_tractor_trailer(cfg, seed=i)
        path = root / f"robot{i % 2}" / f"log{i:03d}.mcap"
        path.parent.mkdir(parents=True, exist_ok=True)
        write_run(path, run, metadata=run_metadata(run))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=20)
    ap.add_argument("--duration", type=float, default=63.0)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--discovery", action="store_true")
    ap.add_argument("--views", action="store_true")
    ap.add_argument("--no-ray", action="store_true")
    args = ap.parse_args()
    options = AnalysisOptions(repeats=args.repeats, discovery=args.discovery, views=args.views)
    runs: list[tuple[str, Engine, int]] = [
        ("local, 1 worker", Engine.LOCAL, 1),
        ("local, 2 workers", Engine.LOCAL, 2),
    ]
    if not args.no_ray:
        try:
            import ray  # noqa: F401

            runs.append(("ray, local 2 CPUs", Engine.RAY, 2))
        except ImportError:
            print("ray not installed: pip install 'logcal[ray]'; its row is left out")
    with tempfile.TemporaryDirectory(prefix="logcal-bench-batch-") as tmp:
        archive = Path(tmp) / "archive"
        t0 = time.perf_counter()
        make_archive(archive, args.logs, args.duration)
        print(
            f"archive: {args.logs} logs of {args.duration:g} s at 20 Hz "
            f"({time.perf_counter() - t0:.1f} s to simulate); options: {options.fingerprint()}"
        )
        print(
            f"{'engine':<20} {'wall s':>8} {'logs/min':>9} {'failed':>7} "
            f"{'per-log s (mean)':>17} {'report s':>9}"
        )
        reference = None
        for name, engine, workers in runs:
            out = Path(tmp) / name.replace(" ", "_").replace(",", "")
            load = os.getloadavg()[0]
            t0 = time.perf_counter()
            summary = run_batch(archive, out, options=options, engine=engine, workers=workers)
            wall = time.perf_counter() - t0
            logs = json.loads((out / "manifest.json").read_text())["logs"].values()
            per_log = sum(float(e["seconds"]) for e in logs) / max(len(logs), 1)
            t1 = time.perf_counter()
            write_fleet_outputs(out)  # once more, to time the fleet table and report alone
            print(
                f"{name:<20} {wall:8.1f} {60 * args.logs / wall:9.1f} "
                f"{len(summary.failed):7d} {per_log:17.2f} {time.perf_counter() - t1:9.1f}"
                f"  (load {load:.1f} on {os.cpu_count()} CPUs before)",
                flush=True,
            )
            outputs = (
                json.dumps(read_records(out), sort_keys=True),
                pl.read_parquet(out / "fleet.parquet"),
            )
            if reference is None:
                reference = outputs
            else:
                same = outputs[0] == reference[0] and outputs[1].equals(reference[1])
                print(f"{'':<20} outputs identical to the first run: {same}")


if __name__ == "__main__":
    main()
