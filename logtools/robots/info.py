"""What a robot adds to ``logcal info`` (``RobotPlugin.info``): the :class:`InfoSection` its
hook returns from the options ``info`` was given (those declared ``option(..., info=True)``),
e.g. the manipulator's URDF transmissions for ``info --urdf``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

__all__ = ["InfoFn", "InfoSection", "load_info"]


@dataclass(frozen=True)
class InfoSection:
    """One robot's part of ``logcal info``.

    Attributes:
        key: its key in the ``--json`` document (e.g. ``urdf``).
        doc: its JSON value (JSON-safe).
        lines: what people read, one line each (printed after the logs' summaries).
    """

    key: str
    doc: Mapping[str, Any]
    lines: Sequence[str] = field(default_factory=tuple)


class InfoFn(Protocol):
    """A robot's ``info`` hook: its section of ``logcal info`` from the robot's options (an
    instance of its ``RobotPlugin.options``), or None when the options given ask for none.

    Raises:
        LogcalInputError: an option's value cannot be used (the message names the flag).
    """

    def __call__(self, options: Any) -> InfoSection | None: ...


def load_info(path: str) -> InfoFn:
    """The :class:`InfoFn` named by ``RobotPlugin.info`` (``"module:function"``)."""
    import importlib

    module, _, name = path.partition(":")
    fn: InfoFn = getattr(importlib.import_module(module), name)
    return fn
