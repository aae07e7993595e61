"""A robot-independent container of a generated log (topics of samples) plus the helpers every
robot generator shares: sample instants, seeded noise, the effect size of a kind.

A ``RobotLog`` is what the writers (``robot_writers``) turn into a file. Each ``Stream`` is one
topic: absolute int64 stamps (ns, as written; ``start_ns`` is t = 0) and named fields (1-D arrays,
or 2-D (n, k) arrays for ``/joint_states``-style array fields). ``noise_std`` per field is the
std of the recorded error of that field (Gaussian noise and quantisation, added in quadrature);
it is the denominator of the effect size.

Effect size of a kind (``effect_size``): per channel (``topic:field`` or ``topic:field[j]``),
RMS(recorded with the kind - recorded without it, same random draws) / the channel's noise std.
The recording without the kind is evaluated at the stamps of the one with it (linear
interpolation in stamp time), so kinds that move stamps (clock drift) are measured too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "FloatArray",
    "RobotLog",
    "Stream",
    "effect_size",
    "grid",
    "log_uniform",
    "quantise",
    "wrap",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Stream:
    """One topic: ``stamps_ns`` (int64, absolute), ``t_true`` (s since the start: the true sample
    instants), ``fields`` (name -> values), ``noise_std`` (name -> recorded error std),
    ``constants`` (fields written unchanged in every message, e.g. joint names), ``angle``
    (fields that are wrapped angles, compared modulo 2 pi), ``expected`` (name -> the value of
    a field before noise and quantisation, angles unwrapped; never written, used by
    ``refit.refit_effect``)."""

    topic: str
    stamps_ns: NDArray[np.int64]
    t_true: FloatArray
    fields: dict[str, FloatArray]
    noise_std: dict[str, float] = field(default_factory=dict)
    constants: dict[str, Any] = field(default_factory=dict)
    angle: tuple[str, ...] = ()
    expected: dict[str, FloatArray] = field(default_factory=dict)


@dataclass
class RobotLog:
    """A generated log: ``robot`` (``tractor_trailer``, ``diff_drive``, ``arm``), ``streams``
    keyed by topic, ``truth`` (JSON-safe dict), ``metadata`` (MCAP metadata records),
    ``csv_columns`` ((topic, field[, j]) -> CSV column), ``files`` (extra files the log needs,
    e.g. the arm's URDF text, by file name)."""

    robot: str
    streams: dict[str, Stream]
    truth: dict[str, Any]
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    csv_columns: dict[tuple[str, str, int], str] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)
    start_ns: int = 1_760_000_000_000_000_000


def log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    """A draw log-uniform in [lo, hi] (lo, hi > 0)."""
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def grid(rng: np.random.Generator, rate_hz: float, T: float, jitter: float = 0.0) -> FloatArray:
    """True sample instants in [0, T] at ``rate_hz`` from a random phase, with a relative
    sampling jitter (std ``jitter`` periods, clipped to 0.2 periods)."""
    period = 1.0 / rate_hz
    phase = float(rng.uniform(0.0, period))
    t = phase + period * np.arange(math.floor((T - phase) / period) + 1)
    if jitter > 0:
        t = t + np.clip(rng.normal(0.0, jitter * period, t.size), -0.2 * period, 0.2 * period)
    return np.asarray(t[(t >= 0.0) & (t <= T)], dtype=float)


def quantise(x: FloatArray, q: float) -> FloatArray:
    """round(x / q) * q (q <= 0: unchanged)."""
    return np.round(x / q) * q if q > 0 else x


def wrap(a: FloatArray) -> FloatArray:
    """Angles wrapped to [-pi, pi)."""
    return np.asarray((a + np.pi) % (2 * np.pi) - np.pi, dtype=float)


def _columns(values: FloatArray) -> list[tuple[int, FloatArray]]:
    if values.ndim == 1:
        return [(-1, values)]
    return [(j, values[:, j]) for j in range(values.shape[1])]


def effect_size(with_kind: RobotLog, clean: RobotLog) -> dict[str, float]:
    """Per channel: RMS(recorded with the kind - recorded without it) / noise std (see module).

    Channels whose noise std is 0 use 1e-9 (so any change is a huge effect). Channels that are
    not in ``clean`` are skipped.
    """
    out: dict[str, float] = {}
    for topic, s in with_kind.streams.items():
        c = clean.streams.get(topic)
        if c is None or s.stamps_ns.size == 0 or c.stamps_ns.size < 2:
            continue
        ts = (s.stamps_ns - with_kind.start_ns) / 1e9
        tc = (c.stamps_ns - clean.start_ns) / 1e9
        same = s.stamps_ns.size == c.stamps_ns.size and bool(np.all(s.stamps_ns == c.stamps_ns))
        for name, values in s.fields.items():
            if name not in c.fields:
                continue
            sd = max(float(s.noise_std.get(name, 0.0)), 1e-9)
            for (j, a), (_, b) in zip(_columns(values), _columns(c.fields[name]), strict=True):
                ref = b if same else np.interp(ts, tc, np.unwrap(b) if name in s.angle else b)
                d = a - ref
                if name in s.angle:
                    d = wrap(d)
                label = f"{topic}:{name}" if j < 0 else f"{topic}:{name}[{j}]"
                out[label] = float(np.sqrt(np.mean(d * d)) / sd)
    return out
