"""CLI start-up time (``logcal --help`` and ``logcal info`` under 1 s).

Runs each command --repeat times in a fresh process and prints wall and CPU seconds (the child's
user + system time), min and median, next to the reference measured in the same run: a bare
``python -c pass`` (the interpreter's own start-up).

Usage: python bench/bench_cli_startup.py [--repeat 5] [--log sample_logs/tt_mixed_ros2.mcap]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run(cmd: list[str]) -> tuple[float, float]:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--log", default="sample_logs/tt_mixed_ros2.mcap")
    args = ap.parse_args()
    cli = [sys.executable, "-m", "logtools.cli.main"]
    plan = {
        "python -c pass (reference)": [sys.executable, "-c", "pass"],
        "logcal --help": [*cli, "--help"],
        f"logcal info {args.log}": [*cli, "info", args.log],
    }
    results: dict[str, list[tuple[float, float]]] = {k: [] for k in plan}
    for _ in range(args.repeat):
        for name, cmd in plan.items():  # interleaved: load on the shared box hits all alike
            results[name].append(_run(cmd))
    print(f"{'command':52s} {'wall s min/med':>15s} {'CPU s min/med':>15s}")
    for name, runs in results.items():
        wall = [w for w, _ in runs]
        cpu = [c for _, c in runs]
        print(
            f"{name:52s} {min(wall):6.2f}/{statistics.median(wall):<6.2f}  "
            f"{min(cpu):6.2f}/{statistics.median(cpu):<6.2f}"
        )


if __name__ == "__main__":
    main()
