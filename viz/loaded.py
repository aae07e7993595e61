"""What the views read of a loaded log, as structural types: ``viz`` draws what it is handed
and depends on no ``logtools`` type (the data flow runs logtools -> calib -> viz, never back).
A robot's options are read the same way, by a protocol in its own room (e.g.
``viz.tractor_trailer.views.TractorViewOptions``)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import polars as pl

__all__ = ["LoadedLike", "RawLog"]


class RawLog(Protocol):
    """The log as read: topic -> frame with ``t_ns``."""

    @property
    def topics(self) -> Mapping[str, pl.DataFrame]: ...


class LoadedLike(Protocol):
    """A loaded log: its aligned ``frame`` and the ``log`` as read."""

    @property
    def frame(self) -> pl.DataFrame: ...

    @property
    def log(self) -> RawLog: ...
