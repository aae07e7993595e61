"""The recording as a user sees it: rerun's web viewer in headless Chromium (Debian chromium)."""

from __future__ import annotations

import os

import pytest

from viz.recording import write_recording
from viz.screenshot import (
    CHROMIUM,
    READY_COLORS,
    alive_in_group,
    color_pixel_counts,
    screenshot_rrd,
)

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(not os.access(CHROMIUM, os.X_OK), reason="needs /usr/bin/chromium"),
]


def test_viewer_shows_the_panels_and_processes_stop(case, tmp_path):
    rrd = write_recording(tmp_path / "case.rrd", case.frame, case.result)
    pids: list[int] = []
    png = screenshot_rrd(rrd, tmp_path / "shot.png", width=1400, height=900, pids=pids)
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    counts = color_pixel_counts(data)
    # The loading screen is grey on black: none of the plotted colours are in it.
    assert all(counts[c] >= 20 for c in READY_COLORS), counts
    assert len(pids) == 2
    for pid in pids:
        assert alive_in_group(pid) == [], f"process group {pid} still has live processes"
