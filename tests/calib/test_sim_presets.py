"""Presets: the command sequence, rates and noise they promise."""

from __future__ import annotations

import pytest

from calib.results import CommandType
from calib.sim.presets import PRESETS, harmonic, patent_mixed, preset, scaled_noise
from calib.sim.tractor_trailer import NoiseSpec, simulate_tractor_trailer


def test_mixed_sequence_and_rescaling() -> None:
    cfg = patent_mixed()
    kinds = [s.command_type for s in cfg.commands.segments()]
    assert kinds == [
        CommandType.HARMONIC,
        CommandType.CURVE,
        CommandType.LINEAR,
        CommandType.CONSTANT,
        CommandType.STEP,
    ]
    assert cfg.commands.duration_s == pytest.approx(249.0)
    short = patent_mixed(duration_s=24.9)
    assert short.commands.duration_s == pytest.approx(24.9)
    assert short.commands.specs[0].duration_s == pytest.approx(6.3)


def test_noise_scale_and_rates() -> None:
    cfg = harmonic(noise_scale=2.0, rate_hz=20.0)
    for name, sd in NoiseSpec().std.items():
        assert cfg.noise.std[name] == pytest.approx(2 * sd)
    assert cfg.rates_hz == {"cmd": 20.0, "odom": 20.0, "pose": 10.0, "hitch": 20.0}
    run = simulate_tractor_trailer(harmonic(duration_s=10.0, rate_hz=20.0, noise_scale=0.0))
    assert run.frames["pose"].height == 101
    assert run.frames["hitch"].height == 201
    with pytest.raises(ValueError, match="noise factor"):
        scaled_noise(-1.0)


def test_preset_lookup() -> None:
    assert set(PRESETS) == {"harmonic", "mixed"}
    assert preset("harmonic", L1=1.0).L1 == 1.0
    with pytest.raises(ValueError, match="unknown simulator preset 'nope'"):
        preset("nope")
