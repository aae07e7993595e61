"""What the views read of a loaded log and of a robot's options, as structural types: ``viz``
draws what it is handed and depends on no ``logtools`` type (the data flow runs logtools ->
calib -> viz, never back)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Protocol

import polars as pl

__all__ = ["LoadedLike", "RawLog", "TractorViewOptions"]


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


class TractorViewOptions(Protocol):
    """The tractor-trailer's view option: the method whose lengths also draw the joint angle."""

    @property
    def method_for_psi(self) -> str | None: ...
