"""Discovery inputs: the aligned frame as arrays, a decimated fitting grid and noise levels."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import polars as pl
from numpy.typing import NDArray

from calib.discovery.effects.base import jump_intervals
from calib.errors import InsufficientDataError

__all__ = [
    "OUTPUTS",
    "CommandSignal",
    "DiscoveryData",
    "block_mean",
    "prepare_data",
    "robust_noise_std",
]

FloatArray = NDArray[np.float64]

OUTPUTS: tuple[str, ...] = ("omega", "psi")
MIN_FIT_SAMPLES = 150
FIT_RATE_HZ = 10.0
N_TIME_BLOCKS = 8
BURN_IN_M = 10.0


def block_mean(x: FloatArray, m: int) -> FloatArray:
    """Means of consecutive blocks of ``m`` samples (the tail that does not fill one is dropped)."""
    nb = x.size // m
    return x[: nb * m].reshape(nb, m).mean(axis=1)


def robust_noise_std(y: FloatArray) -> float:
    """White-noise standard deviation from second differences (robust to smooth signal)."""
    d2 = np.diff(y, n=2)
    if d2.size < 10:
        return float("nan")
    mad = float(np.median(np.abs(d2 - np.median(d2))))
    return 1.4826 * mad / np.sqrt(6.0)


@dataclass(frozen=True)
class DiscoveryData:
    """Arrays for discovery.

    Full rate (the aligned grid): ``t_ns``, ``t_s`` (s from the first row), ``kappa_cmd``
    (1/m), ``v`` (m/s), ``outputs`` (recorded "omega" rad/s and/or "psi" rad).
    Fitting grid: blocks of ``m`` full-rate samples averaged (about 10 Hz): ``tc_s`` (block
    centres), ``outputs_d``; ``sigma_d`` is each output's white-noise level on that grid and
    ``sigma`` at full rate. ``block`` labels each fitting sample with its time block (0..7);
    even blocks train, odd blocks are held out. ``valid`` drops the first ``BURN_IN_M`` metres
    of travel, where the modelled joint angle still forgets its assumed initial state.
    """

    t_ns: NDArray[np.int64]
    t_s: FloatArray
    kappa_cmd: FloatArray
    v: FloatArray
    outputs: dict[str, FloatArray]
    m: int
    tc_s: FloatArray
    outputs_d: dict[str, FloatArray]
    sigma: dict[str, float]
    sigma_d: dict[str, float]
    block: NDArray[np.int64]
    valid: NDArray[np.bool_]
    th_s: FloatArray
    kappa_h: FloatArray
    v_h: FloatArray
    psi0: float
    command: CommandSignal

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.outputs)

    @property
    def n_fit(self) -> int:
        return int(self.tc_s.size)

    def train_mask(self) -> NDArray[np.bool_]:
        return (self.block % 2 == 0) & self.valid

    def test_mask(self) -> NDArray[np.bool_]:
        return (self.block % 2 == 1) & self.valid


def _column(frame: pl.DataFrame, name: str) -> FloatArray:
    return frame.get_column(name).cast(pl.Float64).to_numpy().astype(float)


def _half_grid(t_s: FloatArray, y: FloatArray) -> FloatArray:
    """Samples interleaved with interval midpoints (linear)."""
    out = np.empty(2 * y.size - 1)
    out[0::2] = y
    out[1::2] = 0.5 * (y[1:] + y[:-1])
    return out


@dataclass(frozen=True)
class CommandSignal:
    """The recorded command as a function of continuous time.

    Linear between samples, except across a jump (``jump_intervals``), where it holds the old
    value until the next sample (zero-order hold). ``at`` averages it over [t, t + eps]
    (eps = 1/50 of the sample period): continuous in a time shift, yet a jump that falls on a
    sample is seen at that sample.
    """

    t_s: FloatArray
    y: FloatArray
    slope: FloatArray
    cum: FloatArray
    eps: float

    @classmethod
    def from_samples(cls, t_s: FloatArray, y: FloatArray) -> CommandSignal:
        dt = np.diff(t_s)
        slope = np.where(jump_intervals(y), 0.0, np.diff(y) / np.where(dt > 0, dt, 1.0))
        cum = np.concatenate([[0.0], np.cumsum(y[:-1] * dt + 0.5 * slope * dt * dt)])
        eps = float(np.median(dt)) / 50.0 if dt.size else 1e-6
        return cls(t_s, y, slope, cum, eps)

    def integral(self, tq: FloatArray) -> FloatArray:
        """Integral from t_s[0] to ``tq`` (held constant outside the samples)."""
        t = self.t_s
        i = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, t.size - 2)
        tau = np.clip(tq, t[0], t[-1]) - t[i]
        inside = self.cum[i] + self.y[i] * tau + 0.5 * self.slope[i] * tau * tau
        before = (tq - t[0]) * self.y[0]
        after = self.cum[-1] + (tq - t[-1]) * self.y[-1]
        return np.where(tq < t[0], before, np.where(tq > t[-1], after, inside))

    def at(self, tq: FloatArray) -> FloatArray:
        """Mean over [tq, tq + eps] (units of y)."""
        return (self.integral(tq + self.eps) - self.integral(tq)) / self.eps


def prepare_data(frame: pl.DataFrame) -> DiscoveryData:
    """Arrays from an aligned frame: ``t_ns``, ``kappa_cmd``, ``v``, ``omega``/``kappa``, ``psi``.

    Rows with a missing value in a used column are dropped. Raises ``InsufficientDataError``
    when a column is missing or the log is too short to fit and hold out (< 15 s at 10 Hz).
    """
    need = ["t_ns", "kappa_cmd", "v"]
    missing = [c for c in need if c not in frame.columns]
    if missing:
        raise InsufficientDataError(
            f"discovery: aligned frame lacks column(s) {missing}; expected t_ns, kappa_cmd, v "
            f"and omega (or kappa) and/or psi, got {frame.columns}"
        )
    df = frame.sort("t_ns")
    if "omega" not in df.columns and "kappa" in df.columns:
        df = df.with_columns((pl.col("kappa") * pl.col("v")).alias("omega"))
    outs = [c for c in OUTPUTS if c in df.columns]
    if not outs:
        raise InsufficientDataError(
            "discovery: aligned frame has neither omega (or kappa) nor psi; nothing to compare "
            f"the model with (columns: {df.columns})"
        )
    cols = need + outs
    df = df.select(cols).drop_nulls()
    df = df.filter(pl.all_horizontal([pl.col(c).cast(pl.Float64).is_finite() for c in cols[1:]]))
    t_ns = df.get_column("t_ns").cast(pl.Int64).to_numpy()
    if t_ns.size < 3:
        raise InsufficientDataError(f"discovery: only {t_ns.size} complete rows in the frame")
    t_s = (t_ns - t_ns[0]) / 1e9
    dt = float(np.median(np.diff(t_s)))
    m = max(1, round(1.0 / (FIT_RATE_HZ * dt))) if dt > 0 else 1
    nb = t_s.size // m
    if nb < MIN_FIT_SAMPLES:
        raise InsufficientDataError(
            f"discovery: {t_s[-1]:.1f} s of complete data gives {nb} fitting samples at "
            f"{FIT_RATE_HZ:g} Hz; need at least {MIN_FIT_SAMPLES}"
        )
    outputs = {c: _column(df, c) for c in outs}
    sigma = {}
    for c, y in outputs.items():
        s = robust_noise_std(y)
        floor = 1e-6 * max(float(np.std(y)), 1e-6)
        sigma[c] = max(s if np.isfinite(s) else 0.0, floor)
    kc, v = _column(df, "kappa_cmd"), _column(df, "v")
    v_d = block_mean(np.abs(v), m)
    dist = np.cumsum(v_d) * m * dt
    valid = dist >= BURN_IN_M
    if int(valid.sum()) < MIN_FIT_SAMPLES:
        raise InsufficientDataError(
            f"discovery: only {dist[-1]:.1f} m of travel; need {BURN_IN_M:g} m to settle plus "
            f"{MIN_FIT_SAMPLES} fitting samples"
        )
    th_s = _half_grid(t_s, t_s)
    command = CommandSignal.from_samples(t_s, kc)
    block = np.minimum((np.arange(nb) * N_TIME_BLOCKS) // nb, N_TIME_BLOCKS - 1).astype(np.int64)
    return DiscoveryData(
        t_ns=t_ns,
        t_s=t_s,
        kappa_cmd=kc,
        v=v,
        outputs=outputs,
        m=m,
        tc_s=block_mean(t_s, m),
        outputs_d={c: block_mean(y, m) for c, y in outputs.items()},
        sigma=sigma,
        sigma_d={c: s / np.sqrt(m) for c, s in sigma.items()},
        block=block,
        valid=valid,
        th_s=th_s,
        kappa_h=command.at(th_s),
        v_h=_half_grid(t_s, v),
        psi0=float(np.mean(outputs["psi"][:m])) if "psi" in outputs else 0.0,
        command=command,
    )
