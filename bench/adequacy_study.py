"""Adequacy study: does logcal say "does not explain" (and where) when a log carries physics
outside its catalogue, stay quiet on clean logs, and avoid confident-wrong parameters?

Logs come from the independent generator ``tests/indgen`` (no logcal code): tractor-trailer,
differential drive and a planar 2-link arm, each either clean (~30 %) or with one
catalogue-escaping kind (``indgen.kinds.KINDS``) at a log-uniform magnitude from barely
detectable to large. Log i of seed s draws everything from ``numpy.random.default_rng([s, i])``:
robot, kind, magnitude, format (JSON MCAP, or CSV 20 %) and the generator seed. Each log is
written to a temporary directory and analysed with ``logtools.analyze.analyze_log`` (discovery
on; the arm with its URDF via ``AnalysisConfig(robot_options=...)``).

Per log: the adequacy verdict (a missing ``adequacy`` key counts as "not assessed"), whether it
located the mismatch (``located`` or ``changes`` non-empty), the named effects of discovery,
per estimated parameter whether it is confident-wrong (identifiable and no true value inside
ci95; for kinds that change a parameter mid-log, the values before and after both count as
true), and three effect sizes of the kind, from the generator (max over channels):

- raw (``effect_size``): RMS change of the recording / noise std;
- refit (``refit_effect_size``): the part of the change of the modelled channels (psi; the diff
  drive's window increments; the arm's torque residual) that a refit of the robot's own
  parameters cannot absorb, / noise (``indgen.refit``);
- held-out (``heldout_effect_size``): the same with the parameters fitted on alternate time
  blocks and evaluated on the others.

Rates with Wilson 95 % intervals and their targets:
- confident-wrong parameters among logs the verdict does not warn about (verdict is not
  "does not explain"): upper bound <= 5 %; also shown over all logs;
- flagged and located among kind logs whose held-out effect size > 2 (the issue's "physics
  raises held-out RMS above 2x the noise"): the final verdict is "does not explain" with the
  misfit located, or the nominal model's verdict (``adequacy.before``) was and discovery named
  the effect that explains it (a catalogued cause found is a mismatch flagged): >= 90 %; the
  same over raw effect size > 2 is printed too (labelled: it counts physics a refit absorbs);
- false alarms ("does not explain" on clean logs): upper bound <= 5 %.

``HELD_OUT_KINDS`` are left out unless ``--include-held-out`` (keep them for the final run).

    python bench/adequacy_study.py --n 40 --seed 1 [--jobs 2] [--robots arm,diff_drive]
        [--kinds stribeck,cogging] [--include-held-out] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import tempfile
import time
import traceback
from collections import defaultdict
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT / "tests") not in sys.path:
    sys.path.insert(0, str(ROOT / "tests"))
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from indgen.arm import ArmParams, full_parameters  # noqa: E402
from indgen.kinds import HELD_OUT_KINDS, KINDS, ROBOTS, draw_magnitude, kinds_of  # noqa: E402
from indgen.robot_writers import write_log  # noqa: E402
from indgen.robots import generate_log  # noqa: E402

__all__ = [
    "draw",
    "generate_and_analyse",
    "main",
    "run_one",
    "summarise",
    "true_values",
    "wilson",
]

CLEAN_SHARE = 0.3
EFFECT_THRESHOLD = 2.0
_DD_NAMES = {"wheel_radius_right": "r_R", "wheel_radius_left": "r_L", "track_width": "b"}


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score 95 % interval of k successes in n (n = 0: (0, 1))."""
    if n == 0:
        return 0.0, 1.0
    p = k / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, mid - half), min(1.0, mid + half)


