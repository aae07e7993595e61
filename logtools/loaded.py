"""The records reading a log gives: :class:`ResolvedSignals` (the logical signals found, where
each came from, what was repaired) and :class:`LoadedLog` (those signals aligned on one time
base, with the robot).

Records only: the code that fills them is :mod:`logtools.channel_map` and :mod:`logtools.load`.
This module imports no robot plugin machinery, so that the plugin contract
(:mod:`logtools.robots.base`) can name these types without an import circle.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from logtools.signals import RobotConfig, SignalOrigin, SignalSource

if TYPE_CHECKING:
    import polars as pl

    from logtools.align import Gap
    from logtools.problems import Problem
    from logtools.readers.base import LogData

__all__ = ["FlatSignal", "LoadedLog", "ResolvedSignals"]


@dataclass(frozen=True)
class FlatSignal:
    """A signal that carries nothing: every sample has the same value (e.g. an empty twist).

    Attributes:
        name: logical signal name.
        topic: its topic.
        field: its field path.
        value: the one value it holds (in the signal's unit).
        samples: how many samples hold it.
    """

    name: str
    topic: str
    field: str
    value: float
    samples: int

    def message(self, path: str) -> str:
        """One sentence for ``problems``."""
        return (
            f"{path}: signal {self.name!r} (topic {self.topic!r}, field {self.field!r}) is "
            f"{self.value:g} in all {self.samples} samples: it carries nothing and is not used"
        )


@dataclass(frozen=True)
class ResolvedSignals:
    """Logical signals found in a log.

    Attributes:
        signals: logical name -> frame (``t_ns`` int64 increasing, ``value`` float64 finite);
            derived signals (formulas, a robot's derivations) included.
        sources: logical name -> where it came from (derived: topic ``(derived)``, field the
            expression).
        missing: logical signals (of ``logtools.channel_map.logical_signals()``) not found.
        problems: what was repaired or left out (NaN dropped, duplicate timestamps, signals
            that carry nothing, what a robot's derivation noted).
        flat: signals found but not used because every sample holds the same value.
        origins: how each derived signal was obtained (a formula, a robot's derivation), and
            for a signal a robot could derive, that it was logged.
        robot: the channel map's ``[robot]`` table, its wheelbase completed from the ``logcal``
            metadata record when the map has none.
        outliers: single-sample outliers excluded from the signals (:mod:`logtools.outliers`),
            with times.
    """

    signals: dict[str, pl.DataFrame]
    sources: dict[str, SignalSource]
    missing: list[str]
    problems: list[str] = field(default_factory=list)
    flat: list[FlatSignal] = field(default_factory=list)
    origins: dict[str, SignalOrigin] = field(default_factory=dict)
    robot: RobotConfig = field(default_factory=RobotConfig)
    outliers: list[Problem] = field(default_factory=list)


@dataclass(frozen=True)
class LoadedLog:
    """A log read, resolved and aligned.

    Attributes:
        path: the file read.
        log: the raw frames per topic.
        signals: the logical signals found (raw per-signal frames ``signals.signals``), where
            they came from, the ones that carry nothing, and how derived ones were obtained
            (``signals.origins``).
        frame: aligned frame (``t_ns`` + one float64 column per signal, plus what the robot's
            ``prepare`` adds: the tractor-trailer's ``kappa`` (1/m) and ``kappa_source``).
        robot: the robot type, a plugin's name (channel map, metadata, else inferred from the
            signals).
        truth: true parameters from the ``logcal`` metadata record (simulated logs).
        problems: what was lost or repaired, from reading to alignment (``str(p)`` is the
            sentence; the signal resolution's sentences are ``ProblemKind.SIGNAL`` records).
        gaps: recorder stalls and dropouts of the signals, one record per stretch of time.
    """

    path: str
    log: LogData
    signals: ResolvedSignals
    frame: pl.DataFrame
    robot: str
    truth: dict[str, float]
    problems: list[Problem]
    gaps: list[Gap] = field(default_factory=list)

    @property
    def robot_config(self) -> RobotConfig:
        """The channel map's [robot] table (wheelbase completed from the metadata record)."""
        return self.signals.robot
