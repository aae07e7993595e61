"""Random simulated runs for discovery studies (null study, coverage checks).

Test and bench helper (moved out of ``calib.tractor_trailer.discovery``); imported as
``discovery_simruns``
with ``tests/`` on the path.

A run holds nothing beyond a baseline's physics when it is simulated with the matching hitch
model ("steady" for the steady baseline, "transient" for the transient one) and no effects.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike
from sim_frame import aligned_frame_from_run

from calib.tractor_trailer.discovery import discover
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    NoiseSpec,
    SimulatedRun,
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)

__all__ = [
    "COMMAND_KINDS",
    "SPEED_KINDS",
    "NullStudyResult",
    "TableCommand",
    "TableSpeed",
    "WideRun",
    "command_table",
    "null_study",
    "random_run",
    "speed_table",
    "wide_run",
]

_KINDS = (
    CommandType.HARMONIC,
    CommandType.CURVE,
    CommandType.LINEAR,
    CommandType.CONSTANT,
    CommandType.STEP,
)


def random_run(
    rng: np.random.Generator,
    hitch_model: Literal["steady", "transient"],
    effects: Effects | None = None,
    duration_s: float = 90.0,
) -> SimulatedRun:
    """One run with random geometry, command mix, speed and noise seed.

    L1 in [0.8, 1.6] m, L2 in [1.8, 3.2] m; 3-5 segments of random type, amplitude 0.05-0.15
    1/m and rate 0.05-0.3 rad/s; speed 0.6-1.8 m/s with 0-30 % variation; default noise.
    """
    n_seg = int(rng.integers(3, 6))
    durations = rng.dirichlet(np.ones(n_seg)) * (duration_s - 10.0 * n_seg) + 10.0
    specs = [
        CommandSpec(
            kind=_KINDS[int(rng.integers(len(_KINDS)))],
            duration_s=float(d),
            amplitude=float(rng.uniform(0.05, 0.15) * rng.choice([-1.0, 1.0])),
            rate=float(rng.uniform(0.05, 0.3)),
            phase=float(rng.uniform(0, 2 * np.pi)),
        )
        for d in durations
    ]
    cfg = TractorTrailerSim(
        L1=float(rng.uniform(0.8, 1.6)),
        L2=float(rng.uniform(1.8, 3.2)),
        commands=CommandSequence(specs),
        speed=SpeedProfile(float(rng.uniform(0.6, 1.8)), variation=float(rng.uniform(0, 0.3))),
        effects=effects or Effects(),
        hitch_model=hitch_model,
    )
    return simulate_tractor_trailer(cfg, seed=int(rng.integers(2**31)))


@dataclass(frozen=True)
class NullStudyResult:
    """Per log: baseline used and the labels of the effects reported (empty = quiet)."""

    baselines: list[str]
    reported: list[list[str]]

    @property
    def n_logs(self) -> int:
        return len(self.reported)

    @property
    def n_quiet(self) -> int:
        return sum(1 for r in self.reported if not r)


def null_study(n_logs: int, seed: int = 0, duration_s: float = 90.0) -> NullStudyResult:
    """Run ``discover`` on ``n_logs`` runs without effects, alternating the steady and the
    transient baseline (each simulated with its own hitch model); the calibrated link lengths
    handed to discovery are the truth perturbed by up to 10 %."""

    rng = np.random.default_rng(seed)
    baselines: list[str] = []
    reported: list[list[str]] = []
    for i in range(n_logs):
        base: Literal["steady", "transient"] = "steady" if i % 2 == 0 else "transient"
        run = random_run(rng, base, duration_s=duration_s)
        L1 = run.params["L1"] * float(rng.uniform(0.9, 1.1))
        L2 = run.params["L2"] * float(rng.uniform(0.9, 1.1))
        res = discover(aligned_frame_from_run(run), L1, L2, baseline=base)
        baselines.append(base)
        reported.append([e.label for e in res.effects])
    return NullStudyResult(baselines, reported)


# --- wide conditions: speed profiles with stops, command shapes beyond the patent's ---------

SPEED_KINDS = ("constant", "varying", "stops")
COMMAND_KINDS = ("smooth", "chirp", "rate_limited_steps", "patent")


class TableCommand(CommandSequence):
    """A curvature command given as a table on a fine grid (linear in between), one segment of
    type OTHER (or the patent shapes' own types) for ``segments()``."""

    def __init__(self, t_s: np.ndarray, values: np.ndarray, specs: list[CommandSpec]) -> None:
        super().__init__(specs)
        object.__setattr__(self, "_t", np.asarray(t_s, dtype=float))
        object.__setattr__(self, "_y", np.asarray(values, dtype=float))

    def __call__(self, t_s: ArrayLike) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t_s, dtype=float))
        return np.interp(t, self._t, self._y)  # type: ignore[attr-defined]


