"""The settings of one analysis (:class:`AnalysisConfig`), read by every robot's plugin.

A record only: the pipeline that uses it is :mod:`logtools.analyze`. This module imports no
robot plugin machinery, so that the plugin contract (:mod:`logtools.robots.base`) can name it
without an import circle.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TypeVar

from logtools.robot_options import RobotOptions

__all__ = ["AnalysisConfig"]

T = TypeVar("T", bound=RobotOptions)


@dataclass(frozen=True)
class AnalysisConfig:
    """Settings of one analysis.

    Args:
        repeats: repeats (moving-block bootstrap replicates) per method table row.
        seed: seed of every random draw (bootstrap), for reproducible reports.
        discovery: run model-mismatch discovery.
        per_segment: also report the method table per command type.
        debug: let a failing stage raise (with its traceback) instead of recording it.
        robot_options: each robot's own options by plugin name (an instance of that plugin's
            ``options`` class); a robot not named gets its options' defaults. Read them with
            :meth:`options`.
        window_s: analyse the log by time windows of this many seconds, each read and analysed
            on its own and the windows' estimates pooled (:mod:`logtools.windows`); 0: the whole
            log at once; None (default): windows only when the log is long (more than about
            2 h of samples at 100 Hz), so that memory stays bounded in the log's length.
    """

    repeats: int = 10
    seed: int = 0
    discovery: bool = True
    per_segment: bool = True
    debug: bool = False
    robot_options: Mapping[str, RobotOptions] = field(default_factory=dict)
    window_s: float | None = None

    def __post_init__(self) -> None:
        for name, opts in self.robot_options.items():
            if not isinstance(opts, RobotOptions):
                raise TypeError(
                    f"robot_options[{name!r}]: expected a RobotOptions instance, "
                    f"got {type(opts).__name__}"
                )

    def options(self, cls: type[T]) -> T:
        """The options of class ``cls`` given for this analysis, else ``cls()`` (defaults)."""
        for opts in self.robot_options.values():
            if type(opts) is cls:
                return opts
        return cls()
