"""Screenshot of a recording as a user sees it: rerun's web viewer in headless Chromium.

``rerun FILE --web-viewer --bind 127.0.0.1`` serves the viewer and the recording on free
loopback ports; Playwright drives Debian's Chromium (software rasteriser: SwiftShader; Playwright
is a ``dev``/``test`` extra and its own browser downloads are not used) until the plotted
colours appear, then one screenshot is saved. The viewer process group is stopped and the
browser closed before returning.
"""

from __future__ import annotations

import io
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import quote

import numpy as np
from numpy.typing import NDArray

from viz.style import COLORS, robot_of_application_id, robot_style

if TYPE_CHECKING:
    from playwright.sync_api import Page

__all__ = [
    "CHROMIUM",
    "ViewerScreenshotError",
    "alive_in_group",
    "browser_pids",
    "color_pixel_counts",
    "find_chromium",
    "flat_colors",
    "panel_problems",
    "ready_colors_of",
    "screenshot_rrd",
]

CHROMIUM = "/usr/bin/chromium"


def ready_colors_of(rrd: str | Path) -> tuple[str, ...]:
    """The colours that mean "drawn" for the recording ``rrd``: its robot's (read from the
    recordings' application ids, ``viz.style.application_id``) ``READY_COLORS``
    (``viz/<robot>/style.py``) that the recording draws flat (:func:`flat_colors`), so that
    a view the log gives no data for (a diff drive without a calibrated path) or a colour
    rerun shades (3-D points) is never waited for until the timeout.

    Raises:
        ViewerScreenshotError: the file holds no logcal robot's recording, or draws none of
            its robot's colours.
    """
    from rerun.chunk import RrdReader

    try:
        ids = [r.application_id for r in RrdReader(rrd).recordings()]
    except (OSError, ValueError) as err:
        raise ViewerScreenshotError(f"{rrd}: not a readable rerun recording ({err})") from err
    robots = {r for i in ids if (r := robot_of_application_id(i)) is not None}
    if len(robots) != 1:
        raise ViewerScreenshotError(
            f"{rrd}: holds no recording of one logcal robot (application ids: "
            f"{', '.join(ids) or 'none'}); name the colours to wait for"
        )
    robot = robots.pop()
    declared = tuple(getattr(robot_style(robot), "READY_COLORS", None) or ())
    if not declared:
        raise ViewerScreenshotError(f"{rrd}: its robot's views declare no colours to wait for")
    drawn = flat_colors(rrd)
    ready = tuple(n for n in declared if tuple(COLORS[n]) in drawn)
    if not ready:
        raise ViewerScreenshotError(
            f"{rrd}: draws none of the {robot}'s colours {', '.join(declared)}; "
            "name the colours to wait for"
        )
    return ready


#: Archetypes rerun draws shaded (3-D points: spheres): their exact colour may cover no pixel.
SHADED_ARCHETYPES = frozenset({"Points3D"})


def flat_colors(rrd: str | Path) -> set[tuple[int, int, int]]:
    """RGB colours (0-255) the recordings of ``rrd`` log for an archetype drawn flat (lines,
    2-D points, plot lines, ...; not :data:`SHADED_ARCHETYPES`)."""
    from rerun.chunk import RrdReader

    out: set[tuple[int, int, int]] = set()
    for chunk in RrdReader(rrd).stream().to_chunks():
        rb = chunk.to_record_batch()
        for name in rb.schema.names:
            if not name.endswith(":colors") or name.split(":")[0] in SHADED_ARCHETYPES:
                continue
            packed = _packed_colors(rb.column(name).to_pylist())
            out |= {((p >> 24) & 255, (p >> 16) & 255, (p >> 8) & 255) for p in packed}
    return out


def _packed_colors(rows: list[object]) -> set[int]:
    """The distinct packed RGBA colours (``0xRRGGBBAA``) of a colour column's rows."""
    out: set[int] = set()
    for row in rows:
        if isinstance(row, list):
            out |= {int(p) for p in row if p is not None}
        elif isinstance(row, int):
            out.add(row)
    return out


