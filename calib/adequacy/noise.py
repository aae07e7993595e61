"""The noise floor a residual is judged against, estimated from the data themselves.

A model explains a recording when what it leaves is what the sensors add. That floor is not an
assumed constant: it is read off the residual's own high-frequency content (the part no smooth
model error reaches), at every scale up to a correlation time the robot's sensors may have
(a motion-capture filter, an encoder's averaging window), and never below the quantisation of
the recorded signal (an encoder tick q leaves q / sqrt(12) that differences under-read when the
signal moves slowly). Noise that the model's own inputs carry into the residual, which only the
estimator knows (a noisy path integrated into the predicted joint angle), is added in
quadrature by the caller.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.results import JsonRecord
from calib.stats import detect_quantum, hf_noise_std_t

__all__ = ["NoiseFloor", "noise_floor"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class NoiseFloor(JsonRecord):
    """The noise standard deviation a residual is compared with, and where it came from.

    ``std``: the floor (the channel's unit); ``white_std``: from the residual's local second
    differences at the finest scale; ``scale_std``: the largest such estimate over coarser
    scales up to ``timescale_s``; ``quantum``: the recorded signal's quantisation step (0:
    none found); ``input_std``: what the caller adds for noise carried in by the model's inputs;
    ``source``: which of these sets the floor, in words.
    """

    std: float
    white_std: float
    scale_std: float
    quantum: float
    input_std: float
    timescale_s: float
    source: str


def _decimated_hf(t: FloatArray, r: FloatArray, step: int) -> float:
    """Median over the ``step`` phases of the local-line noise estimate of every step-th
    sample (for white noise: the same sigma at every step)."""
    vals = [hf_noise_std_t(t[k::step], r[k::step]) for k in range(step) if r[k::step].size >= 8]
    return float(np.median(vals)) if vals else 0.0


def noise_floor(
    t_s: FloatArray,
    residual: FloatArray,
    *,
    measured: FloatArray | None = None,
    quantum: float = 0.0,
    timescale_s: float = 0.05,
    input_std: float = 0.0,
) -> NoiseFloor:
    """The noise floor of ``residual`` (sampled at ``t_s``, seconds).

    Args:
        t_s: sample times (s), increasing.
        residual: measured minus model, same length (NaN samples are left out).
        measured: the recorded signal itself, for its quantisation step (when ``quantum`` is
            not given).
        quantum: the sensor's resolution when known.
        timescale_s: the longest correlation time counted as sensor noise rather than model
            error: the high-frequency estimate is taken at sample spacings up to it and the
            largest is kept (coloured sensor noise reads higher at coarser spacing; a smooth
            model error does not reach these scales).
        input_std: noise the model's inputs carry into the residual (added in quadrature).
    """
    t = np.asarray(t_s, dtype=float)
    r = np.asarray(residual, dtype=float)
    ok = np.isfinite(t) & np.isfinite(r)
    t, r = t[ok], r[ok]
    white = hf_noise_std_t(t, r) if r.size >= 8 else 0.0
    scale = white
    if r.size >= 16:
        dt = float(np.median(np.diff(t)))
        top = max(1, min(round(timescale_s / dt) if dt > 0 else 1, r.size // 16))
        step = 2
        while step <= top:
            scale = max(scale, _decimated_hf(t, r, step))
            step *= 2
    q = quantum
    if q <= 0 and measured is not None:
        m = np.asarray(measured, dtype=float)
        q = detect_quantum(m[np.isfinite(m)])
    q_std = q / math.sqrt(12.0)
    sensor = max(scale, q_std)
    std = math.sqrt(sensor**2 + input_std**2)
    if q_std > scale:
        source = f"quantisation (step {q:.3g})"
    elif scale > white * 1.05:
        source = f"high-frequency content up to {timescale_s:g} s"
    else:
        source = "high-frequency content"
    if input_std > sensor:
        source += " + noise carried in by the model's inputs"
    return NoiseFloor(
        float(std),
        float(white),
        float(scale),
        float(q),
        float(input_std),
        float(timescale_s),
        source,
    )
