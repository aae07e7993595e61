"""Discovery inputs: the aligned frame as arrays, a decimated fitting grid and noise levels."""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar, cast

import numpy as np
import polars as pl
from numpy.typing import NDArray

from calib.errors import InsufficientDataError
from calib.stats import hf_noise_std
from calib.tractor_trailer.discovery.jumps import jump_intervals

__all__ = [
    "OUTPUTS",
    "RESOLUTION",
    "CommandSignal",
    "DiscoveryData",
    "block_mean",
    "command_samples",
    "output_noise_std",
    "prepare_data",
    "robust_noise_std",
]

FloatArray = NDArray[np.float64]

OUTPUTS: tuple[str, ...] = ("omega", "psi")
MIN_FIT_SAMPLES = 150
FIT_RATE_HZ = 10.0
N_TIME_BLOCKS = 8
BURN_IN_M = 10.0
REVERSE_MPS = 0.02  # speeds below -this count as reversing
GAP_S = 0.5  # a longer gap between complete rows restarts the joint-angle model
REANCHOR_M = 5.0  # travel (m) left out after a restart, while the model forgets it
# Finest misfit worth explaining, per output (rad/s, rad): below any real sensor's resolution
# (a 14-bit encoder quantises to 3.8e-4 rad), above the model's numerical error. It floors the
# noise level, so that a noise-free log's interpolation error is not taken for physics.
RESOLUTION: dict[str, float] = {"omega": 1e-4, "psi": 1e-4}
_DELAYS_KEPT = 4  # delayed commands remembered per log (each one array of the half grid)
# values remembered per kind by ``DiscoveryData.recall`` (default 4)
RECALLED: dict[str, int] = {"predict": 8, "inputs": 4, "psi": 6, "fit": 8}
T = TypeVar("T")


def block_mean(x: FloatArray, m: int) -> FloatArray:
    """Means of consecutive blocks of ``m`` samples (the tail that does not fill one is dropped)."""
    nb = x.size // m
    return x[: nb * m].reshape(nb, m).mean(axis=1)


def robust_noise_std(y: FloatArray) -> float:
    """:func:`calib.stats.hf_noise_std` of ``y``, NaN for fewer than 12 samples (too few to
    tell noise from signal)."""
    return hf_noise_std(y) if y.size >= 12 else float("nan")


def output_noise_std(y: FloatArray) -> float:
    """White-noise level of a recorded output on the aligned grid (units of y).

    An output interpolated onto a faster grid is linear between its own samples: its second
    differences vanish except where a sample lies, so the estimate is taken on those rows
    (about the recorded samples). A quantised output (many exact repeats) is not quieter than
    its quantisation noise q / sqrt(12), q the smallest step it makes.
    """
    return _noise_and_rows(y)[0]


def _noise_and_rows(y: FloatArray) -> tuple[float, float]:
    """(noise std, aligned rows per recorded sample) of an output on the aligned grid."""
    if y.size < 12:
        return robust_noise_std(y), 1.0
    d2 = np.diff(y, n=2)
    scale = max(float(np.max(np.abs(y))), 1e-12)
    knots = np.flatnonzero(np.abs(d2) > 1e-9 * scale) + 1
    interpolated = 12 <= knots.size < 0.7 * d2.size
    ys = y[knots] if interpolated else y
    rows = y.size / knots.size if interpolated else 1.0
    return _quantised_floor(ys, robust_noise_std(ys)), rows


def _quantised_floor(ys: FloatArray, s: float) -> float:
    d1 = np.diff(ys)
    steps = np.abs(d1[d1 != 0])
    s = s if np.isfinite(s) else 0.0
    if d1.size and float(np.mean(d1 == 0)) > 0.3 and steps.size:
        s = max(s, float(np.percentile(steps, 5)) / math.sqrt(12.0))
    return s