def draw(
    seed: int,
    i: int,
    robots: Sequence[str],
    kinds: Sequence[str] | None,
    include_held_out: bool,
    clean_share: float = CLEAN_SHARE,
) -> dict[str, Any]:
    """The spec of log ``i`` (robot, kind or None with probability ``clean_share``, magnitude,
    format, generator seed)."""
    rng = np.random.default_rng([seed, i])
    robot = str(rng.choice(list(robots)))
    pool = [
        k for k in kinds_of(robot, include_held_out=include_held_out) if kinds is None or k in kinds
    ]
    kind: str | None = None
    if pool and rng.random() >= clean_share:
        kind = str(rng.choice(pool))
    magnitude = draw_magnitude(rng, kind) if kind else 0.0
    fmt = "csv" if rng.random() < 0.2 else "mcap"
    return {
        "i": i,
        "robot": robot,
        "kind": kind,
        "magnitude": magnitude,
        "fmt": fmt,
        "gen_seed": int(rng.integers(0, 2**31 - 1)),
    }


# ------------------------------------------------------------------ truth of the estimates
_TERM = re.compile(r"\s*([+-])?\s*(?:([0-9.eE+-]+)·)?([A-Za-z_]+\[[^\]]+\])")


def _base_truth(name: str, full: dict[str, float]) -> float | None:
    """The true value of an arm base parameter written out as 'a + 0.371·b - c' (None if a
    name is unknown)."""
    total, pos = 0.0, 0
    for m in _TERM.finditer(name):
        if m.start() != pos and name[pos : m.start()].strip():
            return None
        pos = m.end()
        sign = -1.0 if m.group(1) == "-" else 1.0
        coef = float(m.group(2)) if m.group(2) else 1.0
        if m.group(3) not in full:
            return None
        total += sign * coef * full[m.group(3)]
    return total if pos == len(name) else None


def true_values(truth: dict[str, Any], name: str) -> list[float]:
    """Acceptable true values of estimate ``name`` (several when the kind changes it)."""
    robot, kind = truth["robot"], truth.get("kind")
    if robot == "tractor_trailer":
        L1, L2 = truth["L1"], truth["L2"]
        L2s = [L2, truth["L2_after"]] if kind == "trailer_swap" else [L2]
        if name == "L1":
            return [L1]
        if name == "L2":
            return L2s
        if name in ("sum_L1_L2", "L1+L2"):
            return [L1 + x for x in L2s]
        return []
    if robot == "diff_drive":
        key = _DD_NAMES.get(name)
        if key is None:
            return []
        out = [truth[key]]
        if kind == "radius_change" and key == ("r_L" if truth["wheel"] == "left" else "r_R"):
            out.append(truth[key] * (1 + truth["magnitude"]))
        return out
    fulls = [truth["params"]]
    if kind == "payload_pickup":
        arm = dict(truth["arm"])
        arm["Fc"], arm["Fv"] = tuple(arm["Fc"]), tuple(arm["Fv"])
        fulls.append(full_parameters(ArmParams(**arm).with_tip_mass(truth["magnitude"])))
    vals = [_base_truth(name, f) for f in fulls]
    return [v for v in vals if v is not None]


def _estimates(doc: dict[str, Any]) -> dict[str, dict[str, Any]]:
    est = doc.get("estimate") or {}
    return {k: v for k, v in est.items() if isinstance(v, dict) and "ci95" in v}


def _named(doc: dict[str, Any]) -> list[str]:
    disc = doc.get("discovery") or {}
    if isinstance(disc.get("named"), list):
        return [str(x if not isinstance(x, dict) else x.get("name", x)) for x in disc["named"]]
    out = []
    for e in disc.get("effects") or []:
        out.append(
            str(e.get("label") or e.get("name") or e.get("id") or e)
            if isinstance(e, dict)
            else str(e)
        )
    return out


def _param_checks(doc: dict[str, Any], truth: dict[str, Any]) -> list[dict[str, Any]]:
    out = []
    for name, e in _estimates(doc).items():
        tv = true_values(truth, name)
        if not tv:
            continue
        lo, hi = e["ci95"]
        inside = any(lo is not None and hi is not None and lo <= t <= hi for t in tv)
        ident = bool(e.get("identifiable"))
        out.append(
            {
                "name": name,
                "truth": tv,
                "value": e.get("value"),
                "ci95": [lo, hi],
                "identifiable": ident,
                "confident_wrong": ident and not inside,
            }
        )
    return out


