"""Explanation study (issue 30): when a log carries physics outside logcal's catalogues, does
discovery model it (name it correctly or describe the residual), does the held-out fit improve,
and do the intervals the report prints (the estimate's and the alternatives') hold the truth?

Logs come from the independent generator ``tests/indgen`` (no logcal code), drawn as in
``bench/adequacy_study.py`` (whose drawing, writing, analysis and truth machinery this reuses):
tractor-trailer, differential drive and a planar 2-link arm, each clean (``CLEAN_SHARE``) or
with one kind (``indgen.kinds.KINDS``) at a log-uniform magnitude. Per log, from the result's
``discovery`` (the shared shape: ``effects[]`` with ``status`` "named"/"described", ``key``,
``parameters``; ``named``, ``described``, ``remaining``, ``verdict_before``/``verdict_after``,
``heldout_before``/``heldout_after``, ``alternatives[]``) and its ``estimate``:

- found: discovery reports an effect (named or described);
- improved: ``heldout_after < heldout_before``;
- explains / described: ``verdict_after`` is "explains", or the residual the final model leaves
  is described (``discovery.described``: described terms, or ``remaining`` words);
- every printed interval (the estimate's parameters, each alternative's parameters) with a
  known true value; confident-wrong: marked identifiable and no true value inside its ci95;
- false names: named keys that are neither in the kind's ``accepted_names`` nor in the robot's
  ``BASELINE_NAMES`` (physics every log of that generator has); on clean logs only the
  baseline names are correct.

A discovery result without the shared shape (the arm's own record: ``named_keys``,
``findings``, ``selection``) is read through its own fields: ``shape`` = "robot" in the record
(named effects only; the held-out sums from ``selection``; the verdicts from ``adequacy``).

Metrics, each with a Wilson 95 % interval, and their targets (issue 30, "Must show"):

- modelled and improved, among kind logs with held-out effect size > 2: found AND improved AND
  (explains OR described): >= 80 %;
- confident-wrong over every printed interval: Wilson upper <= 2 %;
- false catalogue names (logs with one, over all logs; also per named effect): <= 5 %;
- false alarms ("does not explain" on clean logs): Wilson upper <= 5 %.

    python bench/explanation_study.py --n 60 --seed 1 [--jobs 1] [--kinds a,b] [--new-only]
        [--include-held-out] [--json out.json]
    python bench/explanation_study.py --from-json out.json   # re-tabulate, names rescored
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import traceback
from collections import defaultdict
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT / "tests", ROOT / "bench", ROOT):
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))

from adequacy_study import (  # noqa: E402
    draw,
    generate_and_analyse,
    report_study,
    true_values,
    wilson,
)
from indgen.kinds import (  # noqa: E402
    BASELINE_NAMES,
    HELD_OUT_KINDS,
    KINDS,
    NEW_KINDS,
    ROBOTS,
    is_correct_name,
)

__all__ = [
    "CLEAN_SHARE",
    "EFFECT_THRESHOLD",
    "analyse_record",
    "main",
    "modelled_and_improved",
    "rescore_names",
    "run_one",
    "run_study",
    "summarise",
]

CLEAN_SHARE = 0.25
EFFECT_THRESHOLD = 2.0
"""A kind log counts for "modelled and improved" when its held-out effect size exceeds this."""


# ------------------------------------------------------------------ reading the result
def _num(x: Any) -> float:
    """``x`` as a float (None, strings, non-finite: nan)."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v if math.isfinite(v) else math.nan


