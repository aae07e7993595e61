"""Discovery through windows on long logs: does it name what whole-log discovery names?

``discover`` looks at a log longer than ``max_span_s`` (default 600 s) through windows spread
evenly over it (``calib.tractor_trailer.discovery.windows``). This study draws long logs (15-30
min) from the
independent generator ``tests/indgen`` with the same truth distribution as
``bench/discovery_confusion_study.py`` (clean, one effect, two effects, uncatalogued slip; any
speed and topic-rate condition; the command a random sum of sines (``--command random``, the
default), since the patent's H/C/L shapes stretched over half an hour leave most effects
undetectable in either mode; ``--command any`` draws them too) and runs discovery on each log
twice: through the default windows and on the whole log. It reports, with Wilson 95 % intervals:

- agreement: the named sets are the same;
- logs with an effect outside the catalogue (trailer slip) where catalogue effects were named;
- named right (exact, or the true set among the listed equivalents) in each mode, over the
  logs with a catalogued truth, and false alarms on clean logs in each mode (no
  detectability filter here: both modes see the same logs, so the comparison is paired);
- coverage of the named true effects' 95 % intervals in each mode;
- CPU seconds of discovery per log in each mode (min, median, max) and their ratio.

    python bench/discovery_window_study.py [--n 24] [--seed 7] [--command random|any]
        [--json out.json] [--merge a.json ...]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

import discovery_confusion_study as study  # noqa: E402

DURATION_S = (900.0, 1800.0)


def _wilson(k: int, n: int) -> str:
    if n == 0:
        return "n/a (0 logs)"
    z = 1.959964
    p = k / n
    den = 1 + z * z / n
    c = (p + z * z / (2 * n)) / den
    h = z * ((p * (1 - p) / n + z * z / (4 * n * n)) ** 0.5) / den
    return f"{k}/{n} = {100 * p:.1f} % [{100 * (c - h):.1f}, {100 * (c + h):.1f}]"


def run_one(seed: int, i: int, command: str | None = "random") -> dict[str, Any]:
    from calib.tractor_trailer.discovery import discover

    rng = np.random.default_rng([seed, i])
    truth = study.draw_truth(rng)
    rec: dict[str, Any] = {"seed": seed, "i": i, "truth": truth, "baseline": "transient"}
    frame, L1, L2, cond = study.frame_indgen(rng, truth, seed * 100003 + i, DURATION_S, command)
    signals = cond.pop("signals", None)
    rec["duration_s"] = cond["duration_s"]
    f1, f2 = (float(x) for x in rng.uniform(0.9, 1.1, 2))
    for mode, span in (("windows", None), ("whole", 0.0)):
        kw = {} if span is None else {"max_span_s": span}
        c0 = time.process_time()
        res = discover(frame, L1 * f1, L2 * f2, signals=signals, **kw)  # type: ignore[arg-type]
        rec[mode] = {
            "cpu_s": time.process_time() - c0,
            "status": res.status,
            "named": [e.label for e in res.effects],
            "params": {
                e.label: {k: [e.parameters[k], *e.ci95[k]] for k in e.parameters}
                for e in res.effects
            },
            "alternatives": [[list(a.reported), list(a.alternative)] for a in res.alternatives],
            "used_s": None if res.windows is None else res.windows.used_s,
        }
    return rec


def _as_study_record(rec: dict[str, Any], mode: str) -> dict[str, Any]:
    return {**rec[mode], "truth": rec["truth"], "baseline": rec["baseline"]}


def tabulate(recs: list[dict[str, Any]]) -> str:
    lines = [f"{len(recs)} logs of {DURATION_S[0]:.0f}-{DURATION_S[1]:.0f} s (indgen)"]
    same = sum(set(r["windows"]["named"]) == set(r["whole"]["named"]) for r in recs)
    lines.append(f"same named set, windows vs whole: {_wilson(same, len(recs))}")
    for mode in ("windows", "whole"):
        srecs = [_as_study_record(r, mode) for r in recs]
        with_truth = [s for s in srecs if study._true_set(s)]
        clean = [s for s in srecs if not s["truth"]]
        right = sum(study.correct(s)[1] for s in with_truth)
        alarms = sum(bool(study._named_set(s)) for s in clean)
        slip = [s for s in srecs if s["truth"] and not study._true_set(s)]
        slip_named = sum(bool(study._named_set(s)) for s in slip)
        hit = tot = 0
        for s in srecs:
            for label, truth_p in s["truth"].items():
                got = s["params"].get(label)
                if got is None:
                    continue
                for k, v in truth_p.items():
                    if k in got:
                        tot += 1
                        hit += got[k][1] <= v <= got[k][2]
        cpu = [r[mode]["cpu_s"] for r in recs]
        lines.append(
            f"{mode:8s} named right (exact or equivalent) {_wilson(right, len(with_truth))}; "
            f"false alarms {_wilson(alarms, len(clean))}; uncatalogued effect (trailer slip) "
            f"taken for catalogue effects {_wilson(slip_named, len(slip))}; "
            f"interval coverage {_wilson(hit, tot)}; "
            f"CPU s min/median/max {min(cpu):.1f}/{statistics.median(cpu):.1f}/{max(cpu):.1f}"
        )
    ratio = [r["whole"]["cpu_s"] / r["windows"]["cpu_s"] for r in recs]
    lines.append(f"whole / windows CPU ratio: median {statistics.median(ratio):.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=24)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--json", default=None)
    ap.add_argument("--command", default="random", help="command shape, or 'any' (random)")
    ap.add_argument("--merge", nargs="*", default=None, help="only tabulate these record files")
    args = ap.parse_args(argv)
    if args.merge:
        recs = [r for f in args.merge for r in json.loads(Path(f).read_text())]
    else:
        recs = []
        for i in range(args.n):
            rec = run_one(args.seed, i, None if args.command == "any" else args.command)
            recs.append(rec)
            print(
                f"log {i}: {rec['duration_s']:.0f} s truth {sorted(rec['truth'])} "
                f"windows {rec['windows']['named']} ({rec['windows']['cpu_s']:.1f} s) "
                f"whole {rec['whole']['named']} ({rec['whole']['cpu_s']:.1f} s)",
                flush=True,
            )
            if args.json:
                Path(args.json).write_text(json.dumps(recs))
    out = tabulate(recs)
    print(out)
    return out


if __name__ == "__main__":
    main()
