"""The fuzz harnesses' worker fan-in (``fuzz_logs.py``, ``fuzz_parsers.py``): wait for the
worker processes, add up their JSON reports, print the totals and optionally save them."""

from __future__ import annotations

import json
import subprocess
from collections import Counter
from pathlib import Path


def merge_workers(procs: list[subprocess.Popen[bytes]], out: Path, json_out: Path | None) -> int:
    """Wait for ``procs`` (worker j wrote ``out / f"w{j}.json"``), print the summed outcomes
    per kind and the slowest input, write them to ``json_out``; the worst exit code."""
    codes = [p.wait() for p in procs]
    total: Counter[str] = Counter()
    per: Counter[str] = Counter()
    slowest = 0.0
    for j in range(len(procs)):
        rec = json.loads((out / f"w{j}.json").read_text())
        total.update(rec["counts"])
        per.update(rec["per_kind"])
        slowest = max(slowest, rec["slowest_s"])
    print(
        f"\nALL {len(procs)} workers: inputs {sum(total.values())}, outcomes {dict(total)}, "
        f"slowest input {slowest:.2f} s"
    )
    for key in sorted(per):
        print(f"  {key:28s} {per[key]}")
    if json_out is not None:
        json_out.write_text(
            json.dumps({"counts": dict(total), "per_kind": dict(per), "slowest_s": slowest})
        )
    return max(codes)
