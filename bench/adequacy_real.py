"""Every real recording in ../shared/realworld_*: does logcal's model explain it?

For each recording (OptiOdom sessions, the Jackal bag, the DFKI double-pendulum runs, the TIAGo
arm, the rosbag2 test MCAP files) the analysis ``logcal analyze`` runs, and one row: the robot,
the adequacy verdict, the worst channel's residual over its noise floor (held out where the
robot holds data out), where the misfit sits, what discovery named, what stays unexplained and
whether any estimate is still "determined" under a misfit (that would be a defect). A recording
that cannot be analysed says why (the rosbag2 test files hold no drive signals).

    python bench/adequacy_real.py [--shared DIR] [--json out.json]
    python bench/adequacy_real.py --compare before.json after.json   # a before -> after table
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from logtools.analyze import AnalysisConfig, analyze_logs, options_from_settings
from logtools.errors import LogcalInputError
from logtools.runs import expand_runs

ROOT = Path(__file__).resolve().parents[2] / "shared"


def recordings(shared: Path) -> list[tuple[str, list[Path], dict[str, Any]]]:
    """(name, paths, extra settings) of every real recording."""
    out: list[tuple[str, list[Path], dict[str, Any]]] = []
    opti = shared / "realworld_drive/optiodom"
    for session in sorted(p for p in opti.glob("*/*") if p.is_dir()):
        out.append((f"optiodom/{session.parent.name}/{session.name}", [session], {}))
    jackal = shared / "realworld_drive/jackal/jackal_odom_imu.bag"
    if jackal.exists():
        out.append(("jackal", [jackal], {}))
    dfki = shared / "realworld_arm/dfki_double_pendulum"
    urdf = dfki / "design_C.0_model_3.1_acrobot.urdf"
    for run in sorted(dfki.glob("*.mcap")):
        out.append((f"dfki/{run.stem}", [run], {"urdf": str(urdf)}))
    tiago = shared / "realworld_arm/tiago_arm/tiago_arm_identification.mcap"
    if tiago.exists():
        out.append(("tiago", [tiago], {"urdf": "tiago"}))
    for f in sorted((shared / "realworld_mcap").glob("*.mcap")):
        out.append((f"mcap/{f.name}", [f], {}))
    return out


def row(name: str, paths: list[Path], extra: dict[str, Any]) -> dict[str, Any]:
    t0 = time.process_time()
    try:
        runs = expand_runs(paths)  # a session folder: its runs, as the CLI reads it
        config = AnalysisConfig(robot_options=options_from_settings(extra))
        _, res = analyze_logs(runs, config=config)
    except LogcalInputError as err:
        return {
            "recording": name,
            "robot": "-",
            "verdict": "not analysed",
            "why": str(err).splitlines()[0][:160],
        }
    d = res.to_dict()
    adequacy = d.get("adequacy") or {}
    channels = adequacy.get("channels") or []
    worst = max(channels, key=lambda c: c.get("judged_ratio") or 0.0, default=None)
    located = [loc["label"] for loc in adequacy.get("located") or []][:3]
    disc = d.get("discovery") or {}
    if isinstance(disc.get("named"), list):
        named = [str(x if not isinstance(x, dict) else x.get("name", x)) for x in disc["named"]]
    else:
        named = [
            str(e.get("label") or e.get("name") or e.get("key") or e.get("id") or e)
            if isinstance(e, dict)
            else str(e)
            for e in (disc.get("effects") or [])
        ]
    if not named and isinstance(disc.get("accepted"), list):
        named = [str(x) for x in disc["accepted"]]
    est = d.get("estimate") or {}
    determined = [
        k
        for k, v in est.items()
        if isinstance(v, dict) and "identifiable" in v and v["identifiable"]
    ]
    confident_over_misfit = adequacy.get("verdict") == "does not explain" and bool(determined)
    described = [
        str(e.get("physics"))
        for e in disc.get("effects") or []
        if isinstance(e, dict) and e.get("status") == "described"
    ]
    before = disc.get("verdict_before") if isinstance(disc.get("verdict_before"), dict) else {}
    return {
        "recording": name,
        "robot": d["robot"],
        "verdict": adequacy.get("verdict", "not assessed"),
        "worst_channel": worst["channel"] if worst else None,
        "ratio": worst.get("judged_ratio") if worst else None,
        "floor": worst.get("noise_floor") if worst else None,
        "unit": worst.get("unit") if worst else None,
        "located": located,
        "named": named,
        "unexplained": adequacy.get("unexplained"),
        "changes": [c.get("note") for c in adequacy.get("changes") or []],
        "determined": determined,
        "determined_over_misfit": confident_over_misfit,
        "described": described,
        "remaining": disc.get("remaining") or None,
        "ratio_before": (before or {}).get("ratio"),
        "parameters": _parameters(est),
        "cpu_s": time.process_time() - t0,
    }


def _parameters(est: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Each estimated quantity's value, 95 % interval and whether it is determined."""
    return {
        k: {"value": v.get("value"), "ci95": v.get("ci95"), "determined": v.get("identifiable")}
        for k, v in est.items()
        if isinstance(v, dict) and "value" in v and "ci95" in v
    }


