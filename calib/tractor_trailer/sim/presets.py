"""Ready-made tractor-trailer simulator configurations (used by ``logcal simulate`` and the
sample logs).

Each preset is a function of the physical knobs (link lengths in m, speed in m/s, duration in s,
a factor on the default sensor noise, the base rate in Hz, the timestamp jitter in s, the hitch
model) returning a :class:`~calib.tractor_trailer.sim.tractor_trailer.TractorTrailerSim`. Every
preset stays
within the physical limits at any duration: its command stays within its amplitude (1/m),
lowered for trailers that would otherwise turn past 0.77 rad, so kappa^2 < 1/(L2^2 - L1^2) and
|psi| < 0.785 rad (:data:`~calib.tractor_trailer.sim.validation.PSI_LIMIT_RAD`) throughout.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any, Literal

from calib.tractor_trailer.models.hitch_kinematics import steady_state_kappa
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.choices import PresetName
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    HitchModel,
    NoiseSpec,
    SpeedProfile,
    TractorTrailerSim,
)
from calib.tractor_trailer.sim.validation import (
    PSI_LIMIT_RAD,
    SimParameterError,
    check_non_negative,
    check_positive,
    require,
)

__all__ = [
    "MIXED_CYCLE_S",
    "PRESETS",
    "PRESET_PSI_MAX_RAD",
    "PresetName",
    "harmonic",
    "patent_mixed",
    "preset",
    "scaled_noise",
]

PATENT_SEGMENT_S = 63.0
"""The patent's segment length (s): one period of sin(0.1 t)."""


def scaled_noise(factor: float) -> NoiseSpec:
    """The default :class:`NoiseSpec` with every standard deviation times ``factor`` (>= 0).

    Raises:
        SimParameterError: ``factor`` (named ``noise_scale``) negative or not finite.
    """
    check_non_negative("noise_scale", factor)
    return NoiseSpec(std={k: s * factor for k, s in NoiseSpec().std.items()})


def _rates(rate_hz: float) -> dict[str, float]:
    """Per-group rates: everything at ``rate_hz`` except the pose at half of it."""
    return {"cmd": rate_hz, "odom": rate_hz, "pose": rate_hz / 2.0, "hitch": rate_hz}


PRESET_PSI_MAX_RAD = 0.98 * PSI_LIMIT_RAD
"""Largest steady joint angle (rad) a preset's command may ask for: 2 % inside the patent's
limit |psi| < 0.785 rad. The default geometry (L1 = 1.25 m, L2 = 2.48 m) reaches 0.751 rad
at the presets' full amplitude 0.2 1/m."""


def _build(specs: list[CommandSpec], *, L1: float, L2: float, **sim: Any) -> TractorTrailerSim:
    """The preset's simulator: ``specs`` played in sequence, their amplitudes scaled down (all
    by one factor) where the full command would drive the joint beyond
    :data:`PRESET_PSI_MAX_RAD` in a steady turn (long or off-axle trailers). The joint angle
    relaxes towards its steady state without overshoot, so |psi| < 0.785 rad throughout.

    Raises:
        SimParameterError: a parameter that makes no physical sense, or ``|L1| >= L2``.
    """
    base = TractorTrailerSim(L1=L1, L2=L2, **sim)  # no commands yet: checks all but them
    require(abs(L1) < L2, "L1", L1, "|L1| < L2 (m)", {"L2": L2})
    commands = CommandSequence(specs)
    cap = float(steady_state_kappa(PRESET_PSI_MAX_RAD, L1, L2))
    peak = commands.peak_abs() * base.curvature_gain()
    if peak > cap:
        f = cap / peak
        commands = CommandSequence(
            [replace(s, amplitude=s.amplitude * f, offset=s.offset * f) for s in specs]
        )
    return replace(base, commands=commands)


def harmonic(
    *,
    L1: float = 1.25,
    L2: float = 2.48,
    v_mps: float = 1.0,
    duration_s: float = PATENT_SEGMENT_S,
    amplitude: float = 0.2,
    noise_scale: float = 1.0,
    rate_hz: float = 50.0,
    effects: Effects | None = None,
    timestamp_jitter_s: float = 0.0,
    hitch_model: HitchModel | Literal["transient", "steady"] = HitchModel.TRANSIENT,
) -> TractorTrailerSim:
    """The patent's harmonic command M sin(0.1 t) (M in 1/m, lowered where the trailer would
    pass |psi| = 0.77 rad: see :func:`_build`) at a constant speed (m/s), for any
    ``duration_s`` (one segment; |command| <= M throughout).

    Raises:
        SimParameterError: a parameter that makes no physical sense, or ``|L1| >= L2``.
    """
    spec = CommandSpec(CommandType.HARMONIC, duration_s, amplitude=amplitude, rate=0.1)
    return _build(
        [spec],
        L1=L1,
        L2=L2,
        speed=SpeedProfile(v_mps=v_mps, ramp_s=0.0),
        noise=scaled_noise(noise_scale),
        effects=effects or Effects(),
        hitch_model=hitch_model,
        rate_hz=rate_hz,
        rates_hz=_rates(rate_hz),
        timestamp_jitter_s=timestamp_jitter_s,
    )


