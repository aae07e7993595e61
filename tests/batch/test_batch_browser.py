"""The batch report in headless Chromium (Debian's chromium, through Playwright), served by
``logcal serve``'s server: tables and plots render, nothing from the logs runs as script, and a
log page's link opens its recording in rerun's web viewer.

``LOGCAL_BATCH_SCREENSHOT=docs/img/batch_report.png`` also saves the report's screenshot there.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import time
from pathlib import Path

import pytest

from logtools.batch.runner import BatchSummary, read_records
from logtools.batch.serve import rerun_binary, start_server
from viz.screenshot import CHROMIUM, color_pixel_counts
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

_STATS = """() => ({
  tables: document.querySelectorAll('table').length,
  rows: document.querySelectorAll('tr').length,
  images: [...document.images].map(i => [i.getAttribute('src'), i.complete, i.naturalWidth]),
  scripts: document.querySelectorAll('script').length,
})"""


def test_report_renders_and_opens_recordings(
    batch_run: tuple[Path, BatchSummary], tmp_path: Path
) -> None:
    from playwright.sync_api import sync_playwright

    out, _ = batch_run
    server = start_server(out, port=0, viewer=rerun_binary() is not None)
    dialogs: list[str] = []
    try:
        with sync_playwright() as pw:
            browser = pw.chromium.launch(
                executable_path=CHROMIUM,
                headless=True,
                args=["--enable-unsafe-swiftshader", "--use-angle=swiftshader"],
            )
            try:
                page = browser.new_page(viewport={"width": 1300, "height": 1800})
                page.on("dialog", lambda d: (dialogs.append(d.message), d.dismiss()))
                page.goto(server.url + "index.html", wait_until="load")
                stats = page.evaluate(_STATS)
                assert stats["tables"] >= 4
                assert stats["rows"] > 20
                assert stats["scripts"] == 0
                assert len(stats["images"]) >= 3  # one plot per robot and parameter
                assert all(ok and width > 100 for _, ok, width in stats["images"]), stats
                shot = tmp_path / "report.png"
                page.screenshot(path=str(shot), full_page=False)
                if target := os.environ.get("LOGCAL_BATCH_SCREENSHOT"):
                    shutil.copy(shot, target)
                for rec in read_records(out):
                    page.goto(server.url + f"pages/{rec['id']}.html", wait_until="load")
                    stats = page.evaluate(_STATS)
                    assert stats["scripts"] == 0
                    assert stats["tables"] >= 1
                    assert all(ok and width > 100 for _, ok, width in stats["images"])
                assert dialogs == []  # no hostile name ran as script
                if server.viewer_url is None:
                    pytest.skip("rerun's web viewer did not start; the report itself passed")
                rec = next(r for r in read_records(out) if r["log"] == "truckA/a0.mcap")
                page.goto(server.url + f"pages/{rec['id']}.html", wait_until="load")
                fetched: list[int] = []
                page.on(
                    "response",
                    lambda r: (
                        fetched.append(r.status) if r.url.endswith(rec["views"][".rrd"]) else None
                    ),
                )
                page.click("a.rerun-web")
                page.wait_for_url(server.viewer_url + "*", timeout=90_000)
                deadline = time.monotonic() + 150
                counts: dict[str, int] = {}
                while time.monotonic() < deadline:
                    counts = color_pixel_counts(page.screenshot(type="png"), READY_COLORS)
                    if fetched and min(counts.values()) >= 20:
                        break
                    time.sleep(2)
                assert fetched == [200], "the viewer did not download the recording"
                assert min(counts.values()) >= 20, f"the recording was not drawn: {counts}"
            finally:
                browser.close()
    finally:
        server.close()