def panel_problems(
    png: bytes | NDArray[np.uint8], names: Sequence[str], min_pixels: int = 20, edge_px: int = 2
) -> list[str]:
    """What is wrong with a screenshot, per colour (panel) in ``names``: "empty" (fewer than
    ``min_pixels`` pixels of it) or "clipped" (its pixels touch the image's outer ``edge_px``
    rows or columns: geometry cut by the window). Empty list: every panel drew, inside."""
    img = _read_png(png) if isinstance(png, bytes) else png
    problems = []
    for name in names:
        rgb = np.array(COLORS[name][:3], dtype=np.int16)
        hit = np.all(np.abs(img[..., :3].astype(np.int16) - rgb) <= 10, axis=-1)
        if int(hit.sum()) < min_pixels:
            problems.append(f"{name}: empty ({int(hit.sum())} pixels)")
            continue
        border = np.zeros_like(hit)
        border[:edge_px, :] = border[-edge_px:, :] = True
        border[:, :edge_px] = border[:, -edge_px:] = True
        if bool((hit & border).any()):
            problems.append(f"{name}: clipped (touches the window's edge)")
    return problems


class ViewerScreenshotError(RuntimeError):
    """The viewer or the browser did not start or did not show the recording in time."""


def find_chromium() -> str | None:
    """Path of a Chromium executable (Debian's ``/usr/bin/chromium`` first), or None."""
    if os.access(CHROMIUM, os.X_OK):
        return CHROMIUM
    for name in ("chromium", "chromium-browser", "google-chrome"):
        found = shutil.which(name)
        if found:
            return found
    return None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _read_png(data: bytes) -> NDArray[np.uint8]:
    from matplotlib import image as mpimg

    img = mpimg.imread(io.BytesIO(data), format="png")
    if img.dtype != np.uint8:
        img = np.round(img * 255).astype(np.uint8)
    return img[..., :3]


def color_pixel_counts(
    png: bytes | NDArray[np.uint8], names: Sequence[str], tol: int = 10
) -> dict[str, int]:
    """Pixels within ``tol`` (per channel, 0-255) of each named colour of ``viz.style.COLORS``."""
    img = _read_png(png) if isinstance(png, bytes) else png
    px = img.reshape(-1, 3).astype(np.int16)
    return {
        n: int((np.abs(px - np.array(COLORS[n], dtype=np.int16)).max(axis=1) <= tol).sum())
        for n in names
    }


def _wait_http(url: str, deadline: float) -> None:
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(url, timeout=2) as r:
                if r.status == 200:
                    return
        except OSError:
            time.sleep(0.2)
    raise ViewerScreenshotError(f"{url} did not answer in time")


def alive_in_group(pgid: int) -> list[int]:
    """Pids of the non-zombie processes of process group ``pgid`` (Linux /proc)."""
    alive = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            alive.append(int(stat.parent.name))
    return alive


def _group_alive(pgid: int) -> bool:
    """True while a non-zombie process of process group ``pgid`` exists."""
    return bool(alive_in_group(pgid))


def _stop(proc: subprocess.Popen[bytes] | None) -> None:
    """Stop ``proc`` and its process group (it was started in a new session): SIGTERM, then
    SIGKILL after 5 s."""
    if proc is None:
        return
    for sig in (signal.SIGTERM, signal.SIGKILL):
        proc.poll()
        if not _group_alive(proc.pid):
            break
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        end = time.monotonic() + 5.0
        while time.monotonic() < end and (proc.poll() is None or _group_alive(proc.pid)):
            time.sleep(0.05)
    proc.poll()