class TableSpeed(SpeedProfile):
    """Speed (m/s) given as a table on a fine grid, linear in between."""

    def __init__(self, t_s: np.ndarray, values: np.ndarray) -> None:
        super().__init__(float(np.max(values)))
        object.__setattr__(self, "_t", np.asarray(t_s, dtype=float))
        object.__setattr__(self, "_y", np.asarray(values, dtype=float))

    def __call__(self, t_s: np.ndarray) -> np.ndarray:
        return np.interp(np.asarray(t_s, dtype=float), self._t, self._y)  # type: ignore[attr-defined]


def _rate_limit(x: np.ndarray, dt: float, max_rate: float) -> np.ndarray:
    out = np.empty_like(x)
    out[0] = x[0]
    step = max_rate * dt
    for i in range(1, x.size):
        out[i] = out[i - 1] + min(max(x[i] - out[i - 1], -step), step)
    return out


def speed_table(
    rng: np.random.Generator, kind: str, v_lo: float, v_hi: float, duration_s: float, dt: float
) -> tuple[np.ndarray, np.ndarray]:
    """Speed profile on a grid of step ``dt``: ``constant`` (v_hi, 2 s ramp), ``varying``
    (sinusoid between v_lo and v_hi) or ``stops`` (random levels in [v_lo, v_hi] with
    acceleration-limited changes and 2-5 s stops at zero)."""
    t = np.arange(0.0, duration_s + dt, dt)
    if kind == "constant":
        v = np.full_like(t, v_hi)
    elif kind == "varying":
        period = float(rng.uniform(15.0, 60.0))
        mid, amp = 0.5 * (v_hi + v_lo), 0.5 * (v_hi - v_lo)
        v = mid + amp * np.sin(2 * np.pi * t / period + rng.uniform(0, 2 * np.pi))
    elif kind == "stops":
        v = np.empty_like(t)
        i = 0
        while i < t.size:
            hold = float(rng.uniform(8.0, 25.0))
            level = float(rng.uniform(v_lo, v_hi))
            if i > 0 and rng.random() < 0.35:
                hold, level = float(rng.uniform(2.0, 5.0)), 0.0
            j = min(t.size, i + max(1, round(hold / dt)))
            v[i:j] = level
            i = j
    else:
        raise ValueError(f"unknown speed profile {kind!r}")
    v[t < 2.0] = 0.0 if kind == "stops" else v[t < 2.0]
    accel = max(0.3, 0.5 * v_hi)
    v = _rate_limit(np.concatenate([[0.0], v[1:]]), dt, accel)
    return t, np.maximum(v, 0.0)


def command_table(
    rng: np.random.Generator, kind: str, k_max: float, v_mean: float, duration_s: float, dt: float
) -> tuple[np.ndarray, np.ndarray, list[CommandSpec]]:
    """Curvature command (1/m) on a grid of step ``dt`` with |kappa| <= ``k_max``.

    ``smooth``: a sum of 3-5 sinusoids with spatial wavelengths 8-60 m at speed ``v_mean``;
    ``chirp``: a sweep from 60 m to 8 m wavelength; ``rate_limited_steps``: random levels held
    5-20 s, reached at a steering rate limit; ``patent``: the patent's H, C, L shapes.
    """
    t = np.arange(0.0, duration_s + dt, dt)
    vm = max(v_mean, 0.1)
    specs = [CommandSpec(CommandType.OTHER, duration_s)]
    if kind == "smooth":
        y = np.zeros_like(t)
        for _ in range(int(rng.integers(3, 6))):
            f = vm / float(rng.uniform(8.0, 60.0))
            y += rng.normal() * np.sin(2 * np.pi * f * t + rng.uniform(0, 2 * np.pi))
        y *= k_max / max(float(np.max(np.abs(y))), 1e-9)
    elif kind == "chirp":
        f0, f1 = vm / 60.0, vm / 8.0
        phase = 2 * np.pi * (f0 * t + 0.5 * (f1 - f0) * t * t / duration_s)
        y = k_max * np.sin(phase)
    elif kind == "rate_limited_steps":
        y = np.empty_like(t)
        i = 0
        while i < t.size:
            j = min(t.size, i + max(1, round(float(rng.uniform(5.0, 20.0)) / dt)))
            y[i:j] = float(rng.uniform(-k_max, k_max))
            i = j
        rate = k_max * float(rng.uniform(0.2, 2.0))  # full swing in 0.5-5 s
        y = _rate_limit(y, dt, rate)
    elif kind == "patent":
        w = vm / float(rng.uniform(8.0, 40.0))
        seq = CommandSequence(
            [
                CommandSpec(CommandType.HARMONIC, duration_s / 3, k_max, w),
                CommandSpec(CommandType.CURVE, duration_s / 3, -k_max, w),
                CommandSpec(CommandType.LINEAR, duration_s / 3, k_max, w / 2),
            ]
        )
        y, specs = np.clip(seq(t), -k_max, k_max), list(seq.specs)
    else:
        raise ValueError(f"unknown command shape {kind!r}")
    return t, y, specs


