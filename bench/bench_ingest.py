"""Ingest throughput: logcal's MCAP reader against rerun's Rust reader, same run.

Writes (once, cached in --workdir) tractor-trailer drive logs with ``logcal simulate`` in JSON and
ROS 2 (CDR) encoding, then times each reader in a fresh subprocess (so that peak RSS belongs to
that reader alone), --repeat times:

* zstd: decompressing every chunk of the ROS 2 log, nothing else (the floor);
* scan: logcal's raw record scan (``scan_mcap``) of the ROS 2 log;
* logcal JSON / logcal CDR: ``read_log`` into per-topic frames (CDR: bulk decoding, cdr_bulk);
* logcal CDR before: ``read_log`` with the per-message ROS 2 decoder (``decode_cdr_each``), on a
  smaller log (--before-messages) because it runs at ~20 k msg/s;
* rerun JSON / rerun CDR: ``rerun.chunk.McapReader(path).stream().to_chunks()``, each chunk to an
  Arrow record batch and into a polars frame (struct columns, not flattened).

Prints msg/s (from CPU seconds of the process, threads included, and wall seconds), min and
median over the runs, peak RSS and the frames' in-memory size, and each rate's ratio against
rerun's reader on the same log in the same run. The box is shared: CPU seconds are the figure
to compare; wall is shown for reference.

Usage: python bench/bench_ingest.py [--messages 1000000] [--before-messages 100000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

RATE = 225.0  # messages per second of simulated drive in the tractor-trailer log (50 Hz base)


def _log(workdir: Path, encoding: str, messages: int) -> Path:
    path = workdir / f"tt_{encoding}_{messages}.mcap"
    if not path.exists():
        duration = f"{messages / RATE:.1f}"
        print(f"  writing {path} ({messages} messages) ...", flush=True)
        cmd = [sys.executable, "-m", "logtools.cli.main", "simulate", "tractor-trailer"]
        cmd += ["--encoding", encoding, "--duration", duration, "-o", str(path)]
        subprocess.run(cmd, check=True, capture_output=True)
    return path


# ---------------------------------------------------------------- one measurement (subprocess)


def _scan(path: Path) -> tuple[int, int]:
    from logtools.readers.mcap_scan import scan_mcap

    scan = scan_mcap(path.read_bytes())
    return sum(len(m.log_times) for m in scan.messages.values()), 0


def _logcal(path: Path, before: bool) -> tuple[int, int]:
    from logtools.readers import DEFAULT_DECODERS, read_log
    from logtools.readers.decoders import decode_cdr_each

    decoders = {**DEFAULT_DECODERS, "cdr": decode_cdr_each} if before else DEFAULT_DECODERS
    log = read_log(path, decoders=decoders)
    frames = log.topics.values()
    return sum(f.height for f in frames), int(sum(float(f.estimated_size()) for f in frames))


def _rerun(path: Path) -> tuple[int, int]:
    import polars as pl
    import rerun.chunk as rc

    parts: dict[str, list[pl.DataFrame]] = {}
    n = 0
    for chunk in rc.McapReader(path).stream().to_chunks():
        batch = chunk.to_record_batch()
        if "message_log_time" not in batch.schema.names:
            continue  # channel/schema/statistics records
        entity = (batch.schema.metadata or {}).get(b"rerun:entity_path", b"").decode()
        parts.setdefault(entity, []).append(pl.from_arrow(batch))  # type: ignore[arg-type]
        n += batch.num_rows
    frames = [pl.concat(p) for p in parts.values()]
    return n, int(sum(float(f.estimated_size()) for f in frames))


def _measure(what: str, path: Path) -> None:
    import polars  # noqa: F401  (imports are not part of the timing)

    if what.startswith("rerun"):
        import rerun.chunk  # noqa: F401
    else:  # logcal's reader, its decoders and their compiled passes, as rerun's above
        import logtools.readers
        import logtools.readers.flat_json  # noqa: F401
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    c0, w0 = time.process_time(), time.perf_counter()
    if what == "scan":
        n, size = _scan(path)
    elif what.startswith("logcal"):
        n, size = _logcal(path, before=what.endswith("before"))
    else:
        n, size = _rerun(path)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    _emit(n, cpu, wall, peak, base, size)


def _emit(n: int, cpu: float, wall: float, peak: int, base: int, size: int) -> None:
    """One measurement as the JSON line the driver reads."""
    rec = {"n": n, "cpu": cpu, "wall": wall, "peak_kb": peak, "base_kb": base}
    print(json.dumps({**rec, "frames_bytes": size}))


def _run_zstd(path: Path) -> None:
    """zstd alone: read the chunk bodies first, then time only their decompression."""
    import zstandard
    from mcap.reader import make_reader
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    n = summary.statistics.message_count if summary.statistics else 0
    chunks = []
    with path.open("rb") as fh:
        for rec in StreamReader(fh, skip_magic=False, emit_chunks=True).records:
            if isinstance(rec, Chunk):
                chunks.append((rec.data, rec.uncompressed_size))
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    dec = zstandard.ZstdDecompressor()
    c0, w0 = time.process_time(), time.perf_counter()
    total = sum(len(dec.decompress(d, max_output_size=s)) for d, s in chunks)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    _emit(n, cpu, wall, peak, base, total)


# ---------------------------------------------------------------- driver


def _once(what: str, path: Path) -> dict[str, float]:
    out = subprocess.run(
        [sys.executable, __file__, "--one", what, "--log", str(path)],
        check=True,
        capture_output=True,
        text=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--messages", type=int, default=1_000_000)
    ap.add_argument("--before-messages", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/logcal_bench_ingest"))
    ap.add_argument("--one", help=argparse.SUPPRESS)
    ap.add_argument("--log", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        if args.one == "zstd":
            _run_zstd(args.log)
        else:
            _measure(args.one, args.log)
        return
    args.workdir.mkdir(parents=True, exist_ok=True)
    ros2 = _log(args.workdir, "ros2", args.messages)
    js = _log(args.workdir, "json", args.messages)
    ros2_small = _log(args.workdir, "ros2", args.before_messages)
    plan = [
        ("zstd", "zstd decompression alone (CDR log)", ros2),
        ("scan", "logcal record scan (CDR log)", ros2),
        ("rerun_cdr", "rerun McapReader -> polars (CDR)", ros2),
        ("logcal_cdr", "logcal read_log CDR, bulk (after)", ros2),
        ("rerun_json", "rerun McapReader -> polars (JSON)", js),
        ("logcal_json", "logcal read_log JSON", js),
        ("rerun_cdr_small", "rerun McapReader -> polars (small CDR)", ros2_small),
        ("logcal_cdr_before", "logcal read_log CDR, per message (before)", ros2_small),
    ]
    results: dict[str, list[dict[str, float]]] = {k: [] for k, _, _ in plan}
    for r in range(args.repeat):
        for key, label, path in plan:  # interleaved, so that load on the box hits all alike
            what = "rerun_cdr" if key == "rerun_cdr_small" else key
            results[key].append(_once(what, path))
            print(
                f"  run {r + 1}/{args.repeat} {label}: {results[key][-1]['cpu']:.2f} s CPU",
                flush=True,
            )
    ref = {
        "zstd": "rerun_cdr",
        "scan": "rerun_cdr",
        "rerun_cdr": "rerun_cdr",
        "logcal_cdr": "rerun_cdr",
        "rerun_json": "rerun_json",
        "logcal_json": "rerun_json",
        "rerun_cdr_small": "rerun_cdr_small",
        "logcal_cdr_before": "rerun_cdr_small",
    }
    print(
        f"\n{'work':44s} {'msgs':>8s} {'CPU s min/med':>14s} {'msg/s (CPU, best)':>18s} "
        f"{'wall s min/med':>15s} {'x rerun':>8s} {'peak RSS MB':>12s} {'frames MB':>10s} "
        f"{'added/frames':>12s}"
    )
    for key, label, _ in plan:
        runs = results[key]
        cpu = [r["cpu"] for r in runs]
        wall = [r["wall"] for r in runs]
        n = int(runs[0]["n"])
        ref_cpu = min(r["cpu"] for r in results[ref[key]])
        ratio = ref_cpu / min(cpu)
        peak = max(r["peak_kb"] for r in runs) / 1e3
        added = max(r["peak_kb"] - r["base_kb"] for r in runs) / 1e3
        frames = runs[0]["frames_bytes"] / 1e6
        share = f"{added / frames:11.2f}x" if frames > 0 else f"{'-':>12s}"
        print(
            f"{label:44s} {n:>8d} {min(cpu):6.2f}/{statistics.median(cpu):<6.2f}  "
            f"{n / min(cpu):>16,.0f}  {min(wall):6.2f}/{statistics.median(wall):<6.2f}  "
            f"{ratio:>7.2f}x {peak:>11.0f} {frames:>10.1f} {share}"
        )
    print(
        "\nx rerun: rate relative to rerun's reader on the same log (CPU s, best of runs); "
        "frames MB for zstd is the decompressed size; added/frames: peak RSS above the process's "
        "RSS once its imports are done, over the frames' size (the issue-14 memory measure)."
    )


if __name__ == "__main__":
    main()
