"""Text taken from a log (topic, schema, field, metadata names and values, file paths) made
safe to print: control characters (ESC sequences that clear the screen or set the window title,
BEL, carriage returns, newlines that would forge report lines) are shown as visible escapes
instead of being sent to the terminal, and rich markup in them is never interpreted."""

from __future__ import annotations

import re

__all__ = ["NOT_A_NUMBER", "no_nan", "printable", "printable_lines"]

_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f\u202a-\u202e\u2066-\u2069]")


def _escape(m: re.Match[str]) -> str:
    c = m.group(0)
    return {"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(
        c, f"\\x{ord(c):02x}" if ord(c) < 256 else f"\\u{ord(c):04x}"
    )


def printable(text: object) -> str:
    """``str(text)`` with every control or bidi-override character replaced by a visible
    escape (``\\x1b``, ``\\n``, ``\\u202e``); ordinary text (including non-ASCII) unchanged."""
    return _CONTROL.sub(_escape, str(text))


def printable_lines(text: object) -> str:
    """Several lines of our own text (which may quote a log's names): each line made
    :func:`printable`, the line breaks kept."""
    return "\n".join(printable(line) for line in str(text).split("\n"))


NOT_A_NUMBER = "n/a"
"""What a text report shows where a value is not a finite number."""

_NAN = re.compile(r"(?<![A-Za-z0-9_.])[-+]?(?:nan|inf(?:inity)?)(?![A-Za-z0-9_])", re.IGNORECASE)


def no_nan(text: str) -> str:
    """``text`` with every number formatted from a NaN or an infinity (``nan``, ``-inf``, as
    ``f"{x:.3g}"`` prints them) shown as :data:`NOT_A_NUMBER`: the last guard of every text
    report, whatever the data (a log whose time jumps ten years printed "residual nan rad")."""
    return _NAN.sub(NOT_A_NUMBER, text)
