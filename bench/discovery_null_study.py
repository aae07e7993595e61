"""Null study of model-mismatch discovery: how often does it report an effect that is not there?

Simulates N runs (default 40) that hold nothing beyond the baseline's physics (random
geometry, command mix, speed and noise; half analysed with the steady-state baseline and
simulated with the steady hitch, half with the transient baseline and transient hitch) and
counts the runs where discovery reports no effect. The target is >= 38 of 40.

    python bench/discovery_null_study.py [--n 40] [--seed 2024]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from discovery_simruns import null_study  # type: ignore[import-not-found]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="number of simulated logs")
    ap.add_argument("--seed", type=int, default=2024, help="seed of the random runs")
    args = ap.parse_args()
    t0 = time.perf_counter()
    res = null_study(args.n, seed=args.seed)
    elapsed = time.perf_counter() - t0
    for i, (base, rep) in enumerate(zip(res.baselines, res.reported, strict=True)):
        print(f"log {i:2d} baseline={base:9s} reported={rep or 'nothing'}")
    print(
        f"no effect reported in {res.n_quiet} of {res.n_logs} null logs "
        f"(target >= {round(0.95 * res.n_logs)}); {elapsed / res.n_logs:.1f} s per log"
    )


if __name__ == "__main__":
    main()