def generate_and_analyse(spec: dict[str, Any], repeats: int = 10) -> tuple[Any, dict[str, Any]]:
    """The log of ``spec`` (a ``draw``) from the independent generator, written to a temporary
    directory and analysed (discovery on; the arm with its URDF): (RobotLog, the result's
    JSON document)."""
    from logtools.analyze import AnalysisConfig, analyze_log, options_from_settings

    log = generate_log(spec["robot"], spec["gen_seed"], spec["kind"], spec["magnitude"])
    with tempfile.TemporaryDirectory(prefix="adequacy_") as d:
        paths = write_log(d, log, fmt=spec["fmt"])
        extra = {"urdf": str(paths["arm.urdf"])} if "arm.urdf" in paths else {}
        _, res = analyze_log(
            paths["log"],
            config=AnalysisConfig(repeats=repeats, robot_options=options_from_settings(extra)),
        )
        doc = res.to_dict()
    return log, doc


def run_one(spec: dict[str, Any], repeats: int = 10) -> dict[str, Any]:
    """Generate, write, analyse one log; the record (never raises: errors are recorded)."""
    t0 = time.perf_counter()
    rec: dict[str, Any] = dict(spec)
    rec["held_out"] = spec["kind"] in HELD_OUT_KINDS
    try:
        log, doc = generate_and_analyse(spec, repeats)
        truth = log.truth
        rec["effect_size"] = truth["max_effect_size"]
        rec["refit_effect_size"] = truth["refit_effect_size"]
        rec["heldout_effect_size"] = truth["heldout_effect_size"]
        rec["refit_seconds"] = truth["refit"]["seconds"]
        rec["effect_channels"] = {k: v for k, v in truth["effect_size"].items() if v > 0}
        rec["truth"] = {k: v for k, v in truth.items() if k not in ("effect_size", "params")}
        ad = doc.get("adequacy") or {"verdict": "not assessed"}
        rec["verdict"] = ad.get("verdict", "not assessed")
        rec["located"] = list(ad.get("located") or [])
        rec["changes"] = list(ad.get("changes") or [])
        rec["is_located"] = bool(rec["located"] or rec["changes"])
        before = ad.get("before") or {}
        # the nominal model's mismatch, when discovery then named what explains it
        rec["before_verdict"] = before.get("verdict")
        rec["before_located"] = bool(before.get("located") or before.get("changes"))
        rec["adequacy_summary"] = ad.get("summary") or ad.get("reason")
        rec["named"] = _named(doc)
        rec["params"] = _param_checks(doc, truth)
        rec["failed_stages"] = [
            s["stage"] for s in doc.get("stages", []) if s.get("status") == "failed"
        ]
        rec["error"] = None
    except Exception as err:  # a crash is a result of the study, not of the script
        rec["error"] = f"{type(err).__name__}: {err}"
        rec["traceback"] = traceback.format_exc(limit=-6)
        for key in ("effect_size", "refit_effect_size", "heldout_effect_size"):
            rec.setdefault(key, None)
        rec.update(
            verdict="error",
            located=[],
            changes=[],
            is_located=False,
            named=[],
            params=[],
            before_verdict=None,
            before_located=False,
        )
    rec["seconds"] = time.perf_counter() - t0
    return rec


