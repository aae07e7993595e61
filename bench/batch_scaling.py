"""How ``logcal batch`` scales with the number of logs: seconds per log for N tiny logs.

    python bench/batch_scaling.py [--sizes 100 1000 3000] [--workers 1]

Each log is a tiny CSV that fails at once (three rows: too short to analyse), so the time is
the batch's own bookkeeping (walk, hashing, manifest or journal, records, fleet table, report),
not the analysis. One fresh archive and output folder per size; a second run over the same
folder (every log already done) is timed too. The marginal time per added log,
(T(N2) - T(N1)) / (N2 - N1), removes the fixed costs (starting the worker pool, the report's
imports): flat means linear, growing with N means worse than linear. Compare ratios, not
absolute times: they depend on the machine's load.
"""

from __future__ import annotations

import argparse
import itertools
import tempfile
import time
from pathlib import Path

from logtools.batch.runner import run_batch
from logtools.batch.worker import AnalysisOptions

TINY = "t,cmd_v,cmd_kappa\n0.0,1.0,0.0\n0.1,1.0,0.0\n0.2,1.0,0.0\n"


def make_archive(root: Path, n: int) -> Path:
    """``n`` tiny CSV logs in folders of 100."""
    for i in range(n):
        folder = root / f"robot{i // 100:03d}"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"log{i:05d}.csv").write_text(TINY)
    return root


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 3000])
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args()
    options = AnalysisOptions(repeats=1, discovery=False, views=False)
    rows = []
    for n in args.sizes:
        with tempfile.TemporaryDirectory(prefix="logcal-scaling-") as tmp:
            archive = make_archive(Path(tmp) / "archive", n)
            out = Path(tmp) / "out"
            t0 = time.perf_counter()
            first = run_batch(archive, out, options=options, workers=args.workers)
            t1 = time.perf_counter()
            again = run_batch(archive, out, options=options, workers=args.workers)
            t2 = time.perf_counter()
            assert first.logs == n, first.logs
            assert len(first.failed) == n, len(first.failed)
            died = [e for _, e in first.failed if "worker analysing this log died" in e]
            assert not died, died[0]  # each log must have been analysed (and refused) by a worker
            assert len(again.skipped) == n, len(again.skipped)
            rows.append((n, t1 - t0, t2 - t1))
            print(
                f"{n:6d} logs: first run {t1 - t0:8.2f} s ({1e3 * (t1 - t0) / n:7.2f} ms/log)"
                f", rerun {t2 - t1:7.2f} s ({1e3 * (t2 - t1) / n:6.2f} ms/log)",
                flush=True,
            )
    print("\nmarginal time per added log (flat = linear):")
    for (n0, f0, a0), (n1, f1, a1) in itertools.pairwise(rows):
        print(
            f"{n0:6d} -> {n1:6d} logs: first run {1e3 * (f1 - f0) / (n1 - n0):7.2f} ms/log, "
            f"rerun {1e3 * (a1 - a0) / (n1 - n0):6.2f} ms/log"
        )
    base_n, base_first, base_again = rows[0]
    print("\nper-log time relative to the smallest archive (1.0 = linear):")
    for n, first_s, again_s in rows:
        print(
            f"{n:6d} logs: first run x{(first_s / n) / (base_first / base_n):5.2f}, "
            f"rerun x{(again_s / n) / (base_again / base_n):5.2f}"
        )


if __name__ == "__main__":
    main()
