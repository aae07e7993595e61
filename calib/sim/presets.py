"""Ready-made tractor-trailer simulator configurations (used by ``logcal simulate`` and the
sample logs).

Each preset is a function of the physical knobs (link lengths in m, speed in m/s, duration in s,
a factor on the default sensor noise, the base rate in Hz) returning a
:class:`~calib.sim.tractor_trailer.TractorTrailerSim`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

from calib.results import CommandType
from calib.sim.commands import CommandSequence, CommandSpec
from calib.sim.tractor_trailer import Effects, NoiseSpec, SpeedProfile, TractorTrailerSim

__all__ = ["PRESETS", "harmonic", "patent_mixed", "preset", "scaled_noise"]

PATENT_SEGMENT_S = 63.0
"""The patent's segment length (s): one period of sin(0.1 t)."""


def scaled_noise(factor: float) -> NoiseSpec:
    """The default :class:`NoiseSpec` with every standard deviation times ``factor``."""
    if factor < 0:
        raise ValueError(f"noise factor must be >= 0, got {factor}")
    return NoiseSpec(std={k: s * factor for k, s in NoiseSpec().std.items()})


def _rates(rate_hz: float) -> dict[str, float]:
    """Per-group rates: everything at ``rate_hz`` except the pose at half of it."""
    return {"cmd": rate_hz, "odom": rate_hz, "pose": rate_hz / 2.0, "hitch": rate_hz}


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
) -> TractorTrailerSim:
    """The patent's harmonic command M sin(0.1 t) (M in 1/m) at a constant speed (m/s)."""
    spec = CommandSpec(CommandType.HARMONIC, duration_s, amplitude=amplitude, rate=0.1)
    return TractorTrailerSim(
        L1=L1,
        L2=L2,
        commands=CommandSequence([spec]),
        speed=SpeedProfile(v_mps=v_mps, ramp_s=0.0),
        noise=scaled_noise(noise_scale),
        effects=effects or Effects(),
        rate_hz=rate_hz,
        rates_hz=_rates(rate_hz),
    )


_MIXED = (
    CommandSpec(CommandType.HARMONIC, PATENT_SEGMENT_S, amplitude=0.2, rate=0.1),
    CommandSpec(CommandType.CURVE, PATENT_SEGMENT_S, amplitude=0.2, rate=0.1),
    CommandSpec(CommandType.LINEAR, PATENT_SEGMENT_S, amplitude=0.2, rate=0.1),
    CommandSpec(CommandType.CONSTANT, 30.0, amplitude=0.15),
    CommandSpec(CommandType.STEP, 30.0, amplitude=-0.15),
)


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
) -> TractorTrailerSim:
    """Harmonic, curve, linear (63 s each, M = 0.2 1/m, w = 0.1 rad/s), constant 0.15 1/m
    (30 s) and a step 0 -> -0.15 1/m (30 s) in sequence, at ``v_mps`` varying by
    ``speed_variation`` (fraction) with a 40 s period; ``duration_s`` rescales all segments
    (default 249 s)."""
    total = sum(s.duration_s for s in _MIXED)
    k = 1.0 if duration_s is None else duration_s / total
    specs = [replace(s, duration_s=s.duration_s * k) for s in _MIXED]
    return TractorTrailerSim(
        L1=L1,
        L2=L2,
        commands=CommandSequence(specs),
        speed=SpeedProfile(v_mps=v_mps, ramp_s=2.0, variation=speed_variation, period_s=40.0),
        noise=scaled_noise(noise_scale),
        effects=effects or Effects(),
        rate_hz=rate_hz,
        rates_hz=_rates(rate_hz),
    )


PRESETS: dict[str, Callable[..., TractorTrailerSim]] = {
    "harmonic": harmonic,
    "mixed": patent_mixed,
}


def preset(name: str, **kwargs: object) -> TractorTrailerSim:
    """The preset ``name`` (a key of :data:`PRESETS`) built with ``kwargs``.

    Raises:
        ValueError: unknown preset name.
    """
    try:
        make = PRESETS[name]
    except KeyError:
        raise ValueError(
            f"unknown simulator preset {name!r}; expected one of {', '.join(sorted(PRESETS))}"
        ) from None
    return make(**kwargs)
