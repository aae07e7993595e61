"""Logical signal names: LOG_FORMAT.md's, the per-joint ``q1``, ``qd1``, ``tau1``, … of
``/joint_states``, and those the robot plugins declare (with their units and default sources).
"""

from __future__ import annotations

import re

from logtools.robots import plugins
from logtools.signals import SIGNAL_UNITS, SignalSource

__all__ = [
    "JOINT_ARRAYS",
    "JOINT_SIGNAL",
    "JOINT_TOPIC",
    "JOINT_UNITS",
    "LOGICAL_SIGNALS",
    "is_logical_signal",
    "plugin_sources",
    "plugin_units",
    "si_unit",
]

LOGICAL_SIGNALS: tuple[str, ...] = (*(s for s in SIGNAL_UNITS if s != "kappa"), "q", "qd", "tau")
"""Logged signals (``kappa`` is derived, never logged); q/qd/tau stand for q1, q2, … per joint."""

JOINT_TOPIC = "/joint_states"
JOINT_ARRAYS = {"position": "q", "velocity": "qd", "effort": "tau"}
JOINT_SIGNAL = re.compile(r"^(q|qd|tau)([1-9]\d*)$")
JOINT_UNITS = {"q": "rad", "qd": "rad/s", "tau": "N·m"}


def plugin_sources() -> dict[str, list[SignalSource]]:
    """Default sources the robot plugins declare (``SignalSpec.sources``), after ours."""
    out: dict[str, list[SignalSource]] = {}
    for p in plugins():
        for spec in p.signals:
            out.setdefault(spec.name, []).extend(spec.sources)
    return out


def plugin_units() -> dict[str, str]:
    """Units of the signals the robot plugins declare beyond LOG_FORMAT.md's."""
    return {s.name: s.unit for p in plugins() for s in p.signals}


def is_logical_signal(name: str) -> bool:
    """True for a logical signal name, including per-joint names like ``q1`` or ``tau2`` and
    the signals a robot plugin declares."""
    return name in LOGICAL_SIGNALS or JOINT_SIGNAL.match(name) is not None or name in plugin_units()


def si_unit(name: str) -> str | None:
    """The SI unit of a logical signal (a joint's by its family); None for another name."""
    m = JOINT_SIGNAL.match(name)
    if m:
        return JOINT_UNITS[m.group(1)]
    return SIGNAL_UNITS.get(name) or plugin_units().get(name)
