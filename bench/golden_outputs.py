"""Golden outputs: ``logcal analyze --json`` on the sample logs, simulated logs of each robot and
the shared real recordings, written to a folder; and the difference of two such folders.

Use it around a change that must not move the numbers: capture before, capture after, compare.
Floats are compared to a relative tolerance (default 1e-9); keys present in one side only are
listed; the checkout's absolute paths are stripped first.

    python bench/golden_outputs.py capture OUT_DIR [--only NAME,...] [--shared DIR]
    python bench/golden_outputs.py compare BEFORE_DIR AFTER_DIR [--rtol 1e-9] [--ignore KEY,...]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"

__all__ = ["cases", "compare", "main"]


def cases(shared: Path, tmp: Path) -> list[tuple[str, list[str]]]:
    """(name, analyze arguments) of every golden case; simulated logs are written to ``tmp``."""
    from logtools.cli.main import main as cli

    sim_dd = tmp / "dd.mcap"
    sim_arm = tmp / "arm.mcap"
    cli(["simulate", "diff-drive", "--out", str(sim_dd), "--asymmetry", "0.01", "--seed", "3"])
    cli(["simulate", "manipulator", "--out", str(sim_arm), "--seed", "3"])
    s = ROOT / "sample_logs"
    out: list[tuple[str, list[str]]] = [
        ("tt_mixed", [str(s / "tt_mixed.mcap")]),
        ("tt_harmonic_clean", [str(s / "tt_harmonic_clean.mcap")]),
        ("field_run_01", [str(s / "field_run_01.mcap")]),
        ("sim_diff_drive", [str(sim_dd)]),
        ("sim_arm", [str(sim_arm), *_arm_urdf(tmp)]),
    ]
    opti = shared / "realworld_drive/optiodom"
    for session in sorted(p for p in opti.glob("*/*") if p.is_dir()):
        out.append((f"optiodom_{session.parent.name}", [str(session)]))
    jackal = shared / "realworld_drive/jackal/jackal_odom_imu.bag"
    if jackal.exists():
        out.append(("jackal", [str(jackal)]))
    dfki = shared / "realworld_arm/dfki_double_pendulum"
    urdf = dfki / "design_C.0_model_3.1_acrobot.urdf"
    for run in sorted(dfki.glob("*_00.mcap")):
        out.append((f"dfki_{run.stem[-2:]}", [str(run), "--urdf", str(urdf)]))
    tiago = shared / "realworld_arm/tiago_arm/tiago_arm_identification.mcap"
    if tiago.exists():
        out.append(("tiago", [str(tiago), "--urdf", "tiago"]))
    return out


def _arm_urdf(tmp: Path) -> list[str]:
    """The simulated arm's URDF option, when the simulator wrote one beside the log."""
    urdfs = sorted(tmp.glob("*.urdf"))
    return ["--urdf", str(urdfs[0])] if urdfs else []


def _strip_paths(doc: Any) -> Any:
    if isinstance(doc, dict):
        return {k: _strip_paths(v) for k, v in doc.items()}
    if isinstance(doc, list):
        return [_strip_paths(v) for v in doc]
    if isinstance(doc, str) and ("/" in doc) and (str(ROOT) in doc or "/tmp" in doc):
        return Path(doc).name
    return doc


def capture(out: Path, shared: Path, only: Sequence[str] | None) -> int:
    """Write ``NAME.json`` for every case (or those in ``only``) into ``out``."""
    import contextlib
    import io

    from logtools.cli.main import main as cli

    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="golden_") as d:
        for name, args in cases(shared, Path(d)):
            if only and name not in only:
                continue
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                code = cli(["analyze", *args, "--json", "--repeats", "4"])
            text = buf.getvalue()
            try:
                doc = _strip_paths(json.loads(text))
            except json.JSONDecodeError:
                doc = {"exit_code": code, "output": text[-2000:]}
            (out / f"{name}.json").write_text(json.dumps(doc, indent=1, sort_keys=True))
            print(f"{name}: exit {code}", file=sys.stderr)
    return 0


def _diffs(a: Any, b: Any, rtol: float, ignore: set[str], where: str = "") -> list[str]:
    if isinstance(a, dict) and isinstance(b, dict):
        out = [
            f"{where}/{k}: only in {'before' if k in a else 'after'}"
            for k in sorted(set(a) ^ set(b))
            if k not in ignore
        ]
        for k in sorted(set(a) & set(b)):
            if k not in ignore:
                out += _diffs(a[k], b[k], rtol, ignore, f"{where}/{k}")
        return out
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} vs {len(b)} items"]
        return [
            d
            for i, (x, y) in enumerate(zip(a, b, strict=True))
            for d in _diffs(x, y, rtol, ignore, f"{where}[{i}]")
        ]
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        ok = math.isclose(float(a), float(b), rel_tol=rtol, abs_tol=1e-300)
        return [] if ok else [f"{where}: {a!r} -> {b!r}"]
    return [] if a == b else [f"{where}: {str(a)[:120]!r} -> {str(b)[:120]!r}"]


def compare(before: Path, after: Path, rtol: float, ignore: set[str]) -> int:
    """Print every difference between the two folders' cases; 1 when any."""
    n = 0
    for f in sorted(before.glob("*.json")):
        g = after / f.name
        if not g.exists():
            print(f"{f.stem}: missing after")
            n += 1
            continue
        diffs = _diffs(json.loads(f.read_text()), json.loads(g.read_text()), rtol, ignore)
        for d in diffs:
            print(f"{f.stem}{d}")
        n += len(diffs)
    print(f"{n} differences", file=sys.stderr)
    return 1 if n else 0


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("capture")
    c.add_argument("out", type=Path)
    c.add_argument("--only", default="")
    c.add_argument("--shared", type=Path, default=SHARED)
    k = sub.add_parser("compare")
    k.add_argument("before", type=Path)
    k.add_argument("after", type=Path)
    k.add_argument("--rtol", type=float, default=1e-9)
    k.add_argument("--ignore", default="", help="comma-separated keys to leave out")
    a = ap.parse_args(argv)
    if a.cmd == "capture":
        only = [x for x in a.only.split(",") if x] or None
        return capture(a.out, a.shared, only)
    return compare(a.before, a.after, a.rtol, {x for x in a.ignore.split(",") if x})


if __name__ == "__main__":
    raise SystemExit(main())
