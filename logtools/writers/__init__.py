"""Log writers: simulated runs -> MCAP (JSON or ROS 2) and CSV drive logs (LOG_FORMAT.md).

The generic writers (:func:`write_frames_mcap` with a :class:`JsonEncoder` or
:class:`CdrEncoder`, and :func:`write_frames_csv`) map sensor-group frames onto topics through
:class:`TopicBinding` lists. Each robot's writer is a module of its own here
(:mod:`logtools.writers.tractor_trailer`, :mod:`~logtools.writers.diff_drive`,
:mod:`~logtools.writers.manipulator`), declaring its bindings, and is imported from that module
by the robot's code; this package exports only the generic writers.

The writers load numpy, polars and mcap on first use of a name exported here, so that
``logtools.writers.encoding`` (the :class:`LogEncoding` choices the CLI needs at start-up)
stays cheap to import.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

from logtools.writers.encoding import ENCODINGS, LogEncoding

if TYPE_CHECKING:
    from logtools.writers.csv_writer import frames_to_table, write_frames_csv
    from logtools.writers.mcap_writer import (
        CdrEncoder,
        JsonEncoder,
        TopicBinding,
        json_schema,
        write_frames_mcap,
    )
    from logtools.writers.ros2_msgdefs import MSGDEFS, msgdef

__all__ = [
    "ENCODINGS",
    "MSGDEFS",
    "CdrEncoder",
    "JsonEncoder",
    "LogEncoding",
    "TopicBinding",
    "frames_to_table",
    "json_schema",
    "msgdef",
    "write_frames_csv",
    "write_frames_mcap",
]

_LAZY = {
    "frames_to_table": "csv_writer",
    "write_frames_csv": "csv_writer",
    "CdrEncoder": "mcap_writer",
    "JsonEncoder": "mcap_writer",
    "TopicBinding": "mcap_writer",
    "json_schema": "mcap_writer",
    "write_frames_mcap": "mcap_writer",
    "MSGDEFS": "ros2_msgdefs",
    "msgdef": "ros2_msgdefs",
}


def __getattr__(name: str) -> object:
    """Import the writer that defines ``name`` on first use (PEP 562)."""
    try:
        module = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