def _bound(x: Any, missing: float) -> float:
    """An interval end (None or unreadable: ``missing``, i.e. unbounded; infinities kept)."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return missing
    return missing if math.isnan(v) else v


def _verdict(rec: Any) -> dict[str, Any] | None:
    if not isinstance(rec, dict):
        return None
    return {k: rec.get(k) for k in ("verdict", "ratio", "channel")}


def _shared_view(doc: dict[str, Any]) -> dict[str, Any]:
    """The discovery fields the study reads, from the shared shape or the arm's own record."""
    disc = doc.get("discovery") or {}
    ad = doc.get("adequacy") or {}
    if "effects" in disc or "verdict_after" in disc:
        effects = [
            {
                "key": str(e.get("key")),
                "status": str(e.get("status")),
                "parameters": e.get("parameters") or {},
            }
            for e in disc.get("effects") or []
            if isinstance(e, dict)
        ]
        return {
            "shape": "shared",
            "status": disc.get("status"),
            "effects": effects,
            "named": [str(x) for x in disc.get("named") or []],
            "described": bool(disc.get("described")),
            "remaining": str(disc.get("remaining") or ""),
            "verdict_before": _verdict(disc.get("verdict_before")),
            "verdict_after": _verdict(disc.get("verdict_after")),
            "heldout_before": _num(disc.get("heldout_before")),
            "heldout_after": _num(disc.get("heldout_after")),
            "alternatives": [a for a in disc.get("alternatives") or [] if isinstance(a, dict)],
        }
    keys = [str(k) for k in disc.get("named_keys") or []]
    sel = disc.get("selection") or {}
    before = ad.get("before") or {}
    return {
        "shape": "robot" if disc else "none",
        "status": disc.get("status"),
        "effects": [{"key": k, "status": "named", "parameters": {}} for k in keys],
        "named": keys,
        "described": False,
        "remaining": "",
        "verdict_before": {"verdict": before.get("verdict") or ad.get("verdict")},
        "verdict_after": {"verdict": ad.get("verdict")},
        "heldout_before": _num(sel.get("heldout_sse_before")),
        "heldout_after": _num(sel.get("heldout_sse_after")),
        "alternatives": [],
    }


def _interval(
    source: str, name: str, e: dict[str, Any], truth: dict[str, Any]
) -> dict[str, Any] | None:
    """One printed interval with its true values (None: no ci95, or no known truth)."""
    ci = e.get("ci95")
    if not isinstance(ci, list | tuple) or len(ci) != 2:
        return None
    tv = true_values(truth, name)
    if not tv:
        return None
    lo, hi = _bound(ci[0], -math.inf), _bound(ci[1], math.inf)
    inside = any(lo <= t <= hi for t in tv)
    ident = bool(e.get("identifiable"))
    return {
        "source": source,
        "name": name,
        "value": _num(e.get("value")),
        "ci95": [lo, hi],
        "truth": tv,
        "identifiable": ident,
        "confident_wrong": ident and not inside,
    }


def _intervals(
    doc: dict[str, Any], view: dict[str, Any], truth: dict[str, Any]
) -> tuple[list[dict[str, Any]], int]:
    """Every printed interval with a known truth, and how many printed ones had no known truth."""
    out: list[dict[str, Any]] = []
    unknown = 0
    est = doc.get("estimate") or {}
    sources = [("estimate", est)] + [
        (f"alternative: {a.get('label', '?')}", a.get("parameters") or {})
        for a in view["alternatives"]
    ]
    for source, params in sources:
        for name, e in params.items():
            if not isinstance(e, dict) or "ci95" not in e:
                continue
            iv = _interval(source, str(e.get("name") or name), e, truth)
            if iv is None:
                unknown += 1
            else:
                out.append(iv)
    return out, unknown


def _correct_names(robot: str, kind: str | None) -> set[str]:
    """The catalogue keys that name a log of ``robot`` with ``kind`` correctly."""
    correct = set(BASELINE_NAMES.get(robot, ()))
    if kind is not None:
        correct |= set(KINDS[kind].accepted_names)
    return correct


def rescore_names(rec: dict[str, Any]) -> dict[str, Any]:
    """``rec``'s accepted and false names recomputed from its named keys under the current
    ``accepted_names`` (for ``--from-json``: re-tabulate stored records without rerunning)."""
    if rec.get("error") is None:
        correct = _correct_names(rec["robot"], rec["kind"])
        rec["accepted_names"] = sorted(correct)
        rec["false_names"] = [k for k in rec["named"] if not is_correct_name(k, correct)]
    return rec


