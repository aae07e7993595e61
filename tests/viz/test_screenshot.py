"""The recording as a user sees it: rerun's web viewer in headless Chromium (Debian chromium)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from viz.recording import write_recording
from viz.screenshot import CHROMIUM, READY_COLORS, color_pixel_counts, screenshot_rrd

pytestmark = [
    pytest.mark.browser,
    pytest.mark.skipif(not os.access(CHROMIUM, os.X_OK), reason="needs /usr/bin/chromium"),
]


def _alive_in_group(pgid: int) -> list[int]:
    alive = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            alive.append(int(stat.parent.name))
    return alive


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
        assert _alive_in_group(pid) == [], f"process group {pid} still has live processes"
