"""Peak memory of reading a large CSV log against the size of the frames it gives.

Writes a CSV of ``--gib`` GiB (time ``t`` in s at 100 Hz and six float signals) under
``--dir`` (once; reused when present), then reads it with ``read_log`` in a child process
under an address-space cap (``--cap-gib``) and prints the child's peak RSS, its RSS after the
imports, the frame's size and the ratio (peak - imports) / frame. Same run, no timing
assertion:

    python bench/bench_csv_memory.py --gib 1 --cap-gib 4
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

_CHILD = """
import json, resource, sys, time
cap = int(sys.argv[2])
resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
from logtools.readers import read_log
import polars, numpy
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
t0 = time.perf_counter()
log = read_log(sys.argv[1])
secs = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
frame = log.topics["csv"]
print(json.dumps({"base": base, "peak": peak, "frame": frame.estimated_size(),
                  "rows": frame.height, "cols": frame.width, "secs": secs,
                  "problems": [p.kind.value for p in log.problems]}))
"""


def write_csv(path: Path, gib: float) -> None:
    import numpy as np
    import polars as pl

    target = int(gib * 2**30)
    rng = np.random.default_rng(1)
    rows = 500_000
    t0 = 0.0
    with open(path, "wb") as fh:
        first = True
        while fh.tell() < target:
            t = t0 + np.arange(rows) * 0.01
            frame = pl.DataFrame(
                {
                    "t": t,
                    **{c: rng.normal(size=rows) for c in ("v", "omega", "x", "y", "yaw", "psi")},
                }
            )
            frame.write_csv(fh, include_header=first)
            first = False
            t0 = float(t[-1]) + 0.01


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--gib", type=float, default=1.0)
    ap.add_argument("--cap-gib", type=float, default=4.0)
    ap.add_argument("--dir", type=Path, default=Path("/tmp"))
    args = ap.parse_args()
    path = args.dir / f"logcal_bench_{args.gib:g}gib.csv"
    if not path.exists():
        t0 = time.perf_counter()
        write_csv(path, args.gib)
        print(
            f"wrote {path} ({path.stat().st_size / 2**30:.2f} GiB) in "
            f"{time.perf_counter() - t0:.0f} s"
        )
    cap = int(args.cap_gib * 2**30)
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, str(path), str(cap)],
        capture_output=True,
        text=True,
        check=False,
    )
    if proc.returncode:
        print(f"read failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}")
        return 1
    rec = json.loads(proc.stdout)
    mib = 2**20
    print(
        f"file {path.stat().st_size / mib:.0f} MiB; frame {rec['rows']} x {rec['cols']}, "
        f"{rec['frame'] / mib:.0f} MiB; read in {rec['secs']:.1f} s under a "
        f"{args.cap_gib:g} GiB cap"
    )
    print(
        f"RSS after imports {rec['base'] / mib:.0f} MiB; peak {rec['peak'] / mib:.0f} MiB; "
        f"(peak - imports) / frame = {(rec['peak'] - rec['base']) / rec['frame']:.2f}; "
        f"peak / file = {rec['peak'] / path.stat().st_size:.2f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