def analyse_record(
    rec: dict[str, Any], doc: dict[str, Any], truth: dict[str, Any]
) -> dict[str, Any]:
    """``rec`` (a spec) completed with what the study reads from the result ``doc``."""
    view = _shared_view(doc)
    correct = _correct_names(rec["robot"], rec["kind"])
    named = [e["key"] for e in view["effects"] if e["status"] == "named"]
    described_effects = [e["key"] for e in view["effects"] if e["status"] == "described"]
    intervals, unknown = _intervals(doc, view, truth)
    ad = doc.get("adequacy") or {}
    va = view["verdict_after"] or {}
    rec.update(
        shape=view["shape"],
        discovery_status=view["status"],
        named=named,
        described_effects=described_effects,
        described=view["described"],
        remaining=view["remaining"],
        verdict_before=view["verdict_before"],
        verdict_after=view["verdict_after"],
        heldout_before=view["heldout_before"],
        heldout_after=view["heldout_after"],
        verdict=ad.get("verdict", "not assessed"),
        effects=[
            {
                "key": e["key"],
                "status": e["status"],
                "parameters": {
                    n: {"value": p.get("value"), "ci95": p.get("ci95")}
                    for n, p in e["parameters"].items()
                    if isinstance(p, dict)
                },
            }
            for e in view["effects"]
        ],
        found=bool(view["effects"]),
        improved=view["heldout_after"] < view["heldout_before"],
        explains_after=va.get("verdict") == "explains",
        false_names=[k for k in named if not is_correct_name(k, correct)],
        accepted_names=sorted(correct),
        intervals=intervals,
        intervals_without_truth=unknown,
    )
    return rec


def run_one(spec: dict[str, Any], repeats: int = 10) -> dict[str, Any]:
    """Generate, write, analyse one log; its record (never raises: errors are recorded)."""
    t0 = time.perf_counter()
    rec: dict[str, Any] = dict(spec)
    rec["held_out"] = spec["kind"] in HELD_OUT_KINDS
    rec["new_kind"] = spec["kind"] in NEW_KINDS
    try:
        log, doc = generate_and_analyse(spec, repeats)
        truth = log.truth
        rec["effect_size"] = truth["max_effect_size"]
        rec["heldout_effect_size"] = truth["heldout_effect_size"]
        rec["truth_kind"] = truth.get("kind")
        rec["truth"] = {
            k: v
            for k, v in truth.items()
            if k not in ("effect_size", "params", "refit", "refit_effect_channels")
        }
        analyse_record(rec, doc, truth)
        rec["error"] = None
    except Exception as err:  # a crash is a result of the study, not of the script
        rec["error"] = f"{type(err).__name__}: {err}"
        rec["traceback"] = traceback.format_exc(limit=-6)
    rec["seconds"] = time.perf_counter() - t0
    return rec


# ------------------------------------------------------------------ metrics
def _rate(k: int, n: int) -> dict[str, Any]:
    lo, hi = wilson(k, n)
    return {"k": k, "n": n, "rate": (k / n if n else None), "lo": lo, "hi": hi}


def _big(r: dict[str, Any]) -> bool:
    return r["kind"] is not None and (r.get("heldout_effect_size") or 0.0) > EFFECT_THRESHOLD


def modelled_and_improved(r: dict[str, Any]) -> bool:
    """Discovery found something, the held-out error fell, and the final model explains the log
    or what it leaves is described."""
    return bool(r["found"] and r["improved"] and (r["explains_after"] or r["described"]))


def failure(r: dict[str, Any]) -> str:
    """Why a log is not modelled and improved (the first missing condition)."""
    if not r["found"]:
        return "nothing found"
    if not r["improved"]:
        return "held-out not lower"
    if not (r["explains_after"] or r["described"]):
        return "not explained, not described"
    return ""


