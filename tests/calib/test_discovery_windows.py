"""Discovery on a long log looks at evenly spread windows up to its span budget."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest

from calib.tractor_trailer.discovery.windows import (
    DEFAULT_MAX_SPAN_S,
    WINDOW_S,
    choose_windows,
    restrict,
)
from calib.tractor_trailer.results import CommandType, Segment


def test_a_log_within_the_budget_is_used_whole() -> None:
    assert choose_windows(DEFAULT_MAX_SPAN_S, DEFAULT_MAX_SPAN_S) is None
    assert choose_windows(3600.0, None) is None
    assert choose_windows(3600.0, 0.0) is None


def test_windows_span_the_log_from_start_to_end() -> None:
    w = choose_windows(3600.0, 600.0)
    assert w is not None
    assert len(w.spans_s) == 5
    assert w.spans_s[0] == (0.0, WINDOW_S)
    assert w.spans_s[-1][1] == pytest.approx(3600.0)
    assert w.used_s == pytest.approx(600.0)
    gaps = np.diff([a for a, _ in w.spans_s])
    np.testing.assert_allclose(gaps, gaps[0])  # evenly spread
    assert "600 s of the 3600 s log" in w.note()
    small = choose_windows(1000.0, 90.0)
    assert small is not None
    assert small.spans_s == ((0.0, 45.0), (955.0, 1000.0))
    tiny = choose_windows(1000.0, 40.0)
    assert tiny is not None
    assert tiny.spans_s == ((0.0, 40.0),)


def test_restrict_keeps_rows_samples_and_segments_inside() -> None:
    t_ns = np.arange(0, 4000) * 1_000_000_000  # 1 Hz for 4000 s
    frame = pl.DataFrame({"t_ns": t_ns, "x": np.arange(4000.0)})
    sig = {"psi": pl.DataFrame({"t_ns": t_ns[::2], "value": np.zeros(2000)})}
    segs = [
        Segment(0.0, 50.0, CommandType.HARMONIC),
        Segment(1000.0, 1100.0, CommandType.CURVE),
        Segment(3900.0, 3999.0, CommandType.LINEAR),
    ]
    w = choose_windows(3999.0, 240.0)
    assert w is not None
    assert len(w.spans_s) == 2
    sub, sig2, seg2 = restrict(frame, sig, segs, w)
    t = sub.get_column("t_ns").to_numpy() / 1e9
    inside = np.zeros(t.size, dtype=bool)
    for a, b in w.spans_s:
        inside |= (t >= a) & (t <= b)
    assert inside.all()
    assert sub.height == 242  # 121 whole seconds in each closed window
    assert sig2 is not None
    assert sig2["psi"].height == 61 + 60  # even seconds only
    assert seg2 is not None
    assert [s.command_type for s in seg2] == [CommandType.HARMONIC, CommandType.LINEAR]
