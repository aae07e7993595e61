"""What discovery costs ``analyze`` on a 1-hour 100 Hz tractor-trailer log: CPU and peak RSS with
discovery on (the default) against ``--no-discovery``, measured in the same run, and the stages'
shares.

Each run is a fresh subprocess (imports included, as a user's ``logcal analyze`` pays them)
running ``logtools.analyze.analyze_log`` with the CLI's defaults; its CPU seconds are the
child's user + system time, its peak the child's maximum RSS, and each stage's CPU is taken
between consecutive progress messages (as ``bench/bench_analyze_scaling.py`` does). On and off
alternate, so that a machine's load falls on both alike; printed are min and median over
``--repeat`` runs, the ratio of discovery on to off (min over min), and the stages of the
fastest run with discovery on, with the number of path integrations the joint path model ran
(``rk4_hitch_sensitivities`` calls). Ratios, not timed assertions: the target of issue 32 is
analyze with discovery <= 4 s CPU and <= 400 MB on this log.

    python bench/bench_discovery_cost.py [--log /tmp/hour.mcap] [--repeat 3] [--before DIR]

``--before DIR``: also run a checkout of an earlier commit (``git archive REV | tar -x -C DIR``
with the built extension modules copied in), alternating with this one, and print its rows and
its ratio to this checkout's (before -> after in the same run).

The log is written with ``logcal simulate tractor-trailer --duration 3600 --rate 100 --seed 1``
when it does not exist.
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
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _write_log(path: Path) -> None:
    print(f"writing {path} ...", flush=True)
    cmd = [sys.executable, "-m", "logtools.cli.main", "simulate", "tractor-trailer"]
    cmd += ["-o", str(path), "--duration", "3600", "--rate", "100", "--seed", "1"]
    subprocess.run(cmd, check=True, capture_output=True)


def _measure(path: Path, discovery: bool) -> None:
    """One analysis in this process; prints its stages and integration count as JSON."""
    import calib.tractor_trailer.models.hitch_path as hp
    from logtools.analyze import AnalysisConfig, analyze_log

    calls = [0]
    kernel = hp.rk4_hitch_sensitivities

    def counted(*a: Any, **k: Any) -> Any:
        calls[0] += 1
        return kernel(*a, **k)

    hp.rk4_hitch_sensitivities = counted  # type: ignore[assignment]
    marks: list[tuple[str, float]] = []

    def progress(stage: str) -> None:
        marks.append((stage, time.process_time()))

    c0 = time.process_time()
    analyze_log(path, config=AnalysisConfig(discovery=discovery), progress=progress)
    c1 = time.process_time()
    stages: dict[str, float] = {}
    ends = [t for _, t in marks[1:]] + [c1]
    for (stage, t), end in zip(marks, ends, strict=True):
        key = stage.split(":")[0][:40]
        stages[key] = stages.get(key, 0.0) + end - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    row = {"analyze_cpu": c1 - c0, "stages": stages, "integrations": calls[0], "peak_mb": peak}
    print(json.dumps(row))


def _once(path: Path, discovery: bool, root: Path = ROOT) -> dict[str, Any]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cmd = [sys.executable, __file__, "--one", str(path), "--root", str(root)]
    cmd += [] if discovery else ["--no-disc"]
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    row: dict[str, Any] = json.loads(out.stdout.strip().splitlines()[-1])
    row["cpu"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", type=Path, default=Path("/tmp/hour.mcap"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--one", type=Path, help=argparse.SUPPRESS)
    ap.add_argument("--no-disc", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--root", type=Path, default=ROOT, help=argparse.SUPPRESS)
    ap.add_argument("--before", type=Path, help="an earlier checkout to run alongside")
    args = ap.parse_args()
    if args.one:
        sys.path.insert(0, str(args.root))
        _measure(args.one, not args.no_disc)
        return
    if not args.log.exists():
        _write_log(args.log)
    roots = {"this": ROOT} | ({"before": args.before.resolve()} if args.before else {})
    every: dict[str, dict[bool, list[dict[str, Any]]]] = {k: {True: [], False: []} for k in roots}
    for r in range(args.repeat):
        for name, root in roots.items():
            for discovery in (False, True):
                row = _once(args.log, discovery, root)
                every[name][discovery].append(row)
                print(
                    f"  run {r + 1} {name}, discovery {'on ' if discovery else 'off'}: "
                    f"{row['cpu']:.2f} s CPU (analyze {row['analyze_cpu']:.2f} s), "
                    f"{row['integrations']} path integrations, {row['peak_mb']:.0f} MB",
                    flush=True,
                )
    if args.before:
        for discovery in (True, False):
            b = min(r["cpu"] for r in every["before"][discovery])
            a = min(r["cpu"] for r in every["this"][discovery])
            print(
                f"discovery {'on ' if discovery else 'off'}: before {b:.2f} s -> this {a:.2f} s "
                f"CPU (min), ratio {a / b:.2f}"
            )
    for name in roots:
        _summary(f"{args.log} ({name}: {roots[name]})", every[name])


def _summary(title: str, runs: dict[bool, list[dict[str, Any]]]) -> None:
    print(f"\n{title}")
    print(f"{'discovery':>9s} {'CPU s min/med':>14s} {'peak RSS MB':>12s}")
    for discovery in (True, False):
        cpu = [r["cpu"] for r in runs[discovery]]
        print(
            f"{'on' if discovery else 'off':>9s} {min(cpu):6.2f}/{statistics.median(cpu):<6.2f} "
            f"{max(r['peak_mb'] for r in runs[discovery]):>12.0f}"
        )
    on = min(r["cpu"] for r in runs[True])
    off = min(r["cpu"] for r in runs[False])
    print(f"ratio on / off (min CPU): {on / off:.2f}; discovery costs {on - off:.2f} s CPU")
    best = min(runs[True], key=lambda r: r["cpu"])
    total = sum(best["stages"].values())
    print(f"stages of the fastest run with discovery ({total:.2f} s in analyze_log):")
    for stage, sec in sorted(best["stages"].items(), key=lambda kv: -kv[1])[:8]:
        print(f"  {sec:7.2f} s {100 * sec / total:5.1f} %  {stage}")


if __name__ == "__main__":
    main()
