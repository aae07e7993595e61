"""Open a saved recording in the native rerun viewer when one can start.

The viewer's server binds to the loopback address (127.0.0.1) unless the caller names another:
a drive log shown on a laptop must not be served to the network. "Started" means the viewer's
port answers, not merely that a process was spawned.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

__all__ = ["LOOPBACK", "ViewerProcess", "can_start_viewer", "free_port", "open_viewer"]

LOOPBACK = "127.0.0.1"


@dataclass(frozen=True)
class ViewerProcess:
    """A viewer that answered on ``host:port``."""

    process: subprocess.Popen[bytes]
    host: str
    port: int


def can_start_viewer() -> bool:
    """True on macOS / Windows, or on Linux/BSD with an X11 or Wayland display."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def free_port(host: str = LOOPBACK) -> int:
    """A TCP port nothing listens on at ``host`` right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


def _answers(host: str, port: int) -> bool:
    try:
        with socket.create_connection((host, port), timeout=0.2):
            return True
    except OSError:
        return False


def open_viewer(
    path: str | Path, *, host: str = LOOPBACK, timeout_s: float = 20.0
) -> ViewerProcess | None:
    """Start the rerun viewer on ``path`` in the background, its server bound to ``host``; the
    viewer once its port answers, None when no viewer can start or it did not answer within
    ``timeout_s`` (a viewer that died is not reported as started).

    The viewer is the ``rerun`` CLI of the installed rerun-sdk (``python -m rerun FILE``); it
    outlives this process.
    """
    if not can_start_viewer():
        return None
    port = free_port(host)
    try:
        proc = subprocess.Popen(
            [sys.executable, "-m", "rerun", "--bind", host, "--port", str(port), str(path)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
    except OSError:
        return None
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            return None
        if _answers(host, port):
            return ViewerProcess(proc, host, port)
        time.sleep(0.1)
    proc.terminate()
    return None
