"""Screenshot a .rrd in rerun's web viewer (headless Chromium): ``python scripts/screenshot_rrd.py
FILE.rrd OUT.png [--width 1600 --height 1000 --timeout 120]``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from viz.screenshot import ViewerScreenshotError, screenshot_rrd


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("rrd", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--width", type=int, default=1600)
    ap.add_argument("--height", type=int, default=1000)
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument(
        "--ready",
        default="",
        help="colours (viz.style.COLORS names) whose presence means drawn; default: the "
        "recorded robot's own (viz.screenshot.ready_colors_of)",
    )
    args = ap.parse_args(argv)
    try:
        out = screenshot_rrd(
            args.rrd,
            args.out,
            width=args.width,
            height=args.height,
            timeout_s=args.timeout,
            ready_colors=[c for c in args.ready.split(",") if c] or None,
            progress=lambda line: print(line, file=sys.stderr, flush=True),
        )
    except ViewerScreenshotError as err:
        print(f"screenshot failed: {err}", file=sys.stderr)
        return 1
    print(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
