"""Input profiles of the independent generator: commanded curvature (or steering angle) and speed.

Both are plain functions of the true time ``t`` (s since the start of the run) with a scalar
path (used inside the ODE right-hand side) and a vectorised path (used at the sample instants),
plus the list of instants where they are not smooth, so the integrator can restart there.
Times before 0 hold the value at 0 (this is what a delayed actuator sees at the start).
"""

from __future__ import annotations

import math
from bisect import bisect_left, bisect_right
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

__all__ = ["Command", "CommandKind", "FloatArray", "Speed"]

FloatArray = NDArray[np.float64]
CommandKind = Literal["H", "C", "L", "constant", "random", "chirp", "steps"]


@dataclass(frozen=True)
class Command:
    """A command profile u(t) (curvature in 1/m, or steering angle in rad for a steered robot).

    Kinds (M = ``M``):
        ``H``: M sin(0.1 t); ``C``: M tanh(0.1 t); ``L``: M (0.1 t / pi - 1) (the patent's three);
        ``constant``: M;
        ``random``: M * sum_i w_i sin(2 pi f_i t + phi_i) with sum |w_i| = 1 (so |u| <= M);
        ``chirp``: M sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T))), T = ``chirp_s``;
        ``steps``: ``step_levels[0]`` until ``step_times[0]``, then towards ``step_levels[i+1]``
        from ``step_times[i]`` at most at ``rate`` (units of u per second; ``inf``: a jump).
    """

    kind: CommandKind = "H"
    M: float = 0.2
    freqs_hz: tuple[float, ...] = ()
    phases: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()
    f0_hz: float = 0.01
    f1_hz: float = 0.2
    chirp_s: float = 60.0
    step_times: tuple[float, ...] = ()
    step_levels: tuple[float, ...] = (0.0,)
    rate: float = math.inf

    def __call__(self, t: float, left: bool = False) -> float:
        """u(t); ``left``: the left limit at a jump (the value just before it)."""
        t = max(t, 0.0)
        k, M = self.kind, self.M
        if k == "H":
            return M * math.sin(0.1 * t)
        if k == "C":
            return M * math.tanh(0.1 * t)
        if k == "L":
            return M * (0.1 * t / math.pi - 1.0)
        if k == "constant":
            return M
        if k == "random":
            s = 0.0
            for f, p, w in zip(self.freqs_hz, self.phases, self.weights, strict=True):
                s += w * math.sin(2.0 * math.pi * f * t + p)
            return M * s
        if k == "chirp":
            return M * math.sin(self._chirp_phase(t))
        i = (bisect_left if left else bisect_right)(self.step_times, t)
        return self._step_value(i, t)

    def values(self, t: FloatArray) -> FloatArray:
        """u at an array of times (right-continuous at jumps)."""
        t = np.maximum(np.asarray(t, dtype=float), 0.0)
        k, M = self.kind, self.M
        if k == "H":
            return M * np.sin(0.1 * t)
        if k == "C":
            return M * np.tanh(0.1 * t)
        if k == "L":
            return M * (0.1 * t / np.pi - 1.0)
        if k == "constant":
            return np.full_like(t, M)
        if k == "random":
            s = np.zeros_like(t)
            for f, p, w in zip(self.freqs_hz, self.phases, self.weights, strict=True):
                s += w * np.sin(2.0 * np.pi * f * t + p)
            return M * s
        if k == "chirp":
            return M * np.sin(self._chirp_phase(t))
        idx = np.searchsorted(np.asarray(self.step_times, dtype=float), t, side="right")
        return np.array([self._step_value(int(i), float(x)) for i, x in zip(idx, t, strict=True)])

    def _chirp_phase(self, t: FloatArray | float) -> FloatArray | float:
        return (
            2.0 * np.pi * (self.f0_hz * t + (self.f1_hz - self.f0_hz) * t * t / (2 * self.chirp_s))
        )

    def _step_value(self, i: int, t: float) -> float:
        lv = self.step_levels
        if i == 0:
            return lv[0]
        new, prev = lv[i], lv[i - 1]
        if math.isinf(self.rate):
            return new
        dt = t - self.step_times[i - 1]
        if dt >= abs(new - prev) / self.rate:
            return new
        return prev + math.copysign(self.rate * dt, new - prev)

    def breaks(self) -> tuple[float, ...]:
        """Instants where u or its derivative jumps."""
        if self.kind != "steps":
            return ()
        out = list(self.step_times)
        if not math.isinf(self.rate):
            lv = self.step_levels
            out += [s + abs(lv[i + 1] - lv[i]) / self.rate for i, s in enumerate(self.step_times)]
        return tuple(sorted(out))

    def max_abs(self) -> float:
        """An upper bound of |u| (for bounding the hitch angle)."""
        if self.kind == "steps":
            return max(abs(x) for x in self.step_levels)
        return abs(self.M)