_MIXED = (
    CommandSpec(CommandType.HARMONIC, PATENT_SEGMENT_S, amplitude=0.2, rate=0.1),
    CommandSpec(CommandType.CURVE, PATENT_SEGMENT_S, amplitude=0.2, rate=0.1),
    CommandSpec(CommandType.LINEAR, PATENT_SEGMENT_S, amplitude=0.2, rate=0.1),
    CommandSpec(CommandType.CONSTANT, 30.0, amplitude=0.15),
    CommandSpec(CommandType.STEP, 30.0, amplitude=-0.15),
)

MIXED_CYCLE_S = sum(s.duration_s for s in _MIXED)
"""Length of one cycle of the mixed preset (s): 249."""


def _scaled(spec: CommandSpec, k: float) -> CommandSpec:
    """``spec`` stretched in time by ``k``; a linear ramp keeps its range (-M to about +M)."""
    if CommandType(spec.kind) is CommandType.LINEAR:
        return replace(spec, duration_s=spec.duration_s * k, rate=spec.rate / k)
    return replace(spec, duration_s=spec.duration_s * k)


def patent_mixed(
    *,
    L1: float = 1.25,
    L2: float = 2.48,
    v_mps: float = 1.0,
    duration_s: float | None = None,
    noise_scale: float = 1.0,
    rate_hz: float = 50.0,
    speed_variation: float = 0.2,
    effects: Effects | None = None,
    timestamp_jitter_s: float = 0.0,
    hitch_model: HitchModel | Literal["transient", "steady"] = HitchModel.TRANSIENT,
) -> TractorTrailerSim:
    """Harmonic, curve, linear (63 s each, M = 0.2 1/m, w = 0.1 rad/s), constant 0.15 1/m
    (30 s) and a step 0 -> -0.15 1/m (30 s) in sequence, at ``v_mps`` varying by
    ``speed_variation`` (fraction) with a 40 s period.

    ``duration_s`` (default one cycle, 249 s) plays the cycle round(duration_s / 249) times (at
    least once), every repetition stretched by the same factor to fill the duration; the linear
    ramp keeps running from -M to +M (0.2011 1/m at its end, as in the patent), so the command
    stays within |kappa| <= 0.2011 1/m at any duration. The amplitudes are lowered where the
    trailer would pass |psi| = 0.77 rad (see :func:`_build`).

    Raises:
        SimParameterError: a parameter that makes no physical sense, or ``|L1| >= L2``.
    """
    total = MIXED_CYCLE_S if duration_s is None else check_positive("duration_s", duration_s, "s")
    n = max(1, round(total / MIXED_CYCLE_S))
    k = total / (n * MIXED_CYCLE_S)
    return _build(
        [_scaled(s, k) for s in _MIXED] * n,
        L1=L1,
        L2=L2,
        speed=SpeedProfile(v_mps=v_mps, ramp_s=2.0, variation=speed_variation, period_s=40.0),
        noise=scaled_noise(noise_scale),
        effects=effects or Effects(),
        hitch_model=hitch_model,
        rate_hz=rate_hz,
        rates_hz=_rates(rate_hz),
        timestamp_jitter_s=timestamp_jitter_s,
    )


PRESETS: dict[str, Callable[..., TractorTrailerSim]] = {
    PresetName.HARMONIC: harmonic,
    PresetName.MIXED: patent_mixed,
}


def preset(name: PresetName | str, **kwargs: object) -> TractorTrailerSim:
    """The preset ``name`` (a :class:`PresetName` or its value) built with ``kwargs``.

    Raises:
        SimParameterError: unknown preset name (parameter ``preset``), or a keyword argument
            that makes no physical sense.
    """
    try:
        make = PRESETS[name]
    except KeyError:
        raise SimParameterError(
            "preset", str(name), f"one of {', '.join(p.value for p in PresetName)}"
        ) from None
    return make(**kwargs)
