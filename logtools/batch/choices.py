"""Choices of ``logcal batch`` that the command line needs before any work (kept free of heavy
imports so that ``logcal --help`` stays fast)."""

from __future__ import annotations

from enum import StrEnum

__all__ = ["Engine"]


class Engine(StrEnum):
    """Where a batch runs."""

    LOCAL = "local"
    """A process pool on this machine (``--workers N``)."""
    RAY = "ray"
    """A Ray cluster: a new local one with ``--workers`` CPUs, or ``--address ADDR``."""
