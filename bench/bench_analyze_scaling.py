"""How `analyze` scales with log length: CPU seconds per stage and peak RSS.

Writes (once, cached in --workdir) 100 Hz tractor-trailer logs with ``logcal simulate`` of the
given lengths, then runs ``analyze_log`` in a fresh subprocess per (log, discovery on/off, run)
on the whole log (``AnalysisConfig(window_s=0)``: no analysis by time windows, which would
otherwise start by itself above 2 h of samples; windowed analysis is measured by
``bench/bench_long_log.py``), timing the stages from the progress callback (CPU seconds of
the process between consecutive progress messages) and reading the peak RSS. Prints min and
median over --repeat runs, and the CPU seconds per simulated hour (linear scaling: constant per
hour).

Usage: python bench/bench_analyze_scaling.py [--minutes 10 60 240] [--repeat 3]
       [--discovery-minutes 10 60 240] [--discovery-repeat 3] [--profile]
(the full set: --minutes 10 60 240 --discovery-minutes 10 60 240; a 4-hour log analysed whole
needs ~1 GB)
--profile: one cProfile of the shortest log with discovery, top functions by internal time.
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


def _log(workdir: Path, minutes: float) -> Path:
    path = workdir / f"tt_100hz_{minutes:g}min.mcap"
    if not path.exists():
        print(f"  writing {path} ...", flush=True)
        cmd = [sys.executable, "-m", "logtools.cli.main", "simulate", "tractor-trailer"]
        cmd += ["--rate", "100", "--duration", str(minutes * 60), "-o", str(path)]
        subprocess.run(cmd, check=True, capture_output=True)
    return path


def _measure(path: Path, discovery: bool) -> None:
    from logtools.analyze import AnalysisConfig, analyze_log

    marks: list[tuple[str, float]] = []

    def progress(stage: str) -> None:
        marks.append((stage, time.process_time()))

    c0, w0 = time.process_time(), time.perf_counter()
    config = AnalysisConfig(discovery=discovery, window_s=0.0)  # whole, never by windows
    analyze_log(path, config=config, progress=progress)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    stages: dict[str, float] = {}
    ends = [t for _, t in marks[1:]] + [c0 + cpu]
    for (stage, t), end in zip(marks, ends, strict=True):
        key = stage.split(":")[0][:40]
        stages[key] = stages.get(key, 0.0) + end - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    print(json.dumps({"cpu": cpu, "wall": wall, "peak_mb": peak, "stages": stages}))


def _once(path: Path, discovery: bool) -> dict:
    cmd = [sys.executable, __file__, "--one", str(path)] + ([] if discovery else ["--no-disc"])
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def _profile(path: Path) -> None:
    import cProfile
    import pstats

    from logtools.analyze import AnalysisConfig, analyze_log

    prof = cProfile.Profile()
    prof.enable()
    analyze_log(path, config=AnalysisConfig(discovery=True, window_s=0.0))
    prof.disable()
    pstats.Stats(prof).sort_stats("tottime").print_stats(25)
    pstats.Stats(prof).sort_stats("cumulative").print_stats(30)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[10, 60])
    ap.add_argument("--discovery-minutes", type=float, nargs="*", default=[10])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--discovery-repeat", type=int, default=3)
    ap.add_argument("--workdir", type=Path, default=Path("/tmp/logcal_bench_analyze"))
    ap.add_argument("--profile", action="store_true")
    ap.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--no-disc", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.one:
        _measure(args.one, not args.no_disc)
        return
    args.workdir.mkdir(parents=True, exist_ok=True)
    if args.profile:
        _profile(_log(args.workdir, min(args.discovery_minutes or args.minutes)))
        return
    plan = [(m, False, args.repeat) for m in args.minutes]
    plan += [(m, True, args.discovery_repeat) for m in args.discovery_minutes]
    rows = []
    for minutes, discovery, repeat in plan:
        path = _log(args.workdir, minutes)
        runs = []
        for r in range(repeat):
            runs.append(_once(path, discovery))
            print(
                f"  {minutes:g} min, discovery {'on' if discovery else 'off'}, run {r + 1}: "
                f"{runs[-1]['cpu']:.1f} s CPU",
                flush=True,
            )
        rows.append((minutes, discovery, runs))
    print(
        f"\n{'log':>8s} {'discovery':>9s} {'CPU s min/med':>14s} {'CPU s per hour':>15s} "
        f"{'wall s med':>10s} {'peak RSS MB':>12s}"
    )
    for minutes, discovery, runs in rows:
        cpu = [r["cpu"] for r in runs]
        print(
            f"{minutes:>6g} m {'on' if discovery else 'off':>9s} {min(cpu):6.1f}/"
            f"{statistics.median(cpu):<6.1f} {min(cpu) * 60 / minutes:>15.1f} "
            f"{statistics.median(r['wall'] for r in runs):>10.1f} "
            f"{max(r['peak_mb'] for r in runs):>12.0f}"
        )
        best = min(runs, key=lambda r: r["cpu"])
        for stage, sec in sorted(best["stages"].items(), key=lambda kv: -kv[1])[:6]:
            print(f"{'':>20s} {sec:7.2f} s  {stage}")


if __name__ == "__main__":
    main()