@dataclass(frozen=True)
class WideRun:
    """A run under wide conditions: the simulated run and what was drawn for it."""

    run: SimulatedRun
    conditions: dict[str, Any] = field(default_factory=dict)


def wide_run(
    rng: np.random.Generator,
    effects: Effects | None = None,
    *,
    speed_range: tuple[float, float] | None = None,
    speed_kind: str | None = None,
    command_kind: str | None = None,
    noise_scale: float | None = None,
    rate_hz: float | None = None,
) -> WideRun:
    """One transient-physics run with random geometry (L1/(L1 + L2) in [-0.05, 0.6], L1 + L2
    in [2, 4.5] m), speed profile (0.2-8 m/s), command shape and noise (0.5-2x the default).

    The command's amplitude keeps the steady joint angle within 0.5 rad and the lateral
    acceleration within 3 m/s^2; the duration (60-200 s) gives at least 40 m of travel
    where the speed allows.
    """
    total = float(rng.uniform(2.0, 4.5))
    frac = float(rng.uniform(-0.05, 0.6))
    L1, L2 = frac * total, (1.0 - frac) * total
    if speed_range is None:
        v_hi = float(np.exp(rng.uniform(np.log(0.3), np.log(8.0))))
        v_lo = float(v_hi * rng.uniform(0.2, 0.8))
    else:
        v_lo, v_hi = speed_range
    sk = speed_kind or SPEED_KINDS[int(rng.integers(len(SPEED_KINDS)))]
    ck = command_kind or COMMAND_KINDS[int(rng.integers(len(COMMAND_KINDS)))]
    v_mean = v_hi if sk == "constant" else 0.5 * (v_lo + v_hi)
    duration = float(np.clip(60.0 / max(v_mean, 1e-3), 60.0, 200.0))
    k_max = float(min(0.5 / total, 3.0 / v_hi**2, 0.3) * rng.uniform(0.5, 1.0))
    dt = 0.005
    tv, vv = speed_table(rng, sk, v_lo, v_hi, duration, dt)
    tk, kk, specs = command_table(rng, ck, k_max, v_mean, duration, dt)
    ns = float(
        noise_scale if noise_scale is not None else np.exp(rng.uniform(np.log(0.5), np.log(2)))
    )
    noise = NoiseSpec({k: v * ns for k, v in NoiseSpec().std.items()})
    rate = float(rate_hz or rng.choice([20.0, 50.0, 100.0]))
    cfg = TractorTrailerSim(
        L1=L1,
        L2=L2,
        commands=TableCommand(tk, kk, specs),
        speed=TableSpeed(tv, vv),
        noise=noise,
        effects=effects or Effects(),
        hitch_model="transient",
        rate_hz=rate,
        rates_hz={"cmd": rate, "odom": rate, "pose": rate / 2, "hitch": rate},
    )
    run = simulate_tractor_trailer(cfg, seed=int(rng.integers(2**31)))
    cond = {
        "L1": L1,
        "L2": L2,
        "speed_kind": sk,
        "v_lo": v_lo,
        "v_hi": v_hi,
        "command_kind": ck,
        "k_max": k_max,
        "duration_s": duration,
        "noise_scale": ns,
        "rate_hz": rate,
    }
    return WideRun(run, cond)
