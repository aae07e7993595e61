"""The path of link 1 as cumulative arc length and heading, from whatever the log measured.

The transient joint-angle model needs only the increments of arc length ``s`` and heading
``theta`` of link 1 between joint-angle samples (calib.tractor_trailer.models.hitch_path). They
come, best
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

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike

from calib.errors import InsufficientDataError
from calib.smoothing import savgol_filter

__all__ = ["DrivePath", "default_gap_s", "pool_runs", "pose_smoothing", "smoothing_gain"]


def default_gap_s(t_s: np.ndarray) -> float:
    """Sample spacing (s) above which a stream counts as interrupted: 5 median periods, at
    least 0.2 s."""
    if t_s.size < 2:
        return 0.5
    return max(0.2, 5.0 * float(np.median(np.diff(t_s))))


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


def smoothing_gain(n: int) -> float:
    """Factor on white-noise std left by a quadratic Savitzky-Golay filter of ``n`` points
    (its centre weight, sqrt(3 (3 n^2 - 7) / (4 n (n^2 - 4)))); 1 for n < 5."""
    if n < 5:
        return 1.0
    return float(np.sqrt(3.0 * (3 * n * n - 7) / (4.0 * n * (n * n - 4))))


def _runs(t: np.ndarray, gap_s: float) -> list[slice]:
    cut = np.nonzero(np.diff(t) > gap_s)[0] + 1
    edges = np.r_[0, cut, t.size]
    return [slice(int(a), int(b)) for a, b in itertools.pairwise(edges)]


def _smooth(t: np.ndarray, cols: list[np.ndarray], n: int, gap_s: float) -> list[np.ndarray]:
    """Quadratic Savitzky-Golay smoothing of each column over ``n`` samples, run by run."""
    if n < 5:
        return cols
    out = [c.copy() for c in cols]
    for sl in _runs(t, gap_s):
        m = sl.stop - sl.start
        w = min(n, m if m % 2 else m - 1)
        if w < 5:
            continue
        for o, c in zip(out, cols, strict=True):
            o[sl] = savgol_filter(c[sl], w, 2)
    return out


def _cumtrapz(t: np.ndarray, rate: np.ndarray, gap_s: float, hold: bool = False) -> np.ndarray:
    """Trapezoidal integral of ``rate`` (``hold``: held from each sample to the next, as a
    command is); nothing is integrated across a gap (> gap_s)."""
    dt = np.diff(t)
    inc = (rate[:-1] if hold else 0.5 * (rate[1:] + rate[:-1])) * dt
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
        coarser: rebuilds the path from every other raw sample (for the resolution check).
        perturbed: rebuilds it with a fresh draw of the rates' white noise added (odometry).
        smoothing_samples: a pose was smoothed over this many samples first (1: not).
        theta_noise_rad, s_noise_m: white noise left on the heading and the arc length at the
            knots (a pose's; 0 for integrated rates, whose noise does not act directly).
    """

    t_s: np.ndarray
    s_m: np.ndarray
    theta_rad: np.ndarray
    source: str
    gap_s: float
    coarser: Callable[[], DrivePath] | None = field(default=None, repr=False, compare=False)
    smoothing_samples: int = 1
    theta_noise_rad: float = 0.0
    s_noise_m: float = 0.0
    perturbed: Callable[[np.random.Generator], DrivePath] | None = field(
        default=None, repr=False, compare=False
    )

    @classmethod
    def from_pose(
        cls,
        t_s: ArrayLike,
        x_m: ArrayLike,
        y_m: ArrayLike,
        yaw_rad: ArrayLike,
        gap_s: float | None = None,
        *,
        smooth_samples: int = 1,
    ) -> DrivePath:
        """From a pose of link 1 (any point of link 1: lateral motion is projected away).

        The displacement between two poses is a chord; on an arc of heading change d theta
        the arc length is chord (d theta / 2) / sin(d theta / 2), used here. Noise on the pose
        enters the joint-angle model directly (a noisy heading is an error in the input, which
        biases a least-squares fit); ``smooth_samples`` >= 5 smooths x, y and yaw with a
        quadratic Savitzky-Golay filter first.
        """
        from calib.stats import hf_noise_std_t

        t, x, y, yaw = _clean(t_s, x_m, y_m, yaw_rad)
        gap = default_gap_s(t) if gap_s is None else gap_s
        gain = smoothing_gain(smooth_samples)
        s_th = hf_noise_std_t(t, np.unwrap(yaw)) * gain
        s_xy = max(hf_noise_std_t(t, x), hf_noise_std_t(t, y)) * gain
        x, y, th = _smooth(t, [x, y, np.unwrap(yaw)], smooth_samples, gap)
        mid = 0.5 * (th[1:] + th[:-1])
        dth = np.diff(th)
        chord = np.diff(x) * np.cos(mid) + np.diff(y) * np.sin(mid)
        half = 0.5 * dth
        safe = np.abs(half) > 1e-8
        ds = chord * np.where(safe, half / np.where(safe, np.sin(half), 1.0), 1.0)
        across = np.diff(t) > gap
        ds[across] = 0.0
        th = np.concatenate([[th[0]], th[0] + np.cumsum(np.where(across, 0.0, dth))])

        def coarser() -> DrivePath:
            return replace(
                cls.from_pose(t[::2], x[::2], y[::2], th[::2], gap_s=2 * gap),
                theta_noise_rad=s_th,
                s_noise_m=s_xy,
            )

        return cls(
            t,
            np.concatenate([[0.0], np.cumsum(ds)]),
            th,
            "pose",
            gap,
            coarser,
            smooth_samples,
            s_th,
            s_xy,
        )

    @classmethod
    def from_rates(
        cls,
        t_s: ArrayLike,
        v_mps: ArrayLike,
        omega_radps: ArrayLike,
        *,
        source: str = "odometry",
        gap_s: float | None = None,
    ) -> DrivePath:
        """From speed (m/s) and yaw rate (rad/s) of link 1: odometry (trapezoidal), or
        v kappa_cmd for ``source="command"`` (held from sample to sample, as commands are)."""
        from calib.stats import hf_noise_std_t

        t, v, w = _clean(t_s, v_mps, omega_radps)
        gap = default_gap_s(t) if gap_s is None else gap_s
        hold = False  # a command sampled from a smooth signal: trapezoidal too

        def coarser() -> DrivePath:
            return cls.from_rates(t[::2], v[::2], w[::2], source=source, gap_s=2 * gap)

        perturbed = None
        sv, sw = hf_noise_std_t(t, v), hf_noise_std_t(t, w)
        if sv > 0 or sw > 0:

            def perturbed(rng: np.random.Generator) -> DrivePath:
                return cls.from_rates(
                    t,
                    v + sv * rng.standard_normal(t.size),
                    w + sw * rng.standard_normal(t.size),
                    source=source,
                    gap_s=gap,
                )

        return cls(
            t,
            _cumtrapz(t, v, gap, hold),
            _cumtrapz(t, w, gap, hold),
            source,
            gap,
            coarser,
            perturbed=perturbed,
        )

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
        """How far the path reaches along itself (m): the range of the cumulative arc length
        (robust to pose noise, which a sum of |ds| would add up)."""
        return float(np.ptp(self.s_m)) if self.s_m.size else 0.0