def browser_pids(profile: str | Path) -> list[int]:
    """Pids of the live (non-zombie) processes whose command line names the browser profile
    ``profile`` (``--user-data-dir``): the browser Playwright started for one screenshot."""
    needle = f"--user-data-dir={profile}".encode()
    found = []
    for cmdline in Path("/proc").glob("[0-9]*/cmdline"):
        try:
            if needle not in cmdline.read_bytes():
                continue
            state = (cmdline.parent / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            found.append(int(cmdline.parent.name))
    return sorted(found)


def _capture_when_ready(
    page: Page,
    deadline: float,
    min_pixels: int,
    settle_s: float,
    ready: Sequence[str],
    progress: Callable[[str], None],
) -> bytes:
    """Screenshots every second until each ready colour covers ``min_pixels``; then wait
    ``settle_s`` and take the final one, which must show every ready colour, none clipped."""
    last: dict[str, int] = {}
    t0 = time.monotonic()
    while time.monotonic() < deadline:
        last = color_pixel_counts(page.screenshot(type="png"), ready)
        progress(f"waiting for the panels to draw ({time.monotonic() - t0:.0f} s): {last}")
        if min(last.values()) >= min_pixels:
            time.sleep(settle_s)
            png = page.screenshot(type="png")
            bad = panel_problems(png, ready, min_pixels)
            if bad:
                raise ViewerScreenshotError("the screenshot fails its check: " + "; ".join(bad))
            return png
        time.sleep(1.0)
    empty = [n for n, c in last.items() if c < min_pixels]
    raise ViewerScreenshotError(
        f"the viewer did not draw {', '.join(empty)} in time (colour pixel counts: {last})"
    )


def screenshot_rrd(
    rrd: str | Path,
    out_png: str | Path,
    *,
    width: int = 1600,
    height: int = 1000,
    timeout_s: float = 120.0,
    min_pixels: int = 20,
    settle_s: float = 3.0,
    chromium: str | None = None,
    pids: list[int] | None = None,
    ready_colors: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Path:
    """Serve ``rrd`` with rerun's web viewer, open it in headless Chromium, save a PNG.

    Args:
        rrd: recording to show (its default blueprint is used).
        out_png: where to save the screenshot.
        width, height: browser window size (px).
        timeout_s: overall time limit (s); the viewer compiles its shaders on the CPU.
        min_pixels: pixels each of ``ready_colors`` must cover before the final capture.
        settle_s: wait (s) between "ready" and the final capture.
        chromium: browser executable (default: :func:`find_chromium`).
        pids: if given, the ids of the started processes are appended (the viewer, which
            leads its own process group, then the browser's processes), so a caller can check
            that they are gone.
        ready_colors: names in ``viz.style.COLORS`` whose presence means "drawn" (default: the
            recorded robot's own, declared in its style module: :func:`ready_colors_of`); the
            final
            capture must show each, none touching the window's edge (:func:`panel_problems`).
        progress: called with one line per step (viewer, browser, waiting, capture).

    Raises:
        ViewerScreenshotError: no Playwright or no browser, or the viewer did not come up in
            time.
    """
    try:
        from playwright.sync_api import Error as PlaywrightError
        from playwright.sync_api import sync_playwright
    except ImportError as err:
        raise ViewerScreenshotError(
            "Playwright is not installed (pip install 'logcal[dev]')"
        ) from err
    browser = chromium or find_chromium()
    if browser is None:
        raise ViewerScreenshotError("no Chromium found (Debian: apt-get install chromium)")
    say = progress or (lambda _: None)
    ready = tuple(ready_colors) if ready_colors is not None else ready_colors_of(rrd)
    deadline = time.monotonic() + timeout_s
    web_port, grpc_port = _free_port(), _free_port()
    viewer = None
    try:
        viewer = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "rerun",
                str(rrd),
                "--web-viewer",
                "--bind",
                "127.0.0.1",
                "--web-viewer-port",
                str(web_port),
                "--port",
                str(grpc_port),
            ],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
            env={**os.environ, "BROWSER": "true"},
        )
        if pids is not None:
            pids.append(viewer.pid)
        say(f"rerun web viewer starting on 127.0.0.1:{web_port}")
        _wait_http(f"http://127.0.0.1:{web_port}/", deadline)
        say("viewer answers; starting headless Chromium")
        proxy = quote(f"rerun+http://127.0.0.1:{grpc_port}/proxy", safe="")
        url = f"http://127.0.0.1:{web_port}/?url={proxy}"
        with (
            tempfile.TemporaryDirectory(prefix="logcal-chromium-") as profile,
            sync_playwright() as pw,
        ):
            try:
                context = pw.chromium.launch_persistent_context(
                    profile,
                    executable_path=browser,
                    headless=True,
                    args=["--enable-unsafe-swiftshader", "--use-angle=swiftshader"],
                    viewport={"width": width, "height": height},
                    timeout=max(deadline - time.monotonic(), 1.0) * 1e3,
                )
            except PlaywrightError as err:
                raise ViewerScreenshotError(f"{browser} did not start: {err.message}") from err
            try:
                if pids is not None:
                    pids += browser_pids(profile)
                page = context.pages[0] if context.pages else context.new_page()
                page.goto(url, timeout=max(deadline - time.monotonic(), 1.0) * 1e3)
                png = _capture_when_ready(page, deadline, min_pixels, settle_s, ready, say)
                say("captured")
            except PlaywrightError as err:
                raise ViewerScreenshotError(f"the viewer page failed: {err.message}") from err
            finally:
                context.close()
    finally:
        _stop(viewer)
    out = Path(out_png)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_bytes(png)
    return out