# ------------------------------------------------------------------ summary
def _rate(k: int, n: int) -> dict[str, Any]:
    lo, hi = wilson(k, n)
    return {"k": k, "n": n, "rate": (k / n if n else None), "lo": lo, "hi": hi}


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Rates (with Wilson intervals) overall and per (robot, kind)."""
    ok = [r for r in records if r["error"] is None]
    unwarned = [r for r in ok if r["verdict"] != "does not explain"]
    params_all = [p for r in ok for p in r["params"]]
    params_unw = [p for r in unwarned for p in r["params"]]
    big = [r for r in ok if r["kind"] and _big(r)]
    big_raw = [r for r in ok if r["kind"] and _big(r, "effect_size")]
    clean = [r for r in ok if r["kind"] is None]

    def flagged(r: dict[str, Any]) -> bool:
        """The log's mismatch was said and placed: the final verdict does not explain the log
        and locates the misfit, or the nominal model's verdict (``adequacy.before``) did and
        discovery named an effect that explains it."""
        final = r["verdict"] == "does not explain" and r["is_located"]
        named = r.get("before_verdict") == "does not explain" and (
            r.get("before_located") or bool(r.get("named"))
        )
        return bool(final or named)

    out: dict[str, Any] = {
        "n_logs": len(records),
        "n_errors": len(records) - len(ok),
        "confident_wrong_unwarned": _rate(
            sum(p["confident_wrong"] for p in params_unw), len(params_unw)
        ),
        "confident_wrong_all": _rate(
            sum(p["confident_wrong"] for p in params_all), len(params_all)
        ),
        "confident_wrong_logs_unwarned": _rate(
            sum(any(p["confident_wrong"] for p in r["params"]) for r in unwarned), len(unwarned)
        ),
        "flagged_located_big": _rate(sum(flagged(r) for r in big), len(big)),
        "flagged_located_big_raw": _rate(sum(flagged(r) for r in big_raw), len(big_raw)),
        "false_alarm_clean": _rate(
            sum(r["verdict"] == "does not explain" for r in clean), len(clean)
        ),
        "verdicts": dict(sorted(_count(r["verdict"] for r in records).items())),
    }
    cells: dict[str, dict[str, Any]] = {}
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in records:
        groups[(r["robot"], r["kind"] or "clean")].append(r)
    for (robot, kind), rs in sorted(groups.items()):
        good = [r for r in rs if r["error"] is None]
        b = [r for r in good if _big(r)]
        b_raw = [r for r in good if _big(r, "effect_size")]
        ps = [p for r in good for p in r["params"]]
        cells[f"{robot}/{kind}"] = {
            "robot": robot,
            "kind": kind,
            "n": len(rs),
            "errors": len(rs) - len(good),
            "held_out": kind in HELD_OUT_KINDS,
            "median_effect": _median(good, "effect_size"),
            "median_refit_effect": _median(good, "refit_effect_size"),
            "median_heldout_effect": _median(good, "heldout_effect_size"),
            "n_big": len(b),
            "n_big_raw": len(b_raw),
            "flagged": sum(r["verdict"] == "does not explain" for r in good),
            "flagged_located_big": sum(flagged(r) for r in b),
            "flagged_located_big_raw": sum(flagged(r) for r in b_raw),
            "named_any": sum(bool(r["named"]) for r in good),
            "cw_params": sum(p["confident_wrong"] for p in ps),
            "n_params": len(ps),
        }
    out["cells"] = cells
    return out


def _big(r: dict[str, Any], key: str = "heldout_effect_size") -> bool:
    """The kind's effect (held-out by default, or ``key``) exceeds ``EFFECT_THRESHOLD``."""
    return (r.get(key) or 0.0) > EFFECT_THRESHOLD


def _median(rs: list[dict[str, Any]], key: str) -> float | None:
    vals = [r[key] for r in rs if r.get(key) is not None]
    return float(np.median(vals)) if vals else None


def _count(xs: Any) -> dict[str, int]:
    c: dict[str, int] = defaultdict(int)
    for x in xs:
        c[str(x)] += 1
    return dict(c)


def _fmt_rate(r: dict[str, Any]) -> str:
    if not r["n"]:
        return "  n/a (n = 0)"
    lo, hi = 100 * r["lo"], 100 * r["hi"]
    return f"{r['k']:>3}/{r['n']:<4} {100 * r['rate']:5.1f} %  [{lo:5.1f}, {hi:5.1f}]"


