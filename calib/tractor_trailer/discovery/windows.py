"""Which part of a long log discovery looks at: evenly spread windows up to a span budget.

Discovery refits the model with every candidate effect, hundreds of simulations of the log,
so its cost grows with the log's length (about 16 s of CPU for a 1-hour 100 Hz log). The
effects it names (delays, lags, scale errors, offsets, slip, understeer) are properties of the
vehicle and its sensors, not of one minute of driving: ten minutes of varied driving detect
them with a wide margin (the confusion study's logs are 1 to 10 minutes long). A longer log is
therefore looked at through windows spread evenly over its whole length, so that every part
of the drive (its speeds, commands, and any slow change) is represented, and the cost stops
growing with the length. The result says which span was used; ``max_span_s=None`` (CLI
``--discovery-span 0``) looks at everything.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import polars as pl

from calib.tractor_trailer.results import Segment

__all__ = ["DEFAULT_MAX_SPAN_S", "WINDOW_S", "DataWindows", "choose_windows", "restrict"]

DEFAULT_MAX_SPAN_S = 600.0
"""Longest stretch of log (s) discovery looks at by default."""

WINDOW_S = 120.0
"""Length (s) of each window: long enough that the restart at its start (the joint-angle
model forgets its initial state over a few metres of travel) costs a small part of it."""


MIN_WINDOW_S = 30.0
"""Shortest window (s) of a small budget split in two."""


@dataclass(frozen=True)
class DataWindows:
    """The windows (s from the log's first row) discovery used, and the log's span (s)."""

    spans_s: tuple[tuple[float, float], ...]
    total_s: float

    @property
    def used_s(self) -> float:
        return sum(b - a for a, b in self.spans_s)

    def note(self) -> str:
        n = len(self.spans_s)
        return (
            f"Discovery looked at {self.used_s:.0f} s of the {self.total_s:.0f} s log: {n} "
            f"windows of {self.spans_s[0][1] - self.spans_s[0][0]:.0f} s spread evenly over it "
            "(logcal analyze --discovery-span SECONDS to change; 0 looks at all of it)."
        )

    def to_dict(self) -> dict[str, object]:
        return {
            "windows_s": [list(w) for w in self.spans_s],
            "used_s": self.used_s,
            "total_s": self.total_s,
        }


def choose_windows(
    total_s: float, max_span_s: float | None, window_s: float = WINDOW_S
) -> DataWindows | None:
    """Windows covering ``max_span_s`` of a log ``total_s`` long, about ``window_s`` each
    (at least two when the budget allows ``MIN_WINDOW_S`` each), the first at the log's start
    and the last at its end; None when the whole log fits the budget (or there is none)."""
    if max_span_s is None or max_span_s <= 0 or not math.isfinite(total_s):
        return None
    if total_s <= max_span_s:
        return None
    n = max(1, round(max_span_s / window_s))
    if n == 1 and max_span_s >= 2 * MIN_WINDOW_S:
        n = 2  # a start and an end rather than the start alone
    width = max_span_s / n
    if n == 1:
        return DataWindows(((0.0, width),), total_s)
    step = (total_s - width) / (n - 1)
    return DataWindows(tuple((i * step, i * step + width) for i in range(n)), total_s)


def _time_filter(t_ns: pl.Expr, t0_ns: int, windows: DataWindows) -> pl.Expr:
    cond = pl.lit(False)
    for a, b in windows.spans_s:
        lo, hi = t0_ns + round(a * 1e9), t0_ns + round(b * 1e9)
        cond = cond | ((t_ns >= lo) & (t_ns <= hi))
    return cond


def restrict(
    frame: pl.DataFrame,
    signals: Mapping[str, pl.DataFrame] | None,
    segments: Sequence[Segment] | None,
    windows: DataWindows,
) -> tuple[pl.DataFrame, dict[str, pl.DataFrame] | None, list[Segment] | None]:
    """The frame's rows, the signals' samples and the segments inside the windows. Times
    stay relative to the log's first row (the first window starts there)."""
    t0 = int(frame.get_column("t_ns").min())  # type: ignore[arg-type]
    keep = _time_filter(pl.col("t_ns"), t0, windows)
    sub = frame.filter(keep)
    sig = (
        None
        if signals is None
        else {k: (v.filter(keep) if "t_ns" in v.columns else v) for k, v in signals.items()}
    )
    segs = None
    if segments is not None:
        segs = [
            s for s in segments if any(s.start_s < b and s.end_s > a for a, b in windows.spans_s)
        ]
    return sub, sig, segs