@dataclass(frozen=True)
class DiscoveryData:
    """Arrays for discovery.

    Full rate (the aligned grid): ``t_ns``, ``t_s`` (s from the first row), ``kappa_cmd``
    (1/m), ``v`` (m/s), ``outputs`` (recorded "omega" rad/s and/or "psi" rad).
    Fitting grid: blocks of ``m`` full-rate samples averaged (about 10 Hz): ``tc_s`` (block
    centres), ``outputs_d``; ``sigma_d`` is each output's white-noise level on that grid (a
    block averages only the recorded samples it holds) and ``sigma`` per recorded sample.
    ``block`` labels each fitting sample with its time block (0..7); even blocks train, odd
    blocks are held out. ``valid`` drops the first ``BURN_IN_M`` metres
    of travel, where the modelled joint angle still forgets its assumed initial state, and
    ``REANCHOR_M`` after each restart of the joint-angle model: ``anchors`` (aligned rows) and
    ``anchors_d`` (fitting rows) map where it restarts from the recorded angle (reversing,
    gaps longer than ``GAP_S``) to that angle. ``sampled``: per output whose aligned values are
    the linear interpolation of its own samples (checked), those samples' times (s from the
    first row): the model is then recorded the same way (``model.as_recorded``).

    The time, command and speed arrays are read-only; ``recall`` remembers the model's
    intermediate results for the parameters they depend on.
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
    anchors: dict[int, float]
    anchors_d: dict[int, float]
    command: CommandSignal
    sampled: dict[str, FloatArray] = field(default_factory=dict)
    _delayed: dict[float, FloatArray] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _recent: dict[str, OrderedDict[Hashable, Any]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        # read-only: the model's steps remember their results by the arrays they were run on
        # (``effects.base.remembered``)
        for a in (self.t_s, self.tc_s, self.th_s, self.kappa_h, self.v_h, self.kappa_cmd, self.v):
            a.flags.writeable = False

    def recall(self, kind: str, key: Hashable, make: Callable[[], T], size: int | None = None) -> T:
        """``make()``, remembered under ``key`` among the last few values of its ``kind``
        (``RECALLED`` says how many; ``size`` overrides).

        Why: a fit evaluates the model hundreds of times, and a finite-difference Jacobian
        varies one parameter at a time, so most evaluations repeat a step of the one before
        (the inputs when only a link length or a sensor parameter moved, the joint angle when
        only a yaw-rate parameter moved, a fit that selection and confirmation both ask for).
        The values live as long as this object and are never changed (results are pure
        functions of their key); ``functools.lru_cache`` would hold them past it."""
        store = self._recent.setdefault(kind, OrderedDict())
        if key in store:
            store.move_to_end(key)
            return cast(T, store[key])
        value = make()
        store[key] = value
        if len(store) > (size if size is not None else RECALLED.get(kind, 4)):
            store.popitem(last=False)
        return value

    def delayed_command(self, delay_s: float) -> FloatArray:
        """The command on the half-step grid ``delay_s`` later (1/m). Remembered for the last
        few delays: a finite-difference Jacobian varies one parameter at a time, so most of a
        fit's model evaluations share the delay of the one before (a pure function of it)."""
        key = float(delay_s)
        out = self._delayed.get(key)
        if out is None:
            if len(self._delayed) >= _DELAYS_KEPT:
                self._delayed.pop(next(iter(self._delayed)))
            out = self.command.at(self.th_s - key)
            out.flags.writeable = False  # shared between calls: nobody may change it
            self._delayed[key] = out
        return out

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(self.outputs)

    def mean_square_speed(self) -> float:
        """Mean of v^2 over the valid fitting rows (m^2/s^2; each row's speed the mean of its
        block): the speed at which a conversion between speed-dependent explanations holds."""
        v = block_mean(self.v, self.m)[self.valid]
        return float(np.mean(v * v))

    @property
    def dt_s(self) -> float:
        """Median sample period of the aligned grid (s)."""
        return float(np.median(np.diff(self.t_s)))

    @property
    def time_resolution_s(self) -> float:
        """How well a time shift can be known (s): the aligned grid's period, or the command's
        sample period where it jumps (a jump is only known to lie between two samples)."""
        return max(self.dt_s, self.command.jump_period_s)

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

    Linear between samples, except across a jump (``jump_intervals``): a jump is only known
    to lie between the two samples that show it, and is placed at their midpoint, its
    expected place (holding the old value to the later sample would make every jump late by
    half a period on average, which a fitted dead time or clock offset takes up). ``at``
    averages it over the window
    [t - eps/2, t + eps/2], eps the period of the grid it is evaluated on (``prepare_data``:
    the aligned grid's; default 1/50 of the command's period): each row stands for its own
    sample interval, as the block means of the fitting grid do, so the modelled outputs are
    continuous in a time shift (a dead time, a clock offset) even across a held jump, where a
    point sample would give the fit a zero gradient and leave the shift where it started.
    """

    t_s: FloatArray
    y: FloatArray
    slope: FloatArray
    cum: FloatArray
    eps: float
    jump_period_s: float = 0.0
    _knots: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_knots", np.arange(self.t_s.size, dtype=float))

    @classmethod
    def from_samples(
        cls,
        t_s: FloatArray,
        y: FloatArray,
        *,
        hold_jumps: bool = True,
        window_s: float | None = None,
    ) -> CommandSignal:
        """``hold_jumps=False``: linear across jumps too (a jump recorded by a slow command
        topic is only known to lie between two samples; the ramp is its expected place).
        ``window_s``: width (s) of the window ``at`` averages over (default 1/50 of the
        command's median period). ``jump_period_s``: the median sample period across the
        command's jumps (0 without jumps), the uncertainty of their times."""
        dt = np.diff(t_s)
        eps = float(np.median(dt)) / 50.0 if dt.size else 1e-6
        jumps = jump_intervals(y) if dt.size else np.zeros(0, dtype=bool)
        # across a gap in the topic (a dropout, a stall) a change is no jump that can be
        # placed: linear is its expected course
        if dt.size:
            jumps &= dt <= 1.5 * float(np.median(dt))
        jump_period = float(np.median(dt[jumps])) if jumps.any() else 0.0
        if not hold_jumps:
            jumps[:] = False
        if jumps.any():  # a knot at each jump's midpoint: old value before, new value after
            j = np.flatnonzero(jumps)
            t_s = np.insert(t_s, j + 1, 0.5 * (t_s[j] + t_s[j + 1]))
            y = np.insert(y, j + 1, y[j + 1])
            jumps = np.zeros(t_s.size - 1, dtype=bool)
            jumps[j + np.arange(j.size)] = True
            jumps[j + np.arange(j.size) + 1] = True
            dt = np.diff(t_s)
        slope = np.where(jumps, 0.0, np.diff(y) / np.where(dt > 0, dt, 1.0))
        cum = np.concatenate([[0.0], np.cumsum(y[:-1] * dt + 0.5 * slope * dt * dt)])
        if window_s is not None and window_s > 0:
            eps = float(window_s)
        return cls(t_s, y, slope, cum, eps, jump_period)

    def integral(self, tq: FloatArray) -> FloatArray:
        """Integral from t_s[0] to ``tq`` (held constant outside the samples)."""
        tq = np.asarray(tq, dtype=float)
        if tq.ndim == 0:
            return self.integral(tq[None]).reshape(())
        t = self.t_s
        # the interval of each query: np.interp of the knot positions is searchsorted's
        # answer (floored) but walks sorted queries in step, faster
        i = np.interp(tq, t, self._knots).astype(np.int64)
        np.clip(i, 0, t.size - 2, out=i)
        tau = np.clip(tq, t[0], t[-1])
        tau -= t[i]
        # cum + y tau + slope tau^2 / 2, in place (a fit evaluates it for every delay it tries)
        quad = self.slope[i]
        quad *= 0.5
        quad *= tau
        quad *= tau
        out = self.y[i]
        out *= tau
        out += self.cum[i]
        out += quad
        before, after = tq < t[0], tq > t[-1]
        if before.any():
            out[before] = (tq[before] - t[0]) * self.y[0]
        if after.any():
            out[after] = self.cum[-1] + (tq[after] - t[-1]) * self.y[-1]
        return out

    def at(self, tq: FloatArray) -> FloatArray:
        """Mean over [tq - eps/2, tq + eps/2] (units of y)."""
        h = 0.5 * self.eps
        return (self.integral(tq + h) - self.integral(tq - h)) / self.eps


def command_samples(t_s: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The samples of a command that the aligned frame holds between them (zero-order hold
    onto a faster grid): (times, values) to interpolate the command through.

    A value that changes only every few rows was recorded at a lower rate: each change marks a
    sample (at the row where it appears). The typical run between changes gives the command's
    own period P; a run much longer than P (the command really stayed constant) keeps its value
    until P before the next change, so that the change spans one period as it did when it was
    recorded. A command that changes on every row, or whose runs are not mostly of one length
    (fewer than 20 runs, or under 60 % within 1.5 rows of the median), is returned as is.
    """
    if y.size < 4:
        return t_s, y
    starts = np.concatenate([[0], np.flatnonzero(np.diff(y) != 0) + 1])
    if starts.size < 4:
        return t_s, y
    runs = np.diff(np.concatenate([starts, [y.size]]))
    rows = float(np.median(runs[:-1]))
    # a held low-rate command: many runs of about the same length (give or take a row of
    # jitter); a command that is only constant between steps has few runs of any length
    typical = np.abs(runs[:-1] - rows) <= 1.5
    if rows < 1.5 or runs.size < 20 or typical.mean() < 0.6:
        return t_s, y
    dt = float(np.median(np.diff(t_s)))
    period = rows * dt
    ts, ys = [], []
    for i, s0 in enumerate(starts):
        ts.append(t_s[s0])
        ys.append(y[s0])
        if i + 1 < starts.size:
            if runs[i] > 1.5 * rows:
                ts.append(t_s[starts[i + 1]] - period)
                ys.append(y[s0])
        elif t_s[-1] > t_s[s0]:
            ts.append(t_s[-1])
            ys.append(y[s0])
    return np.asarray(ts, dtype=float), np.asarray(ys, dtype=float)


HOLD_JUMPS_MAX_PERIOD_S = 0.02


def _raw(
    signals: Mapping[str, pl.DataFrame] | None, name: str, t0_ns: int
) -> tuple[FloatArray, FloatArray] | None:
    """(time in ns from ``t0_ns`` as float, value) of a raw signal frame (``t_ns``,
    ``value``), finite rows only, in time order.

    The difference is taken in integers before the conversion to float: an absolute stamp
    (ns since 1970, ~1.8e18) is only resolved to 256 ns as a float64, so converting first
    made the times, and with them every fitted time shift, depend on the log's epoch (a CSV
    copy stamped from 0 and an MCAP copy of the same log gave different answers)."""
    if not signals or name not in signals:
        return None
    f = signals[name]
    if "t_ns" not in f.columns or "value" not in f.columns or f.height < 4:
        return None
    t_int = f.get_column("t_ns").cast(pl.Int64).to_numpy()
    t = (t_int - np.int64(t0_ns)).astype(float)
    y = f.get_column("value").cast(pl.Float64).to_numpy()
    ok = np.isfinite(y)
    order = np.argsort(t[ok], kind="stable")
    return t[ok][order], y[ok][order]


def _interpolated_from(
    signals: Mapping[str, pl.DataFrame] | None,
    name: str,
    t_ns: NDArray[np.int64],
    y: FloatArray,
) -> FloatArray | None:
    """Times (s from ``t_ns[0]``) of output ``name``'s own samples if its aligned values ``y``
    at ``t_ns`` are their linear interpolation (RMS difference under 1 % of the RMS change
    between consecutive samples: a zero-order hold would differ by about that change) and
    they are sparser than the aligned grid, else None.

    Why: a slow topic interpolated onto a faster grid turns a jump of the yaw rate (a step
    command) into a ramp over its sample period, and bends the joint angle's fast transients;
    compared with the model at every row, that ramp is a misfit of many times the noise that
    no catalogue effect explains (a clock offset fitted to it drifts with the conditions).
    Recording the model the same way removes it.
    """
    raw = _raw(signals, name, int(t_ns[0]))
    if raw is None:
        return None
    t_raw, y_raw = raw
    keep = np.concatenate([[True], np.diff(t_raw) > 0])
    t_raw, y_raw = t_raw[keep], y_raw[keep]
    if t_raw.size < 4 or t_raw.size >= 0.8 * t_ns.size:
        return None
    ts = t_raw / 1e9
    t_s = (t_ns - t_ns[0]) / 1e9
    inside = (t_s >= ts[0]) & (t_s <= ts[-1])
    if not inside.any():
        return None
    rebuilt = np.interp(t_s[inside], ts, y_raw)
    step = float(np.sqrt(np.mean(np.diff(y_raw) ** 2)))
    if float(np.sqrt(np.mean((rebuilt - y[inside]) ** 2))) > 0.01 * step + 1e-12:
        return None
    return np.asarray(ts, dtype=float)


def prepare_data(
    frame: pl.DataFrame, signals: Mapping[str, pl.DataFrame] | None = None
) -> DiscoveryData:
    """Arrays from an aligned frame: ``t_ns``, ``kappa_cmd``, ``v`` (else ``v_cmd``),
    ``omega``/``kappa``, ``psi``. A command held between its samples is interpolated through
    them (``command_samples``).

    Rows with a missing value in a used column are dropped (the command is taken from every
    row that holds it). ``signals``: optional raw logical signals (``t_ns``, ``value``, e.g.
    ``logtools``' ``ResolvedSignals.signals``): the command is then interpolated through its
    own samples and the outputs' noise is measured on theirs. A jump of the command is held
    (zero-order) only when its samples are at most ``HOLD_JUMPS_MAX_PERIOD_S`` apart; from a
    slower topic it is only known to lie between two samples and is spread over them.

    Raises ``InsufficientDataError`` when a column is missing or the log is too short to fit
    and hold out (< 15 s at 10 Hz).
    """
    need = ["t_ns", "kappa_cmd", "v"]
    if "v" not in frame.columns and "v_cmd" in frame.columns:
        # no measured speed: the commanded one stands in (a drive-gain error then shows up
        # as a yaw-rate gain or understeer)
        frame = frame.with_columns(pl.col("v_cmd").alias("v"))
    missing = [c for c in need if c not in frame.columns]
    if missing:
        raise InsufficientDataError(
            f"discovery: aligned frame lacks column(s) {missing}; expected t_ns, kappa_cmd, v "
            f"and omega (or kappa) and/or psi, got {frame.columns}"
        )
    df = frame.sort("t_ns").unique(subset="t_ns", keep="first", maintain_order=True)
    if "omega" not in df.columns and "kappa" in df.columns:
        kappa = pl.col("kappa")
        if "kappa_source" in df.columns:  # a curvature differentiated from the path is no sensor
            kappa = pl.when(pl.col("kappa_source") == "path").then(None).otherwise(kappa)
        df = df.with_columns((kappa * pl.col("v")).alias("omega"))
        if df.get_column("omega").drop_nulls().len() == 0:
            df = df.drop("omega")
    outs = [c for c in OUTPUTS if c in df.columns]
    if not outs:
        raise InsufficientDataError(
            "discovery: aligned frame has neither omega (or kappa) nor psi; nothing to compare "
            f"the model with (columns: {df.columns})"
        )
    cols = need + outs
    # the command from every row that has it: a gap in an output must not move its steps
    cmd = df.select("t_ns", "kappa_cmd").drop_nulls()
    cmd = cmd.filter(pl.col("kappa_cmd").cast(pl.Float64).is_finite())
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
    sampled = {}
    for c, y in outputs.items():
        ts = _interpolated_from(signals, c, t_ns, y)
        if ts is not None:
            sampled[c] = ts
    sigma, sigma_d = {}, {}
    for c, y in outputs.items():
        raw = _raw(signals, c, int(t_ns[0]))
        if raw is not None and raw[0].size >= 12:
            period = float(np.median(np.diff(raw[0]))) / 1e9
            s = _quantised_floor(raw[1], robust_noise_std(raw[1]))
            rows = max(period / dt, 1.0) if dt > 0 else 1.0
        else:
            s, rows = _noise_and_rows(y)
        sigma[c] = max(s if np.isfinite(s) else 0.0, RESOLUTION[c])
        # a block of m rows averages only the recorded samples it holds
        sigma_d[c] = sigma[c] / math.sqrt(max(m / rows, 1.0))
    kc, v = _column(df, "kappa_cmd"), _column(df, "v")
    # travel (m) at the end of each fitting block, over the recorded time (gaps included)
    step = np.abs(v[1:] + v[:-1]) * 0.5 * np.diff(t_s)
    travel = np.concatenate([[0.0], np.cumsum(step)])
    dist = travel[np.arange(1, nb + 1) * m - 1]
    valid = dist >= BURN_IN_M
    anchors, anchors_d = {}, {}
    if "psi" in outputs:
        # where the model cannot run open loop, restart it from the recorded angle: reversing
        # (the joint angle is unstable backwards) and after a gap in the recording
        gap = np.concatenate([[False], np.diff(t_s) > GAP_S])
        events = (v < -REVERSE_MPS) | gap
        psi_rec = outputs["psi"]
        anchors = {int(i): float(psi_rec[i]) for i in np.flatnonzero(events)}
        ev_d = block_mean(events.astype(float), m) > 0
        psi_d = block_mean(psi_rec, m)
        anchors_d = {int(i): float(psi_d[i]) for i in np.flatnonzero(ev_d)}
        last = -np.inf
        for i in range(nb):
            if ev_d[i]:
                last = dist[i]
            if dist[i] - last < REANCHOR_M:
                valid[i] = False
    if int(valid.sum()) < MIN_FIT_SAMPLES:
        raise InsufficientDataError(
            f"discovery: only {dist[-1]:.1f} m of travel; need {BURN_IN_M:g} m to settle plus "
            f"{MIN_FIT_SAMPLES} fitting samples"
        )
    th_s = _half_grid(t_s, t_s)
    raw_cmd = _raw(signals, "kappa_cmd", int(t_ns[0]))
    if raw_cmd is not None:
        tk, yk = raw_cmd[0] / 1e9, raw_cmd[1]
        keep = np.concatenate([[True], np.diff(tk) > 0])
        tk, yk = tk[keep], yk[keep]
    else:
        tk = (cmd.get_column("t_ns").cast(pl.Int64).to_numpy() - t_ns[0]) / 1e9
        tk, yk = command_samples(tk, _column(cmd, "kappa_cmd"))
    period = float(np.median(np.diff(tk))) if tk.size > 1 else 0.0
    command = CommandSignal.from_samples(
        tk, yk, hold_jumps=period <= HOLD_JUMPS_MAX_PERIOD_S, window_s=dt
    )
    kc = command.at(t_s)
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
        sigma_d=sigma_d,
        block=block,
        valid=valid,
        th_s=th_s,
        kappa_h=command.at(th_s),
        v_h=_half_grid(t_s, v),
        psi0=float(np.mean(outputs["psi"][:m])) if "psi" in outputs else 0.0,
        anchors=anchors,
        anchors_d=anchors_d,
        command=command,
        sampled=sampled,
    )
