"""The path of link 1 as cumulative arc length and heading, from whatever the log measured.

The transient joint-angle model needs only the increments of arc length ``s`` and heading
``theta`` of link 1 between joint-angle samples (calib.models.hitch_path). They come, best
first, from:

- a pose of link 1 (motion capture, GPS + heading): theta is the unwrapped yaw, ds the
  displacement projected on the heading (so it is signed: negative when reversing). Noise on a
  pose does not accumulate in these sums;
- odometry (speed and yaw rate): s and theta are their trapezoidal integrals;
- the command (speed and commanded curvature): theta is the integral of v kappa_cmd. Actuator
  delay, lag or understeer then enter the model; from a measured path they do not.

Cumulative values are interpolated linearly to any time, which is what integrating a rate that
is constant between samples gives: the same at 5 Hz or 200 Hz, and for asynchronous sensors.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calib.errors import InsufficientDataError

__all__ = ["DrivePath", "default_gap_s", "pool_runs"]


def default_gap_s(t_s: np.ndarray) -> float:
    """Sample spacing (s) above which a stream counts as interrupted: 5 median periods, at
    least 0.5 s."""
    if t_s.size < 2:
        return 0.5
    return max(0.5, 5.0 * float(np.median(np.diff(t_s))))


def _clean(t: ArrayLike, *cols: ArrayLike) -> tuple[np.ndarray, ...]:
    arrs = [np.asarray(a, dtype=float).ravel() for a in (t, *cols)]
    if len({a.size for a in arrs}) != 1:
        raise InsufficientDataError(
            f"DrivePath: time and values must have equal lengths, got {[a.size for a in arrs]}"
        )
    ok = np.all([np.isfinite(a) for a in arrs], axis=0)
    arrs = [a[ok] for a in arrs]
    order = np.argsort(arrs[0], kind="stable")
    arrs = [a[order] for a in arrs]
    keep = np.concatenate([[True], np.diff(arrs[0]) > 0])
    arrs = [a[keep] for a in arrs]
    if arrs[0].size < 2:
        raise InsufficientDataError(f"DrivePath: {arrs[0].size} usable samples; need 2")
    return tuple(arrs)


def _cumtrapz(t: np.ndarray, rate: np.ndarray, gap_s: float) -> np.ndarray:
    """Trapezoidal integral of ``rate``; nothing is integrated across a gap (> gap_s)."""
    dt = np.diff(t)
    inc = 0.5 * (rate[1:] + rate[:-1]) * dt
    inc[dt > gap_s] = 0.0
    return np.concatenate([[0.0], np.cumsum(inc)])


@dataclass(frozen=True)
class DrivePath:
    """Cumulative arc length and heading of link 1 at the knot times.

    Attributes:
        t_s: knot times (s), strictly increasing.
        s_m: cumulative signed arc length (m) at the knots.
        theta_rad: cumulative (unwrapped) heading of link 1 (rad) at the knots.
        source: where it came from ("pose", "odometry" or "command").
        gap_s: knot spacing (s) above which the path is unknown in between.
    """

    t_s: np.ndarray
    s_m: np.ndarray
    theta_rad: np.ndarray
    source: str
    gap_s: float

    @classmethod
    def from_pose(
        cls, t_s: ArrayLike, x_m: ArrayLike, y_m: ArrayLike, yaw_rad: ArrayLike,
        gap_s: float | None = None,
    ) -> DrivePath:
        """From a pose of link 1 (any point of link 1: lateral motion is projected away)."""
        t, x, y, yaw = _clean(t_s, x_m, y_m, yaw_rad)
        gap = default_gap_s(t) if gap_s is None else gap_s
        th = np.unwrap(yaw)
        mid = 0.5 * (th[1:] + th[:-1])
        ds = np.diff(x) * np.cos(mid) + np.diff(y) * np.sin(mid)
        dth = np.diff(th)
        across = np.diff(t) > gap
        ds[across] = 0.0
        th = np.concatenate([[th[0]], th[0] + np.cumsum(np.where(across, 0.0, dth))])
        return cls(t, np.concatenate([[0.0], np.cumsum(ds)]), th, "pose", gap)

    @classmethod
    def from_rates(
        cls, t_s: ArrayLike, v_mps: ArrayLike, omega_radps: ArrayLike, *,
        source: str = "odometry", gap_s: float | None = None,
    ) -> DrivePath:
        """From speed (m/s) and yaw rate (rad/s) of link 1: odometry, or v kappa_cmd for
        ``source="command"``."""
        t, v, w = _clean(t_s, v_mps, omega_radps)
        gap = default_gap_s(t) if gap_s is None else gap_s
        return cls(t, _cumtrapz(t, v, gap), _cumtrapz(t, w, gap), source, gap)

    def at(self, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Cumulative (s, theta) at ``t_s`` (linear between knots; held beyond the ends)."""
        return np.interp(t_s, self.t_s, self.s_m), np.interp(t_s, self.t_s, self.theta_rad)

    def covered(self, t_s: np.ndarray) -> np.ndarray:
        """Which times fall inside the knot span and not inside a gap between knots."""
        i = np.searchsorted(self.t_s, t_s, side="right")
        inside = (i > 0) & (i < self.t_s.size) | (t_s == self.t_s[-1])
        ic = np.clip(i, 1, self.t_s.size - 1)
        span = self.t_s[ic] - self.t_s[ic - 1]
        return inside & (span <= self.gap_s)

    @property
    def distance_m(self) -> float:
        """Total distance travelled (m), forward and back."""
        return float(np.sum(np.abs(np.diff(self.s_m))))


