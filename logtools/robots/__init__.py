"""The robot plugins ``logcal`` knows, and how a log's robot is found.

A robot is a :class:`~logtools.robots.base.RobotPlugin`. Adding one takes its own modules plus
ONE line in ``_PLUGIN_MODULES`` below (or, from another package, an entry point in the group
``logcal.robots`` naming its plugin object, or :func:`register` at run time).

Plugins are imported lazily (on first use), so that reading a log never imports every robot's
numerics and the plugin modules may import ``logtools.load``.
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points

from logtools.errors import LogcalInputError
from logtools.robot_options import RobotOptions
from logtools.robots.base import RobotPlugin, SignalDerivation, SignalSpec

__all__ = [
    "RobotOptions",
    "RobotPlugin",
    "SignalDerivation",
    "SignalSpec",
    "UnknownRobotError",
    "identify_robot",
    "plugin_for",
    "plugins",
    "register",
]

_PLUGIN_MODULES: tuple[str, ...] = (
    "logtools.robots.tractor_trailer",
    "logtools.robots.diff_drive",
    "logtools.robots.manipulator",
)

_registered: list[RobotPlugin] = []
_loaded: list[RobotPlugin] | None = None


class UnknownRobotError(LogcalInputError):
    """A robot type that no plugin provides.

    Attributes:
        name: the robot type asked for.
        where: where the name came from (a file, the channel map, the command line).
        known: the robot types available.
    """

    def __init__(self, name: str, where: str, known: list[str]) -> None:
        self.name, self.where, self.known = name, where, known
        super().__init__(
            f"{where}: robot type {name!r} is not known; expected one of {', '.join(known)}."
        )


def _load() -> list[RobotPlugin]:
    global _loaded
    if _loaded is None:
        found = [importlib.import_module(m).PLUGIN for m in _PLUGIN_MODULES]
        for ep in entry_points(group="logcal.robots"):
            found.append(ep.load())
        _loaded = found
    return _loaded


def plugins() -> tuple[RobotPlugin, ...]:
    """Every robot plugin, built-in first, then entry points, then :func:`register`-ed ones."""
    return (*_load(), *_registered)


def register(plugin: RobotPlugin) -> None:
    """Add ``plugin`` (replacing one of the same name that was registered before)."""
    _registered[:] = [p for p in _registered if p.name != plugin.name] + [plugin]


def plugin_for(name: str, where: str = "robot type") -> RobotPlugin:
    """The plugin whose ``name`` (or alias) is ``name``.

    Raises:
        UnknownRobotError: no plugin has that name; the message lists the known ones.
    """
    for p in reversed(plugins()):
        if name == p.name or name in p.aliases:
            return p
    raise UnknownRobotError(name, where, [p.name for p in plugins()])


def identify_robot(signals: frozenset[str]) -> tuple[RobotPlugin, str] | None:
    """The first plugin whose signals are in ``signals``, with its reason; None if none."""
    for p in plugins():
        reason = p.identify(signals)
        if reason is not None:
            return p, reason
    return None
