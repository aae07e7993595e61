"""Joint signals made ready for identification: one uniform time grid, zero-phase low-pass
filtering, velocity and acceleration by differentiation, decimation.

Velocity is taken from the positions (central differences, then the zero-phase filter) rather
than from a logged velocity: real drives log velocities that lag (TIAGo, ~0.16 s) or spike (DFKI
runs 01, 02), while positions are what the encoder measured. The filter is scipy's Butterworth
``sosfiltfilt`` (zero phase, so no lag between torque and motion); the torque used for fitting
is filtered with the same filter ("consistent filtering"), the held-out prediction is compared
with the torque as logged, at the log's own time stamps (``raw_t_s``, ``raw_tau``): the smooth
prediction is interpolated onto the stamps, never the noisy torque onto the grid (interpolating
between jittered samples averages their noise and flatters the comparison).

The positions' own noise (their quantisation step, or their high-frequency content where larger)
is estimated from the log, and one seeded draw of it is passed through the same differentiation
and filtering chain (``noise``): what the model's inputs q, qd, qdd carry of the encoder's noise,
for the torque noise the model's prediction inherits (the acceleration of a quantised position
is noisy even after the filter).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.signal import butter, sosfiltfilt

from calib.adequacy import noise_floor
from calib.errors import InsufficientDataError

__all__ = ["JointSignals", "prepare_signals", "zero_phase_lowpass"]

Array = NDArray[np.float64]


def zero_phase_lowpass(x: Array, rate_hz: float, cutoff_hz: float, order: int = 4) -> Array:
    """Butterworth low-pass of order ``order`` run forward and backward along axis 0."""
    if cutoff_hz >= 0.45 * rate_hz:
        return np.array(x, dtype=float)
    sos = butter(order, cutoff_hz, btype="low", fs=rate_hz, output="sos")
    padlen = min(len(x) - 1, 3 * (2 * len(sos) + 1) * 4)
    return np.asarray(sosfiltfilt(sos, x, axis=0, padlen=padlen), dtype=float)


@dataclass(frozen=True)
class JointSignals:
    """Joint signals on a uniform grid (``t_s`` from 0, s).

    ``q``/``qd``/``qdd`` are filtered (rad or m, /s, /s^2), ``tau`` is the torque as logged
    (interpolated onto the grid), ``tau_f`` the same filtered. Shapes (N, n). ``raw_t_s`` and
    ``raw_tau`` are the distinct logged samples (stamps on the same time axis as ``t_s``), kept
    whole by :meth:`slice` and :meth:`every`.
    """

    t_s: Array
    q: Array
    qd: Array
    qdd: Array
    tau: Array
    tau_f: Array
    rate_hz: float
    cutoff_hz: float
    raw_t_s: Array | None = None
    raw_tau: Array | None = None
    q_noise: Array | None = None
    noise: tuple[Array, Array, Array] | None = None

    def slice(self, start: int, stop: int) -> JointSignals:
        return JointSignals(
            self.t_s[start:stop],
            self.q[start:stop],
            self.qd[start:stop],
            self.qdd[start:stop],
            self.tau[start:stop],
            self.tau_f[start:stop],
            self.rate_hz,
            self.cutoff_hz,
            self.raw_t_s,
            self.raw_tau,
            self.q_noise,
            None
            if self.noise is None
            else tuple(  # type: ignore[arg-type]
                x[start:stop] for x in self.noise
            ),
        )

    def every(self, step: int) -> JointSignals:
        """Every ``step``-th sample (after filtering, so no aliasing below the cut-off)."""
        return JointSignals(
            self.t_s[::step],
            self.q[::step],
            self.qd[::step],
            self.qdd[::step],
            self.tau[::step],
            self.tau_f[::step],
            self.rate_hz / step,
            self.cutoff_hz,
            self.raw_t_s,
            self.raw_tau,
            self.q_noise,
            None
            if self.noise is None
            else tuple(  # type: ignore[arg-type]
                x[::step] for x in self.noise
            ),
        )

    def __len__(self) -> int:
        return len(self.t_s)


def prepare_signals(
    t_s: Array,
    q: Array,
    tau: Array,
    *,
    cutoff_hz: float = 10.0,
    rate_hz: float | None = None,
    max_rate_hz: float = 250.0,
    qd: Array | None = None,
) -> JointSignals:
    """Resample onto a uniform grid, differentiate, filter and decimate.

    Args:
        t_s: sample times (s), increasing; repeated stamps keep their first sample.
        q: (N, n) positions (rad or m). tau: (N, n) torques (N*m or N).
        cutoff_hz: zero-phase low-pass cut-off for q, qd, qdd and the fitting torque.
        rate_hz: grid rate; None: the median rate of ``t_s``.
        max_rate_hz: decimate (after filtering) to at most this rate.
        qd: a velocity to use instead of differentiating ``q`` (simulation studies).

    Raises:
        InsufficientDataError: fewer than 50 distinct samples.
    """
    t = np.asarray(t_s, dtype=float)
    keep = np.concatenate([[True], np.diff(t) > 0])
    t, q, tau = t[keep], np.asarray(q, float)[keep], np.asarray(tau, float)[keep]
    if qd is not None:
        qd = np.asarray(qd, float)[keep]
    if len(t) < 50:
        raise InsufficientDataError(f"{len(t)} distinct joint samples; need at least 50")
    dt = float(np.median(np.diff(t))) if rate_hz is None else 1.0 / rate_hz
    grid = np.arange(t[0], t[-1] + 0.5 * dt, dt)
    grid = grid[grid <= t[-1]]

    def on_grid(x: Array) -> Array:
        return np.stack([np.interp(grid, t, x[:, j]) for j in range(x.shape[1])], axis=1)

    rate = 1.0 / dt
    qg, taug = on_grid(q), on_grid(tau)
    qf = zero_phase_lowpass(qg, rate, cutoff_hz)
    if qd is None:
        qdf = zero_phase_lowpass(np.gradient(qg, dt, axis=0), rate, cutoff_hz)
    else:
        qdf = zero_phase_lowpass(on_grid(qd), rate, cutoff_hz)
    qddf = zero_phase_lowpass(np.gradient(qdf, dt, axis=0), rate, cutoff_hz)
    tauf = zero_phase_lowpass(taug, rate, cutoff_hz)
    q_noise = position_noise(grid, qg, qf, q)
    draw = np.random.default_rng(0).normal(0.0, 1.0, qg.shape) * q_noise[None, :]
    nq = zero_phase_lowpass(draw, rate, cutoff_hz)
    nqd = zero_phase_lowpass(np.gradient(draw, dt, axis=0), rate, cutoff_hz)
    nqdd = zero_phase_lowpass(np.gradient(nqd, dt, axis=0), rate, cutoff_hz)
    edge = min(int(np.ceil(rate / cutoff_hz)), len(grid) // 10)  # filter start-up at both ends
    cut = slice(edge, len(grid) - edge)
    t0 = grid[edge]
    out = JointSignals(
        grid[cut] - t0,
        qf[cut],
        qdf[cut],
        qddf[cut],
        taug[cut],
        tauf[cut],
        rate,
        cutoff_hz,
        t - t0,
        tau,
        q_noise,
        (nq[cut], nqd[cut], nqdd[cut]),
    )
    step = max(1, int(np.floor(rate / max_rate_hz)))
    return out.every(step) if step > 1 else out


def position_noise(grid: Array, qg: Array, qf: Array, q_raw: Array) -> Array:
    """Per joint, the std of the positions' noise (rad or m): the high-frequency content of what
    the low-pass removes from the positions on the grid, never below the recorded positions'
    quantisation step / sqrt(12)."""
    out = []
    for j in range(qg.shape[1]):
        nf = noise_floor(grid, qg[:, j] - qf[:, j], measured=q_raw[:, j], timescale_s=0.0)
        out.append(nf.std)
    return np.asarray(out, dtype=float)
