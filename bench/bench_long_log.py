"""Peak memory of `logcal analyze` on a 24-hour 100 Hz log, against a 1-hour reference measured
in the same run: bounded memory in the log's length (windowed analysis, logtools/windows.py).

Writes (once, cached in --workdir) 100 Hz tractor-trailer logs of 1 h, 4 h and 24 h (JSON MCAP,
the `logcal simulate` topics) in one streaming pass: the simulator runs hour by hour (seed
--seed + hour, its clock continued, the pose carried on from the previous hour's end so the
path is continuous; the hitch angle restarts at 0 each hour) and each hour's messages are
appended to every file still open, so the writer never holds more than one hour. Then runs
`logcal analyze --json` on each in a fresh subprocess and reads its peak RSS
(``getrusage(RUSAGE_CHILDREN).ru_maxrss`` after the child ends, each child measured alone):

- 24 h, default options (automatic windows: 24 windows of 3600 s);
- 1 h, default options (the reference: one window's worth, analysed whole);
- 4 h with --window 0 (the whole log at once, for contrast).

Prints peak RSS of each, the ratio 24 h / 1 h, wall time per window, and the pooled estimate.

Usage: nice -n 10 python bench/bench_long_log.py [--workdir DIR] [--hours 24] [--repeats 10]
       [--skip-whole] [--no-discovery]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

HOUR_NS = 3600 * 10**9


def _hour_frames(hour: int, seed: int, start: tuple[float, float, float]) -> tuple:
    """One simulated hour: its frames (the ``logcal simulate`` topics' groups), its metadata,
    and the pose where the next hour starts."""
    import numpy as np
    import polars as pl

    from calib.tractor_trailer.sim.presets import preset
    from calib.tractor_trailer.sim.tractor_trailer import simulate_tractor_trailer
    from logtools.writers.tractor_trailer import run_frames, run_metadata

    cfg = preset("mixed", rate_hz=100.0, duration_s=3600.0)
    cfg = replace(cfg, start_time_ns=cfg.start_time_ns + hour * HOUR_NS)
    run = simulate_tractor_trailer(cfg, seed=seed + hour)
    end_ns = cfg.start_time_ns + HOUR_NS  # t = 3600 s is the next hour's first sample
    frames = {g: f.filter(pl.col("t_ns") < end_ns) for g, f in run_frames(run).items()}
    x0, y0, yaw0 = start
    c, s = math.cos(yaw0), math.sin(yaw0)
    pose = frames["pose"]
    yaw = pose["yaw"].to_numpy() + yaw0
    frames["pose"] = pose.with_columns(
        pl.Series("x", x0 + c * pose["x"].to_numpy() - s * pose["y"].to_numpy()),
        pl.Series("y", y0 + s * pose["x"].to_numpy() + c * pose["y"].to_numpy()),
        pl.Series("yaw", yaw),
        pl.Series("qz", np.sin(yaw / 2)),
        pl.Series("qw", np.cos(yaw / 2)),
    )
    last = run.truth.row(-1, named=True)
    nxt = (
        x0 + c * last["x"] - s * last["y"],
        y0 + s * last["x"] + c * last["y"],
        yaw0 + last["yaw"],
    )
    return frames, run_metadata(run, extra={"preset": "mixed"}), nxt


def _hour_messages(frames: dict) -> tuple:
    """The JSON messages of one hour's frames, in time order: (channel index, log time, payload)
    arrays. Payloads are built column-wise by polars (one string per message, the fields of
    ``JSON_BINDINGS``; every simulated value is finite), so that writing costs the MCAP
    writer's loop and no per-message dict or ``json.dumps``."""
    import numpy as np
    import polars as pl

    from logtools.writers.tractor_trailer import JSON_BINDINGS

    times, which, payloads = [], [], []
    for i, b in enumerate(JSON_BINDINGS):
        frame = frames[b.group]
        parts: list[pl.Expr] = []
        for k, (key, col) in enumerate(b.fields.items()):
            parts += [
                pl.lit(("{" if k == 0 else ",") + json.dumps(key) + ":"),
                pl.col(col).cast(pl.Float64).cast(pl.String),
            ]
        text = frame.select(pl.concat_str([*parts, pl.lit("}")]).cast(pl.Binary).alias("p"))
        times.append(frame["t_ns"].to_numpy())
        which.append(np.full(frame.height, i))
        payloads.append(text["p"].to_list())
    t_all, w_all = np.concatenate(times), np.concatenate(which)
    order = np.lexsort((w_all, t_all))
    flat = [p for chunk in payloads for p in chunk]
    return w_all[order].tolist(), t_all[order].tolist(), [flat[k] for k in order.tolist()]


def write_logs(paths: dict[int, Path], seed: int) -> dict[str, float]:
    """Write the logs of ``paths`` (hours -> file) in one pass; CPU seconds and peak RSS (MB)."""
    from mcap.writer import CompressionType, Writer

    from logtools.writers.mcap_writer import json_schema
    from logtools.writers.tractor_trailer import JSON_BINDINGS

    c0, w0 = time.process_time(), time.perf_counter()
    hours = max(paths)
    tmp = {h: p.with_suffix(".part") for h, p in paths.items()}
    files = {h: open(t, "wb") for h, t in tmp.items()}  # noqa: SIM115 (closed below)
    writers: dict[int, Writer] = {}
    channels: dict[int, list[int]] = {}
    for h in paths:
        w = writers[h] = Writer(files[h], compression=CompressionType.ZSTD)
        w.start(profile="", library="logcal")
        channels[h] = []
        for b in JSON_BINDINGS:
            sid = w.register_schema(
                b.schema_name, "jsonschema", json.dumps(json_schema(b)).encode()
            )
            channels[h].append(w.register_channel(b.topic, "json", sid))
    pose = (0.0, 0.0, 0.0)
    meta: dict = {}
    for hour in range(hours):
        frames, meta_h, pose = _hour_frames(hour, seed, pose)
        meta = meta or meta_h
        which, times, payloads = _hour_messages(frames)
        del frames
        for h, w in writers.items():
            if hour < h:
                ids = channels[h]
                for i, t_ns, payload in zip(which, times, payloads, strict=True):
                    w.add_message(ids[i], t_ns, payload, t_ns)
            if hour + 1 == h:
                for name, data in meta.items():
                    w.add_metadata(name, dict(data))
                w.finish()
                files[h].close()
                tmp[h].replace(paths[h])
        print(
            f"  hour {hour + 1} of {hours} written ({time.perf_counter() - w0:.0f} s)", flush=True
        )
    return {
        "cpu_s": time.process_time() - c0,
        "wall_s": time.perf_counter() - w0,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3,
    }


def _logs(workdir: Path, hours: list[int], seed: int) -> dict[int, Path]:
    paths = {h: workdir / f"tt_100hz_{h}h_seed{seed}.mcap" for h in hours}
    missing = {h: p for h, p in paths.items() if not p.exists()}
    if missing:
        print(f"writing {', '.join(str(p) for p in missing.values())} ...", flush=True)
        cmd = [
            sys.executable,
            __file__,
            "--write",
            "--seed",
            str(seed),
            "--workdir",
            str(workdir),
            "--hours",
            *[str(h) for h in missing],
        ]
        subprocess.run(cmd, check=True)
    return paths


def analyse(path: Path, extra: list[str], repeats: int) -> dict:
    """``logcal analyze --json`` of ``path`` in a fresh process: wall time, peak RSS, JSON."""
    cmd = [
        sys.executable,
        "-m",
        "logtools.cli.main",
        "analyze",
        str(path),
        "--json",
        "--repeats",
        str(repeats),
        *extra,
    ]
    w0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - w0
    # the largest child so far: run from a parent of its own (_one_child_peak), this one
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    if out.returncode != 0:
        print(out.stderr[-3000:], file=sys.stderr)
        raise SystemExit(f"analyze exited {out.returncode}")
    return {"wall_s": wall, "peak_mb": peak / 1e3, "doc": json.loads(out.stdout)}


def _one_child_peak(path: Path, extra: list[str], repeats: int) -> dict:
    """:func:`analyse` from a parent of its own, so that RUSAGE_CHILDREN holds this child only
    (the maximum over children would otherwise be the largest one so far)."""
    cmd = [
        sys.executable,
        __file__,
        "--measure",
        str(path),
        "--repeats",
        str(repeats),
        "--",
        *extra,
    ]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _summary(name: str, res: dict) -> str:
    doc = res["doc"]
    est = doc.get("estimate") or {}
    win = doc.get("source", {}).get("windows")
    what = f"{win['count']} windows of {win['window_s']:g} s" if win else "whole"
    vals = ", ".join(
        f"{k} = {est[k]['value']:.4g} ± {est[k]['std']:.2g}" for k in ("L1", "L2") if k in est
    )
    per = f", {res['wall_s'] / win['count']:.1f} s per window" if win else ""
    return (
        f"{name:>14}: peak RSS {res['peak_mb']:7.0f} MB, wall {res['wall_s']:7.1f} s{per}; "
        f"{what}; {vals}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/logcal_long_log"))
    ap.add_argument("--hours", type=int, nargs="+", default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=10, help="analyze --repeats")
    ap.add_argument("--skip-whole", action="store_true", help="skip the 4 h whole-log run")
    ap.add_argument(
        "--no-discovery",
        action="store_true",
        help="analyze --no-discovery (CPU ~2.5x less; the same peak on 1 h)",
    )
    ap.add_argument("--write", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--measure", type=Path, default=None, help=argparse.SUPPRESS)
    ap.add_argument("extra", nargs="*", help=argparse.SUPPRESS)
    args = ap.parse_args()
    args.workdir.mkdir(parents=True, exist_ok=True)
    if args.write:
        hours = args.hours or [1, 4, 24]
        paths = {h: args.workdir / f"tt_100hz_{h}h_seed{args.seed}.mcap" for h in hours}
        cost = write_logs(paths, args.seed)
        sizes = {h: os.path.getsize(p) / 1e6 for h, p in paths.items()}
        print(
            f"writer: {cost['wall_s']:.0f} s wall, {cost['cpu_s']:.0f} s CPU, peak RSS "
            f"{cost['peak_mb']:.0f} MB; sizes (MB): {sizes}",
            flush=True,
        )
        return
    if args.measure is not None:
        res = analyse(args.measure, args.extra, args.repeats)
        print(json.dumps(res))
        return
    long_h = max(args.hours or [24])
    hours = sorted({1, 4, long_h} - ({4} if args.skip_whole else set()))
    paths = _logs(args.workdir, hours, args.seed)
    results = {}
    opts = ["--no-discovery"] if args.no_discovery else []
    results[f"{long_h} h windowed"] = _one_child_peak(paths[long_h], opts, args.repeats)
    results["1 h reference"] = _one_child_peak(paths[1], opts, args.repeats)
    if not args.skip_whole:
        results["4 h whole"] = _one_child_peak(paths[4], [*opts, "--window", "0"], args.repeats)
    print(
        f"\nlogcal analyze --repeats {args.repeats} {' '.join(opts)}, 100 Hz tractor-trailer logs:"
    )
    for name, res in results.items():
        print(_summary(name, res))
    ratio = results[f"{long_h} h windowed"]["peak_mb"] / results["1 h reference"]["peak_mb"]
    print(
        f"peak RSS {long_h} h windowed / 1 h whole: {ratio:.2f} (bounded: ~1; the log is "
        f"{long_h}x longer)"
    )
    if "4 h whole" in results:
        r4 = results["4 h whole"]["peak_mb"] / results["1 h reference"]["peak_mb"]
        print(f"peak RSS 4 h whole / 1 h whole: {r4:.2f}")


if __name__ == "__main__":
    main()