def pool_runs(
    runs: list[tuple[DrivePath, np.ndarray, np.ndarray, list[tuple[float, float]]]],
) -> tuple[DrivePath, np.ndarray, np.ndarray, list[tuple[float, float]], list[float]]:
    """Several runs of one robot laid end to end on one clock, separated by gaps, so that one
    fit sees them all (each run starts its own pieces; nothing is integrated between runs).

    Args:
        runs: per run (path, joint-angle times (s), joint angles (rad), gaps (s)).

    Returns:
        (path, t_psi, psi, gaps, offsets): the pooled inputs and each run's time offset (s).
    """
    if not runs:
        raise InsufficientDataError("pool_runs: no runs")
    spacer = 2.0 * max(p.gap_s for p, *_ in runs) + 1.0
    t_k, s_k, th_k, t_p, p_p, gaps, offsets = [], [], [], [], [], [], []
    end_t = end_s = end_th = 0.0
    for i, (path, t_psi, psi, run_gaps) in enumerate(runs):
        t_psi = np.asarray(t_psi, dtype=float)
        start = min(float(path.t_s[0]), float(np.min(t_psi)) if t_psi.size else path.t_s[0])
        off = (end_t + spacer - start) if i else -start
        offsets.append(off)
        t_k.append(path.t_s + off)
        s_k.append(path.s_m - path.s_m[0] + end_s)
        th_k.append(path.theta_rad - path.theta_rad[0] + end_th)
        t_p.append(t_psi + off)
        p_p.append(np.asarray(psi, dtype=float))
        gaps += [(a + off, b + off) for a, b in run_gaps]
        if i:
            gaps.append((end_t, float(t_k[-1][0])))
        end_t = max(float(t_k[-1][-1]), float(t_p[-1].max()) if t_p[-1].size else end_t)
        end_s, end_th = float(s_k[-1][-1]), float(th_k[-1][-1])
    sources = sorted({p.source for p, *_ in runs})
    pooled = DrivePath(
        np.concatenate(t_k), np.concatenate(s_k), np.concatenate(th_k), "+".join(sources),
        max(p.gap_s for p, *_ in runs),
    )
    return pooled, np.concatenate(t_p), np.concatenate(p_p), gaps, offsets
