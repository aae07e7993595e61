"""What was lost or repaired on the way from a file to an aligned frame, as typed records.

A :class:`Problem` carries the structured facts (what kind, which topic, which stretch of time,
how many messages or rows) so that code and tests decide on fields, never on the wording; its
``str`` is the sentence the report and ``logcal info`` print.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

__all__ = ["Problem", "ProblemKind"]


class ProblemKind(StrEnum):
    """The kinds of loss or repair the readers, the signal resolution and the alignment report."""

    LOST_MESSAGES = "lost_messages"
    """Fewer messages read than the MCAP summary lists for a channel (``count`` lost)."""
    LOST_CHUNK = "lost_chunk"
    """A chunk that did not open (``t0_ns``..``t1_ns``: the log times it held)."""
    CHUNK_ERROR = "chunk_error"
    """A chunk whose decompression failed for a reason other than a CRC mismatch."""
    CORRUPT_BYTES = "corrupt_bytes"
    """A corrupt byte range skipped to reach the next chunk (``count`` bytes)."""
    TRUNCATED = "truncated"
    """Unreadable bytes after the last good record (``count`` bytes)."""
    NO_FOOTER = "no_footer"
    """The file ends without an MCAP footer."""
    BAD_LOG_TIME = "bad_log_time"
    """Messages with an impossible log_time, dropped (``count``)."""
    UNKNOWN_CHANNEL = "unknown_channel"
    """Messages naming a channel the file does not define, dropped (``count``)."""
    UNKNOWN_ENCODING = "unknown_encoding"
    """A topic in a message encoding no decoder was given for (``count`` messages)."""
    UNKNOWN_TYPE = "unknown_type"
    """A bag topic whose message type is neither in the bag nor a standard type."""
    UNDECODABLE = "undecodable"
    """A whole channel that could not be decoded, e.g. its schema does not parse."""
    DROPPED_MESSAGES = "dropped_messages"
    """Some messages of a topic did not decode and were dropped (``count``)."""
    UNSORTED = "unsorted"
    """Time went backwards (``count`` times); the messages or rows were sorted."""
    NO_TIME = "no_time"
    """CSV rows without a finite time, dropped (``count``)."""
    GAP = "gap"
    """A stretch ``t0_ns``..``t1_ns`` without samples on some signals (a recorder stall)."""
    DROPOUT = "dropout"
    """Aligned rows of a signal left null beyond the gaps (``count`` rows)."""
    SIGNAL = "signal"
    """A repair or choice made while resolving the logical signals (channel map)."""
    OUTLIER = "outlier"
    """Samples of a signal that jump away and back (robust rate-of-change test), excluded
    (``count``; ``t0_ns``..``t1_ns``: first and last such sample)."""
    TIME_UNIT = "time_unit"
    """A CSV time column in epoch milliseconds, microseconds or nanoseconds, rescaled to s."""
    CONCATENATED = "concatenated"
    """A second MCAP file appended after the first one's footer (``count`` bytes), not read."""
    DUPLICATE_CHANNEL = "duplicate_channel"
    """A channel id defined twice with different topics or encodings (``count`` redefinitions)."""


@dataclass(frozen=True)
class Problem:
    """One loss or repair.

    Attributes:
        kind: what happened.
        topic: the topic (or, for ``GAP``/``DROPOUT``/``SIGNAL``, the signal) concerned; None
            when it concerns the file.
        t0_ns: start of the affected time (log time, ns), when known.
        t1_ns: end of the affected time (ns), when known.
        count: how many messages, rows, bytes or occurrences (see :class:`ProblemKind`).
        message: the sentence for people, naming the file.
    """

    kind: ProblemKind
    topic: str | None = None
    t0_ns: int | None = None
    t1_ns: int | None = None
    count: int | None = None
    message: str = ""

    def __str__(self) -> str:
        return self.message

    def to_dict(self) -> dict[str, object]:
        """JSON-safe dictionary of the fields."""
        return {
            "kind": self.kind.value,
            "topic": self.topic,
            "t0_ns": self.t0_ns,
            "t1_ns": self.t1_ns,
            "count": self.count,
            "message": self.message,
        }
