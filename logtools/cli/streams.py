"""Standard streams that end cleanly, whatever the terminal or the disk behind them.

* **What the terminal cannot show is spelled, never an error**: an ASCII, ``C``/``POSIX`` or
  latin-1 stdout used to end the text report with ``UnicodeEncodeError`` on ``±``. Both streams
  are reconfigured with the error handler ``logcal-fallback``: a character the encoding lacks
  becomes its ASCII spelling (``±`` -> ``+/-``, ``×`` -> ``x``, ``°`` -> ``deg``...), the bytes of
  an undecodable file name (surrogates) ``\\xNN``, anything else ``\\uXXXX``.
* **A closed stdout is said, not ignored**: with file descriptor 1 closed Python drops every
  ``print``; :func:`guard_streams` puts a stand-in there whose first write raises ``EBADF``, so a
  command that prints ends with one message (exit 2) and one that does not is unaffected.
* **A full or broken stdout**: stdout is wrapped so that a failed write raises
  :class:`StdoutError` (an ``OSError`` that says it is stdout's, not a file's: ``/dev/full``,
  no space left), a broken pipe stays ``BrokenPipeError`` (click and the CLI end quietly on it);
  :func:`silence_stdout` points file descriptor 1 at ``/dev/null`` so that the text still
  buffered is not flushed again at exit (which would print Python's "Exception ignored" after
  our message). The wrapper has no ``buffer``: click then writes through it (it would otherwise
  re-wrap an ASCII stdout as UTF-8 and print mojibake).
"""

from __future__ import annotations

import codecs
import errno
import io
import os
import sys
from typing import Any

__all__ = [
    "FALLBACK",
    "STREAM_ERRNOS",
    "StdoutError",
    "ascii_spelling",
    "guard_streams",
    "pipe_broken",
    "silence_stdout",
    "stdout_failure",
]

FALLBACK = "logcal-fallback"
"""Name of the codec error handler registered by this module."""

STREAM_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EBADF})
"""Errors of a write to stdout that are the stream's state (full, closed), not a bug."""

_SPELLINGS = {
    "±": "+/-",
    "×": "x",
    "÷": "/",
    "°": " deg",
    "µ": "u",
    "μ": "u",
    "σ": "sigma",
    "Δ": "d",
    "δ": "d",
    "θ": "theta",
    "ω": "omega",
    "√": "sqrt",
    "≈": "~",
    "≤": "<=",
    "≥": ">=",
    "≠": "!=",
    "−": "-",
    "–": "-",
    "—": "-",
    "→": "->",
    "←": "<-",
    "…": "...",
    "·": "*",
    "²": "^2",
    "³": "^3",
    "‘": "'",
    "’": "'",
    "“": '"',
    "”": '"',
    "✓": "ok",
    "✗": "x",
    "•": "*",
    "█": "#",
    "━": "-",
    "─": "-",
    "│": "|",
}


def _spell(char: str) -> str:
    code = ord(char)
    if char in _SPELLINGS:
        return _SPELLINGS[char]
    if 0xDC80 <= code <= 0xDCFF:  # a byte of a file name that is not UTF-8 (surrogateescape)
        return f"\\x{code - 0xDC00:02x}"
    if code < 0x100:
        return f"\\x{code:02x}"
    return f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"


def _fallback(err: UnicodeError) -> tuple[str, int]:
    if not isinstance(err, UnicodeEncodeError):
        raise err
    text = err.object[err.start : err.end]
    return "".join(_spell(c) for c in text), err.end


codecs.register_error(FALLBACK, _fallback)


def ascii_spelling(text: str, encoding: str = "ascii") -> str:
    """``text`` as a stream in ``encoding`` shows it (see the module docstring)."""
    return text.encode(encoding, FALLBACK).decode(encoding)


_BROKEN_PIPE: list[bool] = []  # a write to stdout met a broken pipe (click ends quietly then)


def pipe_broken() -> bool:
    """Whether a write to stdout met a broken pipe in this process."""
    return bool(_BROKEN_PIPE)


class StdoutError(OSError):
    """A write to standard output failed (full, closed, an I/O error)."""


class _GuardedStdout(io.TextIOBase):
    """The real stdout, its write errors raised as :class:`StdoutError` (EPIPE as it is)."""

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def _guard(self, err: OSError) -> OSError:
        if isinstance(err, BrokenPipeError) or err.errno == errno.EPIPE:
            _BROKEN_PIPE.append(True)
            return err
        return StdoutError(err.errno, err.strerror or str(err))

    def write(self, s: str) -> int:
        try:
            return int(self._stream.write(s))
        except OSError as err:
            raise self._guard(err) from err

    def flush(self) -> None:
        try:
            self._stream.flush()
        except OSError as err:
            raise self._guard(err) from err

    def writable(self) -> bool:
        return True

    def isatty(self) -> bool:
        return bool(self._stream.isatty())

    def fileno(self) -> int:
        return int(self._stream.fileno())

    @property
    def encoding(self) -> str:  # type: ignore[override]
        return str(self._stream.encoding)

    @property
    def errors(self) -> str | None:  # type: ignore[override]
        return self._stream.errors

    def reconfigure(self, **kwargs: Any) -> None:
        self._stream.reconfigure(**kwargs)


class _ClosedStdout(io.TextIOBase):
    """Stands for a closed file descriptor 1: the first write raises ``EBADF``."""

    def write(self, s: str) -> int:
        raise StdoutError(errno.EBADF, "standard output is closed")

    def writable(self) -> bool:
        return True

    def isatty(self) -> bool:
        return False


def _fd_open(fd: int) -> bool:
    try:
        os.fstat(fd)
    except OSError:
        return False
    return True


def guard_streams() -> None:
    """Reconfigure stdout and stderr with :data:`FALLBACK`; wrap stdout (its failures raise
    :class:`StdoutError`); stand in for a closed stdout. Idempotent; called at the start of
    each run of the CLI (a broken pipe of an earlier in-process run is forgotten)."""
    _BROKEN_PIPE.clear()
    if sys.stdout is None or not _fd_open(1):
        sys.stdout = _ClosedStdout()
    elif not isinstance(sys.stdout, _GuardedStdout | _ClosedStdout) and hasattr(
        sys.stdout, "reconfigure"
    ):
        sys.stdout = _GuardedStdout(sys.stdout)
    for stream in (sys.stdout, sys.stderr):
        reconfigure: Any = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            try:
                reconfigure(errors=FALLBACK)
            except (ValueError, OSError, io.UnsupportedOperation):
                continue


def stdout_failure(err: OSError) -> str | None:
    """The one line of an output that cannot be written: stdout (:class:`StdoutError`), or a
    file on a full disk; None when ``err`` is neither (a bug, or an EPIPE: quiet)."""
    if isinstance(err, StdoutError):
        return f"cannot write to standard output: {err.strerror or err}"
    if err.errno not in STREAM_ERRNOS or err.errno in (errno.EBADF, errno.EPIPE):
        return None
    where = str(err.filename) if err.filename else "an output file"
    return f"cannot write {where}: {err.strerror or err}; the file was not replaced"


def silence_stdout() -> None:
    """Point file descriptor 1 at ``/dev/null`` (the text still buffered is dropped there)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:
        return
    try:
        if _fd_open(1):
            os.dup2(devnull, 1)
    finally:
        os.close(devnull)
    if isinstance(sys.stdout, _ClosedStdout | _GuardedStdout):
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 (the process's stdout until it ends)
