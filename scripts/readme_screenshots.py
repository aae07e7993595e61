"""Regenerate the README images: for each example log, the viewer's default blueprint (headless
Chromium, 1600 x 900) and the static report PNG, written into docs/img/.

``python scripts/readme_screenshots.py [--out docs/img] [--only NAME] [--optiodom SESSION]``.
Every log is the repository's own: the tractor's sample logs, and a differential drive's and
an arm's written by ``logcal simulate`` into a temporary folder; ``--optiodom`` adds the real
OptiOdom square session (a folder of runs, pooled) when the user has it. Each log goes through
the real command line (``logcal analyze LOG --rrd ...``, which also writes the PNG where the
robot has one), then ``viz.screenshot.screenshot_rrd`` (waiting for the robot's own colours,
``viz.screenshot.ready_colors_of``); progress is printed per step. Without Chromium only the
report images are written.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from viz.screenshot import ViewerScreenshotError, find_chromium, screenshot_rrd

ROOT = Path(__file__).resolve().parents[1]

#: name -> (log in the repository, extra CLI arguments).
SAMPLES: dict[str, tuple[Path, list[str]]] = {
    "tt_mixed": (ROOT / "sample_logs" / "tt_mixed.mcap", []),
    "field_run_03": (ROOT / "sample_logs" / "field_run_03.mcap", []),
}
#: name -> ``logcal simulate`` arguments writing that log (the output path is appended).
SIMULATED: dict[str, list[str]] = {
    "dd_square": ["diff-drive", "--pattern", "square-cw", "--asymmetry", "0.01", "--seed", "1"],
    "arm_planar2": ["manipulator", "--duration", "20", "--seed", "1"],
}
NAMES = (*SAMPLES, *SIMULATED, "optiodom_square")


def _shrink(png: Path, limit_bytes: int = 500_000) -> None:
    """Re-save ``png`` with a palette (PIL if present) when above the limit."""
    if png.stat().st_size <= limit_bytes:
        return
    try:
        from PIL import Image
    except ImportError:
        return
    Image.open(png).convert("RGB").quantize(colors=128).save(png, optimize=True)


def _simulate(name: str, folder: Path) -> Path:
    """Write the simulated log ``name`` into ``folder`` with ``logcal simulate``."""
    log = folder / f"{name}.mcap"
    cmd = [sys.executable, "-m", "logtools.cli.main", "simulate", *SIMULATED[name], "-o", str(log)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return log


def _one(name: str, log: Path, extra: list[str], out: Path, *, shoot: bool) -> None:
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
        if not shoot:
            print(f"[{name}] no Chromium: the viewer's screenshot is not taken", flush=True)
            return
        print(f"[{name}] screenshot of the viewer (1600 x 900) ...", flush=True)
        try:
            shot = screenshot_rrd(rrd, out / f"{name}_viewer.png", width=1600, height=900)
        except ViewerScreenshotError as err:
            print(f"[{name}] screenshot failed: {err}", flush=True)
            return
        _shrink(shot)
    print(f"[{name}] done in {time.monotonic() - t0:.0f} s: {shot}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "img")
    ap.add_argument("--only", choices=sorted(NAMES), action="append")
    ap.add_argument(
        "--optiodom",
        type=Path,
        help="an OptiOdom square session folder (its runs pooled) for optiodom_square_*.png",
    )
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    shoot = find_chromium() is not None
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only or list(NAMES):
            if name in SAMPLES:
                log, extra = SAMPLES[name]
            elif name in SIMULATED:
                log, extra = _simulate(name, Path(tmp)), []
            elif args.optiodom is not None:
                log, extra = args.optiodom, []
            else:
                print(f"[{name}] no --optiodom session given: skipped", flush=True)
                continue
            _one(name, log, extra, args.out, shoot=shoot)


if __name__ == "__main__":
    main()
