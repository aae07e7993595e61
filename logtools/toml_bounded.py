"""TOML from a file we were handed (a channel map, a ``logcal.toml``), parsed by ``tomllib`` only
when its arrays and inline tables nest at most :data:`MAX_DEPTH` deep.

``tomllib`` parses nested arrays by recursion: a file of 100,000 ``[`` runs it into the
interpreter's recursion limit. Catching that ``RecursionError`` is not enough: in a long-running
fuzz worker, such a parse ended in "SystemError: error return without exception set", and the
same process then failed unrelated calls and crashed. Counting the nesting first (one linear
scan that skips strings and comments) refuses such a file before any recursion happens.
"""

from __future__ import annotations

import tomllib
from typing import Any

__all__ = ["MAX_DEPTH", "TomlTooDeepError", "loads", "nesting_depth"]

MAX_DEPTH = 100
"""Deepest nesting of arrays and inline tables accepted (real files nest two or three deep)."""


class TomlTooDeepError(ValueError):
    """A TOML text whose arrays or inline tables nest deeper than :data:`MAX_DEPTH`."""


def _skip_string(text: str, i: int) -> int:
    """The index after the string starting at ``text[i]`` (a quote)."""
    q = text[i]
    n = len(text)
    if text.startswith(q * 3, i):  # multi-line: ends at the next unescaped triple quote
        j = i + 3
        while j < n:
            if q == '"' and text[j] == "\\":
                j += 2
                continue
            if text.startswith(q * 3, j):
                return j + 3
            j += 1
        return n
    j = i + 1
    while j < n and text[j] != "\n":
        if q == '"' and text[j] == "\\":
            j += 2
            continue
        if text[j] == q:
            return j + 1
        j += 1
    return j


def nesting_depth(text: str, stop_above: int = MAX_DEPTH) -> int:
    """How deep the brackets and braces of ``text`` nest outside strings and comments (the
    count stops once above ``stop_above``)."""
    depth = deepest = 0
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c in "\"'":
            i = _skip_string(text, i)
            continue
        if c == "#":
            end = text.find("\n", i)
            i = n if end < 0 else end
            continue
        if c in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > stop_above:
                    return deepest
        elif c in "]}":
            depth = max(0, depth - 1)
        i += 1
    return deepest


def loads(text: str) -> dict[str, Any]:
    """``tomllib.loads(text)`` once its nesting is at most :data:`MAX_DEPTH`.

    Raises:
        TomlTooDeepError: nested deeper (nothing parsed).
        tomllib.TOMLDecodeError: not TOML.
    """
    if nesting_depth(text) > MAX_DEPTH:
        raise TomlTooDeepError(f"arrays or tables nested more than {MAX_DEPTH} deep")
    return tomllib.loads(text)