@dataclass(frozen=True)
class Speed:
    """Speed of the reference point C1 (m/s): v(t) = smooth(t) * envelope(t).

    smooth: ``base`` (kind ``constant``), or ``lo + (hi - lo) (1 + sum_i w_i sin(2 pi f_i t +
    phi_i)) / 2`` with sum |w_i| = 1 (kind ``random``, so lo <= smooth <= hi).
    envelope: piecewise linear through (``knots_t``, ``knots_f``), held outside; 1 without knots.
    Ramps, stops (envelope 0) and a short reverse (envelope < 0) are envelope knots.
    """

    kind: Literal["constant", "random"] = "constant"
    base: float = 1.0
    lo: float = 0.2
    hi: float = 8.0
    freqs_hz: tuple[float, ...] = ()
    phases: tuple[float, ...] = ()
    weights: tuple[float, ...] = ()
    knots_t: tuple[float, ...] = ()
    knots_f: tuple[float, ...] = ()

    def __call__(self, t: float) -> float:
        if self.kind == "constant":
            s = self.base
        else:
            acc = 0.0
            for f, p, w in zip(self.freqs_hz, self.phases, self.weights, strict=True):
                acc += w * math.sin(2.0 * math.pi * f * t + p)
            s = self.lo + (self.hi - self.lo) * 0.5 * (1.0 + acc)
        kt = self.knots_t
        if not kt:
            return s
        kf = self.knots_f
        if t <= kt[0]:
            return s * kf[0]
        if t >= kt[-1]:
            return s * kf[-1]
        i = bisect_right(kt, t)
        a, b = kt[i - 1], kt[i]
        return s * (kf[i - 1] + (kf[i] - kf[i - 1]) * (t - a) / (b - a))

    def values(self, t: FloatArray) -> FloatArray:
        t = np.asarray(t, dtype=float)
        if self.kind == "constant":
            s = np.full_like(t, self.base)
        else:
            acc = np.zeros_like(t)
            for f, p, w in zip(self.freqs_hz, self.phases, self.weights, strict=True):
                acc += w * np.sin(2.0 * np.pi * f * t + p)
            s = self.lo + (self.hi - self.lo) * 0.5 * (1.0 + acc)
        if not self.knots_t:
            return s
        return s * np.interp(t, self.knots_t, self.knots_f)

    def breaks(self) -> tuple[float, ...]:
        """Kinks of the envelope."""
        return tuple(self.knots_t)

    @staticmethod
    def envelope(
        duration_s: float,
        ramp_s: float = 0.0,
        ramp_down: bool = False,
        stops: tuple[tuple[float, float], ...] = (),
        reverse: tuple[float, float, float] | None = None,
        transition_s: float = 1.0,
    ) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Envelope knots: a start ramp, stops ``(start, length)`` (envelope 0 for ``length`` s,
        reached and left over ``transition_s``), a ``reverse`` ``(start, length, fraction)``
        (envelope -fraction) and an optional ramp down to 0 at the end."""
        pts: list[tuple[float, float]] = [(0.0, 0.0 if ramp_s > 0 else 1.0)]
        if ramp_s > 0:
            pts.append((ramp_s, 1.0))
        events = [(s, ln, 0.0) for s, ln in stops]
        if reverse is not None:
            events.append((reverse[0], reverse[1], -reverse[2]))
        for s, ln, level in sorted(events):
            tr = transition_s
            if s - tr <= pts[-1][0]:
                continue  # overlapping events are skipped
            pts += [(s - tr, 1.0), (s, level), (s + ln, level), (s + ln + tr, 1.0)]
        if ramp_down and ramp_s > 0 and duration_s - ramp_s > pts[-1][0]:
            pts += [(duration_s - ramp_s, 1.0), (duration_s, 0.0)]
        if len(pts) == 1:
            return (), ()
        return tuple(p[0] for p in pts), tuple(p[1] for p in pts)
