"""Choices of the arm simulator named on the command line, kept free of numpy so that the CLI
can build its options without importing the numerics."""

from __future__ import annotations

from enum import StrEnum

__all__ = ["Conceal"]


class Conceal(StrEnum):
    """What a simulated log's declared model leaves out (``logcal simulate manipulator
    --conceal``), for discovery to name."""

    FRICTION = "friction"
    PAYLOAD = "payload"
