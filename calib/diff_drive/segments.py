"""Cut runs into calibration segments: consecutive windows of fixed duration, each starting from
the ground-truth pose, so that dead-reckoning errors do not carry from one to the next."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from calib.diff_drive.data import DriveRun

__all__ = ["SegmentIndex", "cut_segments", "segment_length"]

MIN_WHEEL_TRAVEL_RAD = 0.5
"""A segment counts only if a wheel turned at least this much (rad) in it: standing still
carries nothing about the parameters, only noise."""


@dataclass(frozen=True)
class SegmentIndex:
    """Samples ``start``..``stop`` (inclusive) of run number ``run``."""

    run: int
    start: int
    stop: int


def cut_segments(runs: Sequence[DriveRun], segment_s: float) -> list[SegmentIndex]:
    """Windows of ``segment_s`` seconds (the last one of a run may be shorter, down to half),
    in run order; windows where neither wheel turned ``MIN_WHEEL_TRAVEL_RAD`` are left out."""
    if not segment_s > 0:
        raise ValueError(f"segment length must be > 0 s, got {segment_s!r}")
    out: list[SegmentIndex] = []
    for k, run in enumerate(runs):
        if run.n < 2:
            continue
        edges = np.arange(run.t[0], run.t[-1] + 1e-9, segment_s)
        idx = np.unique(np.searchsorted(run.t, edges))
        if idx[-1] != run.n - 1:
            if run.t[-1] - run.t[idx[-1]] >= 0.5 * segment_s or idx.size == 1:
                idx = np.append(idx, run.n - 1)
            else:
                idx[-1] = run.n - 1
        for a, b in itertools.pairwise(idx):
            travel = max(
                abs(run.wheel_right[b] - run.wheel_right[a]),
                abs(run.wheel_left[b] - run.wheel_left[a]),
                float(np.sum(np.abs(np.diff(run.wheel_right[a : b + 1])))),
            )
            if b > a and travel >= MIN_WHEEL_TRAVEL_RAD:
                out.append(SegmentIndex(k, int(a), int(b)))
    return out


def segment_length(
    runs: Sequence[DriveRun], want: int = 30, longest: float = 4.0, shortest: float = 1.0
) -> float:
    """A segment length (s) that cuts ``runs`` into about ``want`` segments: ``longest`` for a
    long log, down to ``shortest`` for a short one (a 30 s log still gives the joint fits and
    the two-fold check a few dozen segments)."""
    total = sum(float(r.t[-1] - r.t[0]) for r in runs if r.n >= 2)
    if total <= 0:
        return longest
    return float(min(longest, max(shortest, total / want)))
