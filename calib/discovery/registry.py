"""One effect registry for every robot: effects added to a robot's catalogue from outside it.

A robot's catalogue is its built-in effects followed by the registered ones. One behaviour
everywhere: ``register`` checks the entry's hook (the robot says what its fitter needs), adds
the entry after the built-in ones and returns it; registering the same entry again is a no-op;
a *different* entry under a key the catalogue already holds (built in or registered) is
refused with ValueError, since keys name effects in every report; ``unregister`` takes a key
(or the entry) and is silent when nothing is registered under it.

An entry is whatever the robot's catalogue lists: an :class:`~calib.discovery.base.EffectSpec`
with its model hook for most robots, or a factory making a fresh effect object for an engine
whose effects remember intermediate results (the tractor-trailer's command-driven discovery).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Generic, TypeVar

__all__ = ["EffectRegistry"]

E = TypeVar("E")


class EffectRegistry(Generic[E]):
    """The registered effects of one robot's catalogue (see the module docstring).

    Args:
        robot: the catalogue's name in messages ("diff drive", "arm").
        key: an entry's key (``id(target)``).
        builtin: the built-in entries' keys (checked against on registration).
        check: the reason an entry cannot be registered (no hook of the right protocol, say),
            or None when it can.
    """

    def __init__(
        self,
        robot: str,
        *,
        key: Callable[[E], str],
        builtin: Callable[[], Iterable[str]] = tuple,
        check: Callable[[E], str | None] | None = None,
    ) -> None:
        self.robot = robot
        self._key = key
        self._builtin = builtin
        self._check = check
        self._entries: list[E] = []

    def register(self, entry: E) -> E:
        """Add ``entry`` after the built-in effects; returns it (ValueError: see the module
        docstring)."""
        key = self._key(entry)
        why = self._check(entry) if self._check is not None else None
        if why:
            raise ValueError(f"{self.robot} effect {key}: {why}")
        if any(e is entry or e == entry for e in self._entries):
            return entry
        taken = set(self._builtin()) | {self._key(e) for e in self._entries}
        if key in taken:
            raise ValueError(f"{self.robot} effect {key}: already in the catalogue")
        self._entries.append(entry)
        return entry

    def unregister(self, entry: E | str) -> None:
        """Take the entry registered under this key (or ``entry``'s key) out again."""
        key = entry if isinstance(entry, str) else self._key(entry)
        self._entries[:] = [e for e in self._entries if self._key(e) != key]

    def entries(self) -> tuple[E, ...]:
        """The registered entries, in order of registration."""
        return tuple(self._entries)
