"""Logical signal names: the shared core's (:data:`logtools.signals.SHARED_SIGNALS`), those the
robot plugins declare (``RobotPlugin.signals``: units, default sources, what the resolution must
know of each), and the per-element signals of a family a plugin declares
(``SignalSpec.per_element``: ``NAME1``, ``NAME2``, … from an array of ``/joint_states``).

The shared resolution reads every signal's properties here and names no robot's signal itself:
a robot brings its vocabulary in its plugin's declaration.
"""

from __future__ import annotations

import re
from dataclasses import replace

from logtools.robots import plugins
from logtools.robots.base import RobotPlugin
from logtools.signals import SHARED_SIGNALS, RobotKey, SignalSource, SignalSpec

__all__ = [
    "JOINT_TOPIC",
    "command_signals",
    "element_families",
    "element_family",
    "heading_signals",
    "is_logical_signal",
    "joint_arrays",
    "logical_signals",
    "plugin_sources",
    "plugin_units",
    "robot_keys",
    "si_unit",
    "signal_spec",
    "vocabulary",
]

JOINT_TOPIC = "/joint_states"
"""The standard ROS topic of ``sensor_msgs/JointState`` (arrays ``name``, ``position``, …)."""

_ELEMENT = re.compile(r"^(.*\D)([1-9]\d*)$")

_cache: tuple[tuple[RobotPlugin, ...], dict[str, SignalSpec]] | None = None


def vocabulary() -> dict[str, SignalSpec]:
    """Every logical signal by name: the shared core's first, then each plugin's in plugin order.

    A signal declared more than once keeps its first unit and meaning; its flags are those any
    declaration sets, its default sources every declaration's in order (each once)."""
    global _cache
    current = plugins()
    if _cache is not None and _same_plugins(_cache[0], current):
        return _cache[1]
    merged: dict[str, SignalSpec] = {}
    for spec in (*SHARED_SIGNALS, *(s for p in current for s in p.signals)):
        merged[spec.name] = _merge(merged[spec.name], spec) if spec.name in merged else spec
    _cache = (current, merged)
    return merged


def _same_plugins(a: tuple[RobotPlugin, ...], b: tuple[RobotPlugin, ...]) -> bool:
    return len(a) == len(b) and all(x is y for x, y in zip(a, b, strict=True))


def _merge(first: SignalSpec, other: SignalSpec) -> SignalSpec:
    """``first`` with the flags and sources ``other`` adds."""
    sources = (*first.sources, *(s for s in other.sources if s not in first.sources))
    return replace(
        first,
        required=first.required,
        sources=sources,
        command=first.command or other.command,
        empty_when_zero=first.empty_when_zero or other.empty_when_zero,
        within_turn=first.within_turn or other.within_turn,
        heading=first.heading or other.heading,
        heading_rate=first.heading_rate or other.heading_rate,
        joint_words=first.joint_words or other.joint_words,
        body=first.body or other.body,
    )


def robot_keys() -> dict[str, RobotKey]:
    """The ``[robot]`` keys the plugins declare (``RobotPlugin.robot_keys``), the first
    declaration of a name kept."""
    out: dict[str, RobotKey] = {}
    for p in plugins():
        for key in p.robot_keys:
            out.setdefault(key.name, key)
    return out


def element_families() -> dict[str, SignalSpec]:
    """The declared families of per-element signals (``SignalSpec.per_element``) by name."""
    return {n: s for n, s in vocabulary().items() if s.per_element is not None}


def element_family(name: str) -> str | None:
    """The family of a per-element signal (``NAME3`` -> ``NAME``); None for another name."""
    m = _ELEMENT.match(name)
    return m.group(1) if m is not None and m.group(1) in element_families() else None


def joint_arrays() -> dict[str, str]:
    """Array of the joint-state topic -> the family of signals its elements are."""
    return {s.per_element: n for n, s in element_families().items() if s.per_element}


def signal_spec(name: str) -> SignalSpec | None:
    """The declaration of ``name`` (a per-element signal's by its family); None if none."""
    found = vocabulary().get(name)
    if found is None and (family := element_family(name)) is not None:
        found = vocabulary().get(family)
    return found


def logical_signals() -> tuple[str, ...]:
    """Names of the logged signals (a family stands for its elements ``NAME1``, …)."""
    return tuple(vocabulary())


def command_signals() -> frozenset[str]:
    """Signals that are commands: held between samples, and allowed to be constant."""
    return frozenset(n for n, s in vocabulary().items() if s.command)


def heading_signals() -> frozenset[str]:
    """Signals that are headings: unwrapped to interpolate, wrapped to [-pi, pi) after."""
    return frozenset(n for n, s in vocabulary().items() if s.heading)


def plugin_sources() -> dict[str, list[SignalSource]]:
    """Default sources the robot plugins declare (``SignalSpec.sources``), after ours."""
    return {n: list(s.sources) for n, s in vocabulary().items() if s.sources}


def plugin_units() -> dict[str, str]:
    """Units of every declared signal."""
    return {n: s.unit for n, s in vocabulary().items()}


def is_logical_signal(name: str) -> bool:
    """True for a declared logical signal, or an element of a declared family (``NAME2``)."""
    return name in vocabulary() or element_family(name) is not None


def si_unit(name: str) -> str | None:
    """The SI unit of a logical signal (an element's by its family); None for another name."""
    spec = signal_spec(name)
    return spec.unit if spec is not None else None