def _metrics(rs: list[dict[str, Any]]) -> dict[str, Any]:
    big = [r for r in rs if _big(r)]
    clean = [r for r in rs if r["kind"] is None]
    ivs = [iv for r in rs for iv in r["intervals"]]
    ident = [iv for iv in ivs if iv["identifiable"]]
    n_named = sum(len(r["named"]) for r in rs)
    fails: dict[str, int] = defaultdict(int)
    for r in big:
        if not modelled_and_improved(r):
            fails[failure(r)] += 1
    return {
        "n": len(rs),
        "n_big": len(big),
        "modelled_and_improved": _rate(sum(modelled_and_improved(r) for r in big), len(big)),
        "found_big": sum(r["found"] for r in big),
        "improved_big": sum(r["improved"] for r in big),
        "explains_or_described_big": sum(r["explains_after"] or r["described"] for r in big),
        "failures_big": dict(fails),
        "confident_wrong": _rate(sum(iv["confident_wrong"] for iv in ident), len(ident)),
        "intervals": len(ivs),
        "intervals_without_truth": sum(r["intervals_without_truth"] for r in rs),
        "false_name_logs": _rate(sum(bool(r["false_names"]) for r in rs), len(rs)),
        "false_names": _rate(sum(len(r["false_names"]) for r in rs), n_named),
        "false_alarm_clean": _rate(
            sum(r["verdict"] == "does not explain" for r in clean), len(clean)
        ),
        "found_any": sum(r["found"] for r in rs),
    }


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The metrics overall, over the new kinds (plus the clean logs), per robot and per
    (robot, kind)."""
    ok = [r for r in records if r["error"] is None]
    out: dict[str, Any] = {
        "n_logs": len(records),
        "n_errors": len(records) - len(ok),
        "shapes": dict(sorted(_count(r["shape"] for r in ok).items())),
        "overall": _metrics(ok),
        "new_kinds": _metrics([r for r in ok if r["kind"] is None or r["new_kind"]]),
    }
    out["robots"] = {
        robot: _metrics([r for r in ok if r["robot"] == robot])
        for robot in sorted({r["robot"] for r in ok})
    }
    groups: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for r in ok:
        groups[f"{r['robot']}/{r['kind'] or 'clean'}"].append(r)
    out["cells"] = {k: _metrics(v) for k, v in sorted(groups.items())}
    out["named_by_cell"] = {
        k: dict(sorted(_count(n for r in v for n in r["named"]).items()))
        for k, v in sorted(groups.items())
    }
    return out


def _count(xs: Any) -> dict[str, int]:
    c: dict[str, int] = defaultdict(int)
    for x in xs:
        c[str(x)] += 1
    return dict(c)


# ------------------------------------------------------------------ printing
def _fmt_rate(r: dict[str, Any]) -> str:
    if not r["n"]:
        return "  n/a (n = 0)"
    lo, hi = 100 * r["lo"], 100 * r["hi"]
    return f"{r['k']:>3}/{r['n']:<4} {100 * r['rate']:5.1f} %  [{lo:5.1f}, {hi:5.1f}]"


def _kr(r: dict[str, Any]) -> str:
    return f"{r['k']}/{r['n']}"


def print_table(summary: dict[str, Any], seconds: float) -> None:
    """The table per (robot, kind), then the four metrics overall and per robot."""
    hdr = (
        f"{'robot/kind':36} {'n':>3} {'ho>2':>4} {'mod+imp':>7} {'found':>5} {'impr':>4} "
        f"{'expl|des':>8} {'falsename':>9} {'cw/ivals':>8} {'falarm':>6}  failures (ho>2)"
    )
    print(hdr)
    print("-" * len(hdr))
    for key, c in summary["cells"].items():
        kind = key.split("/", 1)[1]
        mark = " (held out)" if kind in HELD_OUT_KINDS else (" (new)" if kind in NEW_KINDS else "")
        fails = ", ".join(f"{v} {k}" for k, v in sorted(c["failures_big"].items()))
        falarm = _kr(c["false_alarm_clean"]) if kind == "clean" else "-"
        print(
            f"{key + mark:36} {c['n']:>3} {c['n_big']:>4} {_kr(c['modelled_and_improved']):>7} "
            f"{c['found_big']:>5} {c['improved_big']:>4} {c['explains_or_described_big']:>8} "
            f"{_kr(c['false_name_logs']):>9} {_kr(c['confident_wrong']):>8} {falarm:>6}  {fails}"
        )
    print("-" * len(hdr))
    print(
        "ho>2: kind logs with held-out effect > 2 (noise units); mod+imp of those: found, "
        "held-out lower, explains or described; found/impr/expl|des: each condition among "
        "ho>2; falsename: logs with a wrong catalogue name; cw/ivals: confident-wrong among "
        "identifiable printed intervals with a known truth"
    )
    print(
        f"logs {summary['n_logs']}, errors {summary['n_errors']}, discovery shapes "
        f"{summary['shapes']}, {seconds:.0f} s"
    )
    for label, m in [("ALL", summary["overall"]), ("NEW KINDS + clean", summary["new_kinds"])] + [
        (robot, m) for robot, m in summary["robots"].items()
    ]:
        print(f"== {label}")
        print(f"  modelled and improved (ho > 2): {_fmt_rate(m['modelled_and_improved'])}  >= 80 %")
        print(
            f"  confident-wrong intervals:      {_fmt_rate(m['confident_wrong'])}  upper <= 2 %"
            f"  ({m['intervals']} intervals with a truth, {m['intervals_without_truth']} without)"
        )
        print(f"  logs with a false name:         {_fmt_rate(m['false_name_logs'])}  <= 5 %")
        print(f"  false names / named effects:    {_fmt_rate(m['false_names'])}")
        fa = _fmt_rate(m["false_alarm_clean"])
        print(f"  false alarms on clean logs:     {fa}  upper <= 5 %")


# ------------------------------------------------------------------ running
def _run(args: tuple[dict[str, Any], int]) -> dict[str, Any]:
    return run_one(*args)


def run_study(
    n: int,
    seed: int,
    robots: Sequence[str],
    kinds: Sequence[str] | None,
    include_held_out: bool,
    jobs: int = 1,
    repeats: int = 10,
) -> list[dict[str, Any]]:
    """The records of logs 0 .. n-1 (in order)."""
    specs = [draw(seed, i, robots, kinds, include_held_out, CLEAN_SHARE) for i in range(n)]
    if jobs <= 1:
        return [run_one(s, repeats) for s in specs]
    with ProcessPoolExecutor(max_workers=jobs) as ex:
        return list(ex.map(_run, [(s, repeats) for s in specs]))


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--kinds", default=None, help="comma-separated kinds (default: all)")
    ap.add_argument("--new-only", action="store_true", help="only the kinds added for issue 30")
    ap.add_argument("--include-held-out", action="store_true")
    ap.add_argument("--json", default=None, help="write records and summary to this file")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=10, help="AnalysisConfig.repeats")
    ap.add_argument(
        "--from-json",
        default=None,
        help="re-tabulate the records of an earlier --json run (names rescored) instead of running",
    )
    a = ap.parse_args(argv)
    if a.from_json:
        stored = json.loads(Path(a.from_json).read_text())
        records = [rescore_names(r) for r in stored["records"]]
        print_table(summarise(records), 0.0)
        return 0
    robots = [r.strip() for r in a.robots.split(",") if r.strip()]
    kinds = [k.strip() for k in a.kinds.split(",")] if a.kinds else None
    if a.new_only:
        kinds = [k for k in (kinds or NEW_KINDS) if k in NEW_KINDS]
    if set(robots) - set(ROBOTS) or (kinds and set(kinds) - set(KINDS)):
        ap.error(f"unknown robots/kinds; robots: {ROBOTS}, kinds: {sorted(KINDS)}")
    if kinds and not a.include_held_out:
        kinds = [k for k in kinds if k not in HELD_OUT_KINDS]
    if kinds is not None:
        robots = [r for r in robots if any(KINDS[k].robot == r for k in kinds)]
    if not robots:
        ap.error("no robot has one of the chosen kinds")
    t0 = time.perf_counter()
    records = run_study(a.n, a.seed, robots, kinds, a.include_held_out, a.jobs, a.repeats)
    return report_study(a, records, summarise, print_table, t0)


if __name__ == "__main__":
    raise SystemExit(main())