def pool_runs(
    runs: list[tuple[DrivePath, np.ndarray, np.ndarray, list[tuple[float, float]]]],
    offsets: list[float] | None = None,
) -> tuple[DrivePath, np.ndarray, np.ndarray, list[tuple[float, float]], list[float]]:
    """Several runs of one robot laid end to end on one clock, separated by gaps, so that one
    fit sees them all (each run starts its own pieces; nothing is integrated between runs).

    Args:
        runs: per run (path, joint-angle times (s), joint angles (rad), gaps (s)).

        offsets: each run's time offset (s) to use (default: end to end with a spacer).

    Returns:
        (path, t_psi, psi, gaps, offsets): the pooled inputs and each run's time offset (s).
    """
    if not runs:
        raise InsufficientDataError("pool_runs: no runs")
    spacer = 2.0 * max(p.gap_s for p, *_ in runs) + 1.0
    offsets_in = offsets
    t_k, s_k, th_k, t_p, p_p, gaps, offsets = [], [], [], [], [], [], []
    end_t = end_s = end_th = 0.0
    for i, (path, t_psi, psi, run_gaps) in enumerate(runs):
        t_psi = np.asarray(t_psi, dtype=float)
        start = min(float(path.t_s[0]), float(np.min(t_psi)) if t_psi.size else path.t_s[0])
        off = offsets_in[i] if offsets_in is not None else (end_t + spacer - start) if i else -start
        offsets.append(off)
        t_k.append(path.t_s + off)
        s_k.append(path.s_m - path.s_m[0] + end_s)
        th_k.append(path.theta_rad - path.theta_rad[0] + end_th)
        t_p.append(t_psi + off)
        p_p.append(np.asarray(psi, dtype=float))
        gaps += [(a + off, b + off) for a, b in run_gaps]
        if i:
            gaps.append((end_t, float(min(t_k[-1][0], t_p[-1].min(initial=t_k[-1][0])))))
        end_t = max(float(t_k[-1][-1]), float(t_p[-1].max()) if t_p[-1].size else end_t)
        end_s, end_th = float(s_k[-1][-1]), float(th_k[-1][-1])
    sources = sorted({p.source for p, *_ in runs})
    coarser = None
    if all(p.coarser is not None for p, *_ in runs):

        def coarser() -> DrivePath:
            coarse = [(p.coarser(), t, q, g) for p, t, q, g in runs]  # type: ignore[misc]
            return pool_runs(coarse, offsets)[0]

    pooled = DrivePath(
        np.concatenate(t_k),
        np.concatenate(s_k),
        np.concatenate(th_k),
        "+".join(sources),
        max(p.gap_s for p, *_ in runs),
        coarser,
        max(p.smoothing_samples for p, *_ in runs),
        max(p.theta_noise_rad for p, *_ in runs),
        max(p.s_noise_m for p, *_ in runs),
    )
    return pooled, np.concatenate(t_p), np.concatenate(p_p), gaps, offsets


