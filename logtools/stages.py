"""Stage boundaries of an analysis: each stage (segmentation, methods, estimators, discovery)
runs inside its own, so that a stage that lacks data or fails numerically says so and the
others still report. Shared by every robot plugin."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from calib.errors import InsufficientDataError
from calib.results import StageStatus
from logtools.errors import LogcalInputError

__all__ = ["Stages"]

T = TypeVar("T")


class Stages:
    """Runs each stage inside its own boundary: too little data -> "skipped", any numerical
    failure -> "failed", each with its reason; the other stages go on. ``debug`` re-raises.

    ``status`` lists how each stage ended (in order), ``errors`` the exception of each stage
    that did not end "ok", by stage name.
    """

    def __init__(self, debug: bool) -> None:
        self.debug = debug
        self.status: list[StageStatus] = []
        self.errors: dict[str, Exception] = {}

    def run(self, stage: str, fn: Callable[[], T]) -> T | None:
        """``fn()``, or None when it raised (the stage's status then says why)."""
        try:
            out = fn()
        except (InsufficientDataError, LogcalInputError) as err:
            if self.debug:
                raise
            self.errors[stage] = err
            self.status.append(StageStatus(stage, "skipped", str(err)))
            return None
        except (KeyboardInterrupt, MemoryError):
            raise
        except Exception as err:  # a numerical failure stays inside its stage
            if self.debug:
                raise
            self.errors[stage] = err
            self.status.append(StageStatus(stage, "failed", f"{type(err).__name__}: {err}"))
            return None
        self.status.append(StageStatus(stage, "ok"))
        return out

    def skip(self, stage: str, reason: str) -> None:
        """Record that ``stage`` did not run, and why."""
        self.status.append(StageStatus(stage, "skipped", reason))