def _interval(p: dict[str, Any]) -> str:
    lo, hi = (p.get("ci95") or [None, None])[:2]
    if lo is None or hi is None or p.get("value") is None:
        return "-"
    tag = "" if p.get("determined") else " (not determined)"
    return f"{p['value']:.4g} [{lo:.4g}, {hi:.4g}]{tag}"


def compare(before: Path, after: Path) -> int:
    """A before -> after table of two ``--json`` captures (the same recordings)."""
    old = {r["recording"]: r for r in json.loads(before.read_text())}
    for r in json.loads(after.read_text()):
        b = old.get(r["recording"], {})

        def ratio(x: dict[str, Any]) -> str:
            v = x.get("ratio")
            return f"{v:.3g}x" if isinstance(v, (int, float)) else "-"

        print(f"{r['recording']}: {b.get('verdict', '-')} {ratio(b)} -> {r['verdict']} {ratio(r)}")
        found = list(r.get("named") or []) + [f"described: {d}" for d in r.get("described") or []]
        print(f"    found: {'; '.join(map(str, found)) or '-'}")
        for k, p in (r.get("parameters") or {}).items():
            q = (b.get("parameters") or {}).get(k, {})
            print(f"    {k}: {_interval(q)} -> {_interval(p)}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shared", type=Path, default=ROOT)
    ap.add_argument("--json", type=Path)
    ap.add_argument(
        "--compare", type=Path, nargs=2, metavar=("BEFORE", "AFTER"), help="two --json captures"
    )
    args = ap.parse_args(argv)
    if args.compare:
        return compare(*args.compare)
    rows = []
    for name, paths, extra in recordings(args.shared):
        r = row(name, paths, extra)
        rows.append(r)
        ratio = f"{r['ratio']:.3g}x" if r.get("ratio") is not None else "-"
        print(
            f"{name:45s} {r['robot']:15s} {r['verdict']:17s} {ratio:>8s}  "
            f"located: {'; '.join(r.get('located') or []) or '-'}  "
            f"named: {', '.join(map(str, r.get('named') or [])) or '-'}"
            + (f"  WHY: {r['why']}" if "why" in r else "")
            + ("  DETERMINED OVER A MISFIT" if r.get("determined_over_misfit") else ""),
            flush=True,
        )
    bad = sum(bool(r.get("determined_over_misfit")) for r in rows)
    print(
        f"\n{len(rows)} recordings; {sum(r['verdict'] == 'explains' for r in rows)} explained,"
        f" {sum(r['verdict'] == 'does not explain' for r in rows)} not explained, "
        f"{bad} with an estimate determined over a misfit"
    )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
