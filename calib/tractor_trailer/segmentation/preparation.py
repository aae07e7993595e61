"""Preparing the command: input checks, decimation to a uniform grid, scale and noise level."""

from __future__ import annotations

import numpy as np

from calib.stats import hf_noise_std

__all__ = ["clean_inputs", "command_scale", "decimate", "noise_sigma"]


def clean_inputs(t_s: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or t.shape != y.shape:
        raise ValueError(
            f"segment_command: t_s and kappa_cmd must be 1-D of equal length, got shapes "
            f"{t.shape} and {y.shape}"
        )
    if t.size and (not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0)):
        raise ValueError("segment_command: t_s (s) must be finite and strictly increasing")
    ok = np.isfinite(y)
    if ok.any() and not ok.all():
        y = np.interp(t, t[ok], y[ok])  # bridge missing command samples
    return t, y


def decimate(
    t: np.ndarray, y: np.ndarray, rate_hz: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid of period max(median dt, 1 / rate_hz), nearest-sample values and their indices.

    Grid points farther than half a period from any sample (dropouts) get linearly
    interpolated values instead, so a gap does not look like a jump.
    """
    dt = max(float(np.median(np.diff(t))), 1.0 / rate_hz)
    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    grid = t[0] + np.arange(n) * dt
    hi = np.clip(np.searchsorted(t, grid), 0, t.size - 1)
    lo = np.clip(hi - 1, 0, t.size - 1)
    idx = np.where(np.abs(t[lo] - grid) <= np.abs(t[hi] - grid), lo, hi)
    values = y[idx]
    gap = np.abs(t[idx] - grid) > 0.5 * dt  # inside a dropout: bridge linearly
    values[gap] = np.interp(grid[gap], t, y)
    return grid, values, idx


def command_scale(y: np.ndarray) -> float:
    return float(np.percentile(np.abs(y - np.median(y)), 99)) if y.size else 0.0


def noise_sigma(y: np.ndarray, floor: float) -> float:
    """Noise standard deviation from second differences (robust), at least ``floor``."""
    if y.size < 5:
        return floor
    d2 = y[2:] - 2 * y[1:-1] + y[:-2]
    mad = hf_noise_std(y)
    a = np.sort(np.abs(d2))[: max(1, int(0.98 * d2.size))]
    trimmed = float(np.sqrt(np.mean(a * a))) / np.sqrt(6)
    return max(mad, trimmed, floor)
