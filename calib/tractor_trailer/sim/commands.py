"""Curvature command profiles (1/m) as functions of segment-local time (s).

The patent's three (t from 0 to 63 s, w = 0.1 rad/s): harmonic M sin(w t), curve M tanh(w t),
linear M (w t / pi - 1); plus constant M and step (0, then M from ``step_at_s``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from calib.tractor_trailer.results import CommandType, Segment
from calib.tractor_trailer.sim.validation import check_finite, check_positive

__all__ = ["CommandSequence", "CommandSpec", "command_value"]


@dataclass(frozen=True)
class CommandSpec:
    """One command segment.

    Args:
        kind: command type.
        duration_s: length of the segment (s).
        amplitude: M (1/m).
        rate: w (rad/s) for harmonic, curve and linear.
        phase: phase (rad) of the harmonic.
        offset: constant added to the profile (1/m).
        step_at_s: for ``step``, segment-local time of the jump (s); default half the duration.
    """

    kind: CommandType
    duration_s: float
    amplitude: float = 0.2
    rate: float = 0.1
    phase: float = 0.0
    offset: float = 0.0
    step_at_s: float | None = None

    def __post_init__(self) -> None:
        CommandType(self.kind)
        check_positive("duration_s", self.duration_s, "s")
        check_finite("amplitude", self.amplitude, "1/m")
        check_finite("rate", self.rate, "rad/s")
        check_finite("phase", self.phase, "rad")
        check_finite("offset", self.offset, "1/m")
        if self.step_at_s is not None:
            check_finite("step_at_s", self.step_at_s, "s")

    def peak_abs(self) -> float:
        """Largest |command| (1/m) over the segment (an upper bound for ``harmonic``).

        Raises:
            ValueError: a command type without a profile (``other``).
        """
        m, off = self.amplitude, self.offset
        kind = CommandType(self.kind)
        if kind is CommandType.HARMONIC:
            return abs(m) + abs(off)
        if kind is CommandType.CONSTANT:
            return abs(m + off)
        # curve, linear and step are monotone: the extremes are at the ends
        ends = command_value(self, np.array([0.0, self.duration_s]))
        return float(np.max(np.abs(ends)))


def command_value(spec: CommandSpec, t_local_s: ArrayLike) -> NDArray[np.float64]:
    """Curvature command (1/m) of ``spec`` at segment-local times (s)."""
    t = np.asarray(t_local_s, dtype=float)
    m, w = spec.amplitude, spec.rate
    kind = CommandType(spec.kind)
    if kind is CommandType.HARMONIC:
        out = m * np.sin(w * t + spec.phase)
    elif kind is CommandType.CURVE:
        out = m * np.tanh(w * t)
    elif kind is CommandType.LINEAR:
        out = m * (w * t / np.pi - 1.0)
    elif kind is CommandType.CONSTANT:
        out = np.full_like(t, m)
    elif kind is CommandType.STEP:
        at = spec.duration_s / 2 if spec.step_at_s is None else spec.step_at_s
        out = np.where(t >= at, m, 0.0)
    else:
        raise ValueError(f"no profile for command type {kind!r}")
    return out + spec.offset


@dataclass(frozen=True)
class CommandSequence:
    """Command segments played one after another from t = 0."""

    specs: Sequence[CommandSpec]

    @property
    def duration_s(self) -> float:
        return float(sum(s.duration_s for s in self.specs))

    def peak_abs(self) -> float:
        """Largest |command| (1/m) over the sequence (0 when empty): from the segments' closed
        forms (:meth:`CommandSpec.peak_abs`, skipping ``other``), or, for a subclass that
        replaces ``__call__`` (e.g. a table), from the command sampled every 10 ms (at most
        10^6 samples)."""
        if not self.specs:
            return 0.0
        if type(self).__call__ is not CommandSequence.__call__:
            step = max(0.01, self.duration_s / 1e6)
            t = np.arange(0.0, self.duration_s + step, step)
            return float(np.max(np.abs(self(t))))
        peaks = [s.peak_abs() for s in self.specs if CommandType(s.kind) is not CommandType.OTHER]
        return max(peaks, default=0.0)

    def boundaries_s(self) -> NDArray[np.float64]:
        """Start times of each segment and the end time (s), length ``len(specs) + 1``."""
        return np.concatenate([[0.0], np.cumsum([s.duration_s for s in self.specs])])

    def __call__(self, t_s: ArrayLike) -> NDArray[np.float64]:
        """Curvature command (1/m) at times ``t_s`` (s from the start); 0 before and held after."""
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        edges = self.boundaries_s()
        out = np.zeros_like(t)
        idx = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(self.specs) - 1)
        for i, spec in enumerate(self.specs):
            sel = idx == i
            if np.any(sel):
                local = np.minimum(t[sel] - edges[i], spec.duration_s)
                out[sel] = command_value(spec, np.maximum(local, 0.0))
        out[t < 0] = 0.0
        return out

    def segments(self) -> list[Segment]:
        """The true segments (seconds from the start)."""
        edges = self.boundaries_s()
        return [
            Segment(float(edges[i]), float(edges[i + 1]), CommandType(s.kind))
            for i, s in enumerate(self.specs)
        ]
