"""Open a saved recording in the native rerun viewer when one can start."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

__all__ = ["can_start_viewer", "open_viewer"]


def can_start_viewer() -> bool:
    """True on macOS / Windows, or on Linux/BSD with an X11 or Wayland display."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def open_viewer(path: str | Path) -> subprocess.Popen[bytes] | None:
    """Start the rerun viewer on ``path`` in the background; None when no viewer can start.

    The viewer is the ``rerun`` CLI of the installed rerun-sdk (``python -m rerun FILE``); it
    outlives this process.
    """
    if not can_start_viewer():
        return None
    try:
        return subprocess.Popen(
            [sys.executable, "-m", "rerun", str(path)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
    except OSError:
        return None
