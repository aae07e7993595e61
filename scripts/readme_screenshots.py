"""Regenerate the README images: for each example log, the viewer's default blueprint (headless
Chromium, 1600 x 900) and the static report PNG, written into docs/img/.

``python scripts/readme_screenshots.py [--out docs/img] [--only NAME]``. Each log goes through
the real command line (``logcal analyze LOG --rrd ...``, which also writes the PNG where the
robot has one), then ``viz.screenshot.screenshot_rrd``; progress is printed per step.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from viz.screenshot import screenshot_rrd

ROOT = Path(__file__).resolve().parents[1]
REAL = Path("/work/shared/realworld_drive/optiodom/square/231220200029/231220200029_run-01.csv")

#: name -> (log, extra CLI arguments, colours of ``viz.style.COLORS`` that mean "drawn").
LOGS: dict[str, tuple[Path, list[str], tuple[str, ...]]] = {
    "tt_mixed": (ROOT / "sample_logs" / "tt_mixed.mcap", [], ("C1", "C2", "kappa")),
    "field_run_03": (ROOT / "sample_logs" / "field_run_03.mcap", [], ("C1", "C2", "kappa")),
    "optiodom_square": (REAL, [], ("dd_nominal", "dd_calibrated")),
}


def _shrink(png: Path, limit_bytes: int = 500_000) -> None:
    """Re-save ``png`` with a palette (PIL if present) when above the limit."""
    if png.stat().st_size <= limit_bytes:
        return
    try:
        from PIL import Image
    except ImportError:
        return
    Image.open(png).convert("RGB").quantize(colors=128).save(png, optimize=True)


def _one(name: str, log: Path, extra: list[str], ready: tuple[str, ...], out: Path) -> None:
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory() as tmp:
        rrd = Path(tmp) / f"{name}.rrd"
        print(f"[{name}] analysing {log} ...", flush=True)
        subprocess.run(
            [
                sys.executable,
                "-m",
                "logtools.cli.main",
                "analyze",
                str(log),
                "--rrd",
                str(rrd),
                "--repeats",
                "10",
                *extra,
            ],
            check=True,
            stdout=subprocess.DEVNULL,
        )
        png = rrd.with_suffix(".png")
        if png.exists():
            shutil.copy(png, out / f"{name}_report.png")
            _shrink(out / f"{name}_report.png")
            print(f"[{name}] report image: {out / f'{name}_report.png'}", flush=True)
        else:
            print(f"[{name}] this robot has no report image", flush=True)
        print(f"[{name}] screenshot of the viewer (1600 x 900) ...", flush=True)
        shot = screenshot_rrd(
            rrd, out / f"{name}_viewer.png", width=1600, height=900, ready_colors=ready
        )
        _shrink(shot)
    print(f"[{name}] done in {time.monotonic() - t0:.0f} s: {shot}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--only", choices=sorted(LOGS), action="append")
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    for name in args.only or list(LOGS):
        log, extra, ready = LOGS[name]
        if not log.exists():
            print(f"[{name}] {log} not found: skipped", flush=True)
            continue
        _one(name, log, extra, ready, args.out)


if __name__ == "__main__":
    main()
