"""Where a residual's structure sits: time windows, segments and bins of each covariate whose
residual stands above the noise floor and holds more than its share of the excess.

The excess of a bin is its sum of squared residuals minus what the floor explains there; a bin
is *located* when its RMS exceeds the floor by the verdict's ratio and it holds at least 1.5x
the share of the excess its share of samples would give. When the excess is spread evenly, the
location is "throughout the log".
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.adequacy.channel import ResidualChannel
from calib.results import JsonRecord

__all__ = ["Location", "locate"]

FloatArray = NDArray[np.float64]

CONCENTRATION = 1.5
"""A bin is located when its share of the excess is at least this times its share of samples."""
MAX_LOCATIONS = 6


@dataclass(frozen=True)
class Location(JsonRecord):
    """One place where the residual stands above the noise.

    ``axis``: "time", "segment", or a covariate's name; ``lo``/``hi``: the bin's bounds on that
    axis (seconds for time); ``label``: for people; ``rms`` in the channel's unit; ``ratio``:
    rms / noise floor; ``share``: the bin's fraction of the channel's excess sum of squares;
    ``samples``: its fraction of the samples."""

    channel: str
    axis: str
    label: str
    lo: float
    hi: float
    rms: float
    ratio: float
    share: float
    samples: float


def _bins(values: FloatArray, n_bins: int) -> list[tuple[float, float, NDArray[np.bool_]]]:
    ok = np.isfinite(values)
    if ok.sum() < 2 * n_bins:
        return []
    edges = np.unique(np.quantile(values[ok], np.linspace(0.0, 1.0, n_bins + 1)))
    if edges.size < 3:
        return []
    out = []
    for i in range(edges.size - 1):
        lo, hi = float(edges[i]), float(edges[i + 1])
        last = i == edges.size - 2
        m = ok & (values >= lo) & ((values <= hi) if last else (values < hi))
        if m.any():
            out.append((lo, hi, m))
    return out


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def _axis_locations(
    ch: ResidualChannel,
    axis: str,
    bins: Sequence[tuple[str, float, float, NDArray[np.bool_]]],
    r2: FloatArray,
    floor: float,
    ratio: float,
) -> list[Location]:
    n = r2.size
    excess = np.array([max(float(r2[m].sum()) - m.sum() * floor**2, 0.0) for *_, m in bins])
    total = float(excess.sum())
    if total <= 0:
        return []
    out = []
    for (label, lo, hi, m), ex in zip(bins, excess, strict=True):
        k = int(m.sum())
        if k < 3:
            continue
        rms = math.sqrt(float(r2[m].mean()))
        share, frac = ex / total, k / n
        if rms > ratio * floor and share >= CONCENTRATION * frac:
            out.append(Location(ch.name, axis, label, lo, hi, rms, rms / floor, share, frac))
    return out


def locate(ch: ResidualChannel, floor: float, ratio: float) -> list[Location]:
    """The places of ``ch`` whose residual stands above ``ratio`` x ``floor`` and concentrates
    the excess (most excess first); one "throughout the log" location when none does."""
    t = np.asarray(ch.t_s, dtype=float)
    r = np.asarray(ch.residual, dtype=float)
    ok = np.isfinite(t) & np.isfinite(r)
    r2 = np.where(ok, r, 0.0) ** 2
    if ok.sum() < 10 or floor <= 0:
        return []
    found: list[Location] = []
    t0, t1 = float(t[ok][0]), float(t[ok][-1])
    n_win = int(min(10, max(2, ok.sum() // 50)))
    edges = np.linspace(t0, t1, n_win + 1)
    tb = [
        (
            f"t {_fmt(a)}-{_fmt(b)} s",
            float(a),
            float(b),
            ok & (t >= a) & ((t <= b) if i == n_win - 1 else (t < b)),
        )
        for i, (a, b) in enumerate(itertools.pairwise(edges))
    ]
    found += _axis_locations(ch, "time", tb, r2, floor, ratio)
    if ch.segments:
        sb = [
            (f"{lab} {_fmt(a)}-{_fmt(b)} s", a, b, ok & (t >= a) & (t < b))
            for lab, a, b in ch.segments
        ]
        found += _axis_locations(ch, "segment", sb, r2, floor, ratio)
    for name, values in ch.covariates.items():
        v = np.asarray(values, dtype=float)
        cb = [(f"{name} {_fmt(lo)} to {_fmt(hi)}", lo, hi, m & ok) for lo, hi, m in _bins(v, 5)]
        found += _axis_locations(ch, name, cb, r2, floor, ratio)
    if not found:
        rms = math.sqrt(float(r2[ok].mean()))
        return [Location(ch.name, "time", "throughout the log", t0, t1, rms, rms / floor, 1.0, 1.0)]
    found.sort(key=lambda loc: loc.share - loc.samples, reverse=True)
    return found[:MAX_LOCATIONS]
