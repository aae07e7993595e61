"""Cost of recycling the local workers (``RECYCLE_EVERY`` in logtools/batch/engines.py): the
same archive analysed with workers renewed every ``--every`` logs and with workers kept for the
whole batch, alternately, in the same run; prints the time per log of each and their ratio.

    python bench/batch_recycle.py [--logs 60] [--every 10] [--rounds 2] [--workers 2]

A small ``--every`` makes the renewals frequent enough to measure on a short archive; the
cost per renewal it prints, spread over ``workers * RECYCLE_EVERY`` logs, is the overhead of
the default. Logs: harmonic tractor-trailer drives of ``--duration`` s at 20 Hz, analysed with
2 bootstrap repeats, no discovery, no views.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from batch_throughput import make_archive  # bench/ is sys.path[0]

from logtools.batch import engines
from logtools.batch.runner import run_batch
from logtools.batch.worker import AnalysisOptions


def _time(archive: Path, out: Path, workers: int, every: int) -> float:
    engines.RECYCLE_EVERY = every
    t0 = time.perf_counter()
    summary = run_batch(
        archive,
        out,
        options=AnalysisOptions(repeats=2, discovery=False, views=False),
        workers=workers,
        force=True,
        report=False,
    )
    assert not summary.failed, summary.failed
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=60)
    ap.add_argument("--every", type=int, default=10)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--duration", type=float, default=20.0)
    args = ap.parse_args()
    default = engines.RECYCLE_EVERY
    with tempfile.TemporaryDirectory() as tmp:
        archive = Path(tmp) / "archive"
        make_archive(archive, args.logs, args.duration)
        kept: list[float] = []
        renewed: list[float] = []
        for r in range(args.rounds):  # alternate the order: no drift favours one
            order = [(kept, 10**9), (renewed, args.every)]
            for times, every in order if r % 2 == 0 else order[::-1]:
                times.append(_time(archive, Path(tmp) / f"out{every}", args.workers, every))
    n = args.logs
    k, rn = statistics.median(kept), statistics.median(renewed)
    renewals = -(-n // (args.workers * args.every)) - 1
    per_renewal = (rn - k) / max(1, renewals)
    print(f"{n} logs, {args.workers} workers, {args.rounds} rounds (median)")
    print(f"workers kept:               {k / n * 1e3:8.1f} ms/log")
    print(f"renewed every {args.every:4d} logs:   {rn / n * 1e3:8.1f} ms/log  ratio {rn / k:.3f}")
    share = per_renewal / (args.workers * default) / (k / n)
    print(
        f"cost per renewal: {per_renewal:.2f} s; at RECYCLE_EVERY={default} "
        f"({args.workers * default} logs per pool): +{share * 100:.2f} % per log"
    )


if __name__ == "__main__":
    main()
