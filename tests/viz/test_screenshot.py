"""The recording as a user sees it: rerun's web viewer in headless Chromium (Debian chromium)."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import pytest

from viz.screenshot import (
    CHROMIUM,
    alive_in_group,
    color_pixel_counts,
    screenshot_rrd,
)
from viz.tractor_trailer.recording import write_recording
from viz.tractor_trailer.style import READY_COLORS

pytestmark = [
    pytest.mark.browser,
    pytest.mark.slow,
    pytest.mark.skipif(
        not os.access(CHROMIUM, os.X_OK),
        reason=f"needs Debian's chromium at {CHROMIUM} (apt-get install chromium)",
    ),
    pytest.mark.skipif(
        importlib.util.find_spec("playwright") is None,
        reason="needs Playwright (pip install '.[test]')",
    ),
]


def test_viewer_shows_the_panels_and_processes_stop(case, tmp_path):
    rrd = write_recording(tmp_path / "case.rrd", case.frame, case.result)
    pids: list[int] = []
    png = screenshot_rrd(
        rrd, tmp_path / "shot.png", width=1400, height=900, pids=pids, ready_colors=READY_COLORS
    )
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    counts = color_pixel_counts(data, READY_COLORS)
    # The loading screen is grey on black: none of the plotted colours are in it.
    assert all(counts[c] >= 20 for c in READY_COLORS), counts
    viewer, *browser = pids
    assert browser, "no browser process was seen"
    assert alive_in_group(viewer) == [], f"the viewer's process group {viewer} is still alive"
    for pid in browser:
        assert not Path(f"/proc/{pid}").exists() or _zombie(pid), f"browser {pid} still runs"


def _zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True  # gone between the two reads
