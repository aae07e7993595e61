"""Benchmark: write the rerun recording of a 1-hour 100 Hz log; seconds and file size.

Baselines measured in the same run: writing the same aligned frame as Parquet (polars), and
logging one scalar series with one ``rr.log`` per row (on the first minute, scaled up) against
``rr.send_columns`` for the same series.

Usage: ``python bench/bench_rrd.py [--hours 1.0] [--rate 100]``
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rerun as rr

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "viz"))

from conftest import make_result

from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)
from viz.tractor_trailer.plots import write_report_png
from viz.tractor_trailer.recording import write_recording


def simulate(hours: float, rate_hz: float):
    """Mixed harmonic / constant / curve commands, 63 s each, repeated to ``hours``."""
    kinds = [
        CommandSpec(CommandType.HARMONIC, 63.0, amplitude=0.2, rate=0.1),
        CommandSpec(CommandType.CONSTANT, 30.0, amplitude=0.0),
        CommandSpec(CommandType.CURVE, 63.0, amplitude=0.2, rate=0.1),
        CommandSpec(CommandType.CURVE, 63.0, amplitude=-0.2, rate=0.1),
    ]
    total = hours * 3600.0
    specs, t = [], 0.0
    while t < total:
        s = kinds[len(specs) % len(kinds)]
        d = min(s.duration_s, total - t)
        specs.append(CommandSpec(s.kind, d, amplitude=s.amplitude, rate=s.rate))
        t += d
    cfg = TractorTrailerSim(
        commands=CommandSequence(specs),
        speed=SpeedProfile(v_mps=1.0),
        rate_hz=rate_hz,
        rates_hz=dict.fromkeys(("cmd", "odom", "pose", "hitch"), rate_hz),
    )
    return simulate_tractor_trailer(cfg, seed=0)


def per_row_baseline(t_ns: np.ndarray, values: np.ndarray, path: Path) -> float:
    """Seconds to log ``values`` with one ``rr.log`` per row."""
    rec = rr.RecordingStream("bench-per-row")
    rec.save(path)
    t0 = time.perf_counter()
    for t, v in zip(t_ns.tolist(), values.tolist(), strict=True):
        rec.set_time("log_time", timestamp=np.datetime64(t, "ns"))
        rec.log("kappa", rr.Scalars(v))
    rec.flush()
    dt = time.perf_counter() - t0
    rec.disconnect()
    return dt


def columns_baseline(t_ns: np.ndarray, values: np.ndarray, path: Path) -> float:
    """Seconds to log ``values`` with one ``rr.send_columns``."""
    rec = rr.RecordingStream("bench-columns")
    rec.save(path)
    t0 = time.perf_counter()
    rec.send_columns(
        "kappa",
        indexes=[rr.TimeColumn("log_time", timestamp=t_ns.astype("datetime64[ns]"))],
        columns=rr.Scalars.columns(scalars=values),
    )
    rec.flush()
    dt = time.perf_counter() - t0
    rec.disconnect()
    return dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--hours", type=float, default=1.0)
    ap.add_argument("--rate", type=float, default=100.0)
    args = ap.parse_args()
    t0 = time.perf_counter()
    run = simulate(args.hours, args.rate)
    frame, result = run.truth, make_result(run)
    print(
        f"simulated {frame.height} rows ({args.hours} h at {args.rate} Hz) in "
        f"{time.perf_counter() - t0:.1f} s"
    )
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        t0 = time.perf_counter()
        write_recording(d / "log.rrd", frame, result, method_for_psi="PMLS/PM1")
        t_rrd = time.perf_counter() - t0
        size = (d / "log.rrd").stat().st_size
        t0 = time.perf_counter()
        frame.write_parquet(d / "log.parquet")
        t_pq = time.perf_counter() - t0
        size_pq = (d / "log.parquet").stat().st_size
        t0 = time.perf_counter()
        write_report_png(d / "log.png", frame, result)
        t_png = time.perf_counter() - t0
        n_min = min(frame.height, round(60 * args.rate))
        tk = frame["t_ns"].to_numpy()[:n_min]
        kv = frame["kappa"].to_numpy()[:n_min]
        t_row = per_row_baseline(tk, kv, d / "row.rrd")
        t_col = columns_baseline(tk, kv, d / "col.rrd")
    print(f"write_recording: {t_rrd:.2f} s, {size / 1e6:.1f} MB ({size / frame.height:.0f} B/row)")
    print(
        f"baseline parquet of the aligned frame: {t_pq:.2f} s, {size_pq / 1e6:.1f} MB; "
        f"ratio rrd/parquet: time {t_rrd / t_pq:.1f}x, size {size / size_pq:.1f}x"
    )
    print(f"write_report_png: {t_png:.2f} s")
    print(
        f"one scalar series, first {n_min} rows: rr.log per row {t_row:.3f} s, "
        f"send_columns {t_col:.4f} s, ratio {t_row / t_col:.0f}x"
    )


if __name__ == "__main__":
    main()