def print_table(summary: dict[str, Any], seconds: float) -> None:
    """The compact table and the three target rates."""
    hdr = (
        f"{'robot/kind':40} {'n':>3} {'err':>3} {'med raw':>8} {'refit':>7} {'h-out':>7} "
        f"{'ho>2':>4} {'fl+loc':>6} {'raw>2':>5} {'fl+loc':>6} {'flag':>4} {'named':>5} "
        f"{'cw/par':>7}"
    )
    print(hdr)
    print("-" * len(hdr))

    def g(x: float | None, w: int) -> str:
        return f"{'-' if x is None else f'{x:.3g}':>{w}}"

    for key, c in summary["cells"].items():
        mark = " (held out)" if c["held_out"] else ""
        print(
            f"{key + mark:40} {c['n']:>3} {c['errors']:>3} {g(c['median_effect'], 8)} "
            f"{g(c['median_refit_effect'], 7)} {g(c['median_heldout_effect'], 7)} "
            f"{c['n_big']:>4} {c['flagged_located_big']:>6} {c['n_big_raw']:>5} "
            f"{c['flagged_located_big_raw']:>6} {c['flagged']:>4} {c['named_any']:>5} "
            f"{c['cw_params']:>3}/{c['n_params']:<3}"
        )
    print("-" * len(hdr))
    print(
        "effect sizes (medians, noise units): raw = change of the recording, refit = what a "
        "refit of the robot's parameters leaves of it, h-out = the same held out; "
        "ho>2 / raw>2: logs above 2, fl+loc: of those flagged and located"
    )
    print(
        f"logs {summary['n_logs']}, errors {summary['n_errors']}, verdicts "
        f"{summary['verdicts']}, {seconds:.0f} s"
    )
    s = summary
    print(
        f"confident-wrong params, unwarned logs: {_fmt_rate(s['confident_wrong_unwarned'])}"
        "  target: upper <= 5 %"
    )
    print(f"confident-wrong params, all logs:      {_fmt_rate(s['confident_wrong_all'])}")
    print(f"logs with any confident-wrong (unw.):  {_fmt_rate(s['confident_wrong_logs_unwarned'])}")
    print(
        f"flagged+located, held-out effect > 2:  {_fmt_rate(s['flagged_located_big'])}"
        "  target: >= 90 %"
    )
    print(f"  (raw effect size > 2, refit ignored: {_fmt_rate(s['flagged_located_big_raw'])})")
    print(
        f"false alarms on clean logs:            {_fmt_rate(s['false_alarm_clean'])}"
        "  target: upper <= 5 %"
    )


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
    specs = [draw(seed, i, robots, kinds, include_held_out) for i in range(n)]
    if jobs <= 1:
        return [run_one(s, repeats) for s in specs]
    with ProcessPoolExecutor(max_workers=jobs) as ex:
        return list(ex.map(_run, [(s, repeats) for s in specs]))


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--robots", default=",".join(ROBOTS))
    ap.add_argument("--kinds", default=None, help="comma-separated kinds (default: all)")
    ap.add_argument("--include-held-out", action="store_true")
    ap.add_argument("--json", default=None, help="write records and summary to this file")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=10, help="AnalysisConfig.repeats")
    a = ap.parse_args(argv)
    robots = [r.strip() for r in a.robots.split(",") if r.strip()]
    bad = set(robots) - set(ROBOTS)
    kinds = [k.strip() for k in a.kinds.split(",")] if a.kinds else None
    if bad or (kinds and set(kinds) - set(KINDS)):
        ap.error(f"unknown robots/kinds; robots: {ROBOTS}, kinds: {sorted(KINDS)}")
    if kinds and not a.include_held_out and set(kinds) & HELD_OUT_KINDS:
        ap.error(f"{sorted(set(kinds) & HELD_OUT_KINDS)} are held out: add --include-held-out")
    if kinds:
        robots = [r for r in robots if any(KINDS[k].robot == r for k in kinds)]
    t0 = time.perf_counter()
    records = run_study(a.n, a.seed, robots, kinds, a.include_held_out, a.jobs, a.repeats)
    return report_study(a, records, summarise, print_table, t0)


def report_study(
    a: argparse.Namespace,
    records: list[dict[str, Any]],
    summarise: Callable[[list[dict[str, Any]]], dict[str, Any]],
    print_table: Callable[[dict[str, Any], float], None],
    t0: float,
) -> int:
    """A study's end: its table, the logs that failed, and the records and summary written to
    ``--json`` (shared by this study and ``explanation_study.py``)."""
    summary = summarise(records)
    print_table(summary, time.perf_counter() - t0)
    for r in records:
        if r["error"]:
            print(f"  log {r['i']} ({r['robot']}/{r['kind']}): {r['error']}")
    if a.json:
        Path(a.json).write_text(
            json.dumps(
                {"args": vars(a), "summary": summary, "records": records}, indent=1, default=str
            )
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
