"""Regenerate the README images of a sample log: the viewer's default blueprint (headless
Chromium) and the static report PNG.

``python scripts/readme_screenshots.py [LOG] [--out docs/img]`` (default LOG:
sample_logs/tt_mixed.mcap). Runs the real analysis (``logtools.analyze.analyze_log``).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from logtools.analyze import AnalysisConfig, analyze_log
from viz.plots import write_report_png
from viz.recording import write_recording
from viz.screenshot import screenshot_rrd

ROOT = Path(__file__).resolve().parents[1]


def _shrink(png: Path, limit_bytes: int = 500_000) -> None:
    """Re-save ``png`` with a palette (matplotlib + PIL if present) when above the limit."""
    if png.stat().st_size <= limit_bytes:
        return
    try:
        from PIL import Image
    except ImportError:
        return
    Image.open(png).convert("RGB").quantize(colors=128).save(png, optimize=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("log", type=Path, nargs="?", default=ROOT / "sample_logs" / "tt_mixed.mcap")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--repeats", type=int, default=10)
    args = ap.parse_args()
    loaded, result = analyze_log(args.log, config=AnalysisConfig(repeats=args.repeats))
    stem = args.log.stem
    args.out.mkdir(parents=True, exist_ok=True)
    report = write_report_png(args.out / f"{stem}_report.png", loaded.frame, result, dpi=80)
    _shrink(report)
    with tempfile.TemporaryDirectory() as tmp:
        rrd = write_recording(Path(tmp) / f"{stem}.rrd", loaded.frame, result)
        shot = screenshot_rrd(rrd, args.out / f"{stem}_viewer.png", width=1600, height=1000)
    _shrink(shot)
    for p in (report, shot):
        print(f"{p} ({p.stat().st_size / 1e3:.0f} kB)")


if __name__ == "__main__":
    main()
