"""``logcal info``: a curvature command derived from a twist (omega / v) is undefined during a
stop or a spot turn; those stretches are not gaps of the recording."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl

from logtools.loginfo import summarize_log


def _log(tmp_path: Path, *, stall: bool) -> Path:
    t = np.arange(0.0, 30.0, 0.1)
    v = np.where((t > 10) & (t < 14), 0.0, 1.0)  # a 4 s spot turn
    frame = pl.DataFrame(
        {
            "t": t,
            "v_cmd": v,
            "omega_cmd": np.full_like(t, 0.3),
            "v": v,
            "omega": np.full_like(t, 0.3),
            "psi": 0.1 * np.sin(t / 3),
        }
    )
    if stall:  # the recorder stops for 5 s: a real gap of every signal
        frame = frame.filter((pl.col("t") < 20) | (pl.col("t") > 25))
    out = tmp_path / ("stall.csv" if stall else "spot.csv")
    frame.write_csv(out)
    return out


def test_spot_turn_is_not_a_gap_of_the_derived_command(tmp_path: Path) -> None:
    summary = summarize_log(_log(tmp_path, stall=False))
    origin = summary.origins.get("kappa_cmd")
    assert origin is not None
    assert origin.kind == "twist"
    assert summary.gaps == []


def test_a_recorder_stall_is_still_a_gap(tmp_path: Path) -> None:
    summary = summarize_log(_log(tmp_path, stall=True))
    assert len(summary.gaps) == 1
    g = summary.gaps[0]
    assert "kappa_cmd" not in g.signals
    assert "psi" in g.signals