def pose_smoothing(
    t_s: np.ndarray,
    x_m: np.ndarray,
    y_m: np.ndarray,
    yaw_rad: np.ndarray,
    psi_rad: np.ndarray,
    *,
    max_window_s: float = 0.25,
    share: float = 0.3,
) -> int | None:
    """Savitzky-Golay length (samples) that makes a pose quiet enough to drive the joint-angle
    model, or None when no window up to ``max_window_s`` does.

    A pose's noise enters the modelled joint angle directly (about 2 sigma_yaw plus
    0.5 sigma_xy per m), and noise in an input biases a least-squares fit; it must stay below
    ``share`` of the joint angle's own noise (white noise from second differences, at least
    the encoder's quantisation step / sqrt(12)). 1: no smoothing needed.
    """
    from calib.stats import detect_quantum, hf_noise_std, hf_noise_std_t

    ok = np.isfinite(t_s) & np.isfinite(x_m) & np.isfinite(y_m) & np.isfinite(yaw_rad)
    if ok.sum() < 5:
        return None
    t = t_s[ok]
    sy = hf_noise_std_t(t, np.unwrap(yaw_rad[ok]))
    sxy = max(hf_noise_std_t(t, x_m[ok]), hf_noise_std_t(t, y_m[ok]))
    direct = math.hypot(2.0 * sy, 0.5 * sxy)
    p = psi_rad[np.isfinite(psi_rad)]
    target = share * max(hf_noise_std(p), detect_quantum(p) / math.sqrt(12.0), 1e-4)
    if direct <= target:
        return 1
    rate = 1.0 / float(np.median(np.diff(t_s[ok])))
    n_max = int(max_window_s * rate)
    for n in range(5, n_max + 1, 2):
        if direct * smoothing_gain(n) <= target:
            return n
    return None
