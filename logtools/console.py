"""The console a report is printed on. A terminal keeps its own width (rich's layout, wrapped to
fit); a file or a pipe (``> out.txt``, ``| less``, ``| grep``) gets lines as long as their
content: no 80-column wrap and no cell cut to "Transien…", so each record stays on one line and
names stay whole. ``COLUMNS`` set by the user still rules."""

from __future__ import annotations

import os
import sys
from typing import IO

from rich.console import Console

__all__ = ["UNWRAPPED_WIDTH", "report_console"]

UNWRAPPED_WIDTH = 10_000
"""The width given to a console that is not a terminal: wider than any line a report holds."""


def _is_terminal(stream: IO[str]) -> bool:
    isatty = getattr(stream, "isatty", None)
    try:
        return bool(isatty()) if isatty is not None else False
    except (OSError, ValueError):  # a closed stream
        return False


def report_console(
    *, stderr: bool = False, min_width: int = 0, file: IO[str] | None = None
) -> Console:
    """A rich console for a report on stdout (``stderr``: on stderr; ``file``: on that stream):
    at least ``min_width`` columns on a terminal, unwrapped when the stream is not one."""
    stream = file if file is not None else sys.stderr if stderr else sys.stdout
    if _is_terminal(stream) or os.environ.get("COLUMNS"):
        width = max(Console(file=stream).width, min_width)
        return Console(file=file, stderr=stderr, width=width)
    return Console(file=file, stderr=stderr, width=UNWRAPPED_WIDTH, soft_wrap=True)
