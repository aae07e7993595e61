"""Presets: the command sequence, rates and noise they promise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.errors import CalibError
from calib.tractor_trailer.models.hitch_kinematics import kappa_limit, steady_state_kappa
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.presets import (
    MIXED_CYCLE_S,
    PRESET_PSI_MAX_RAD,
    PRESETS,
    PresetName,
    harmonic,
    patent_mixed,
    preset,
    scaled_noise,
)
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    NoiseSpec,
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)
from calib.tractor_trailer.sim.validation import PSI_LIMIT_RAD, SimParameterError


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
    with pytest.raises(SimParameterError, match="noise_scale = -1: expected") as err:
        scaled_noise(-1.0)
    assert err.value.parameter == "noise_scale"


def test_preset_lookup() -> None:
    assert set(PRESETS) == {"harmonic", "mixed"} == {p.value for p in PresetName}
    assert preset("harmonic", L1=1.0).L1 == 1.0
    assert preset(PresetName.MIXED).commands.duration_s == pytest.approx(MIXED_CYCLE_S)
    with pytest.raises(SimParameterError, match="preset = 'nope': expected one of harmonic"):
        preset("nope")


@pytest.mark.parametrize("name", list(PresetName))
@pytest.mark.parametrize(("L1", "L2"), [(1.25, 2.48), (-0.02, 0.6), (0.0, 3.0)])
def test_presets_stay_bounded_at_any_duration(name: PresetName, L1: float, L2: float) -> None:
    """1800 s past the preset's length, the linear command ran to 2.7 1/m and psi
    to 449 rad; now the command stays within the steady-turn limit and |psi| < 0.785 rad."""
    run = simulate_tractor_trailer(
        preset(name, L1=L1, L2=L2, duration_s=1800.0, rate_hz=4.0, noise_scale=0.0)
    )
    kappa_cmd = np.abs(run.truth["kappa_cmd"].to_numpy())
    psi = np.abs(run.truth["psi"].to_numpy())
    assert run.config.commands.duration_s == pytest.approx(1800.0)
    assert np.max(kappa_cmd) <= 0.2011
    assert np.max(kappa_cmd) ** 2 < 1.0 / (L2 * L2 - L1 * L1)
    assert np.max(kappa_cmd) < kappa_limit(L1, L2)
    assert np.max(psi) < PSI_LIMIT_RAD


def test_mixed_cycles_past_its_length() -> None:
    cfg = patent_mixed(duration_s=1800.0)
    kinds = [s.command_type for s in cfg.commands.segments()]
    assert len(kinds) == 5 * 7  # round(1800 / 249) = 7 cycles, each stretched by 1.033
    assert (
        kinds[:5]
        == kinds[-5:]
        == [
            CommandType.HARMONIC,
            CommandType.CURVE,
            CommandType.LINEAR,
            CommandType.CONSTANT,
            CommandType.STEP,
        ]
    )
    assert cfg.commands.specs[0].duration_s == pytest.approx(63.0 * 1800.0 / (7 * 249.0))
    assert cfg.commands.peak_abs() == pytest.approx(0.2 * (6.3 / math.pi - 1.0))
    # the default length is unchanged (the sample logs depend on it)
    assert patent_mixed().commands.specs[2] == CommandSpec(CommandType.LINEAR, 63.0, 0.2, 0.1)


@pytest.mark.parametrize(
    ("kwargs", "parameter", "value"),
    [
        ({"rate_hz": 0.0}, "rate_hz", 0.0),
        ({"rate_hz": math.nan}, "rate_hz", math.nan),
        ({"L2": 0.0}, "L2", 0.0),
        ({"L2": -1.0}, "L2", -1.0),
        ({"L1": 2.5}, "L1", 2.5),
        ({"L1": math.inf}, "L1", math.inf),
        ({"duration_s": -5.0}, "duration_s", -5.0),
        ({"duration_s": 0.0}, "duration_s", 0.0),
        ({"v_mps": math.inf}, "v_mps", math.inf),
        ({"noise_scale": -1.0}, "noise_scale", -1.0),
        ({"timestamp_jitter_s": 0.02}, "timestamp_jitter_s", 0.02),
        ({"timestamp_jitter_s": -1e-3}, "timestamp_jitter_s", -1e-3),
        ({"hitch_model": "wobbly"}, "hitch_model", "wobbly"),
    ],
)
@pytest.mark.parametrize("name", list(PresetName))
def test_structured_errors(
    name: PresetName, kwargs: dict[str, object], parameter: str, value: float | str
) -> None:
    with pytest.raises(SimParameterError) as info:
        preset(name, **kwargs)
    err = info.value
    assert isinstance(err, CalibError)
    assert isinstance(err, ValueError)
    assert err.parameter == parameter
    assert err.value == value or (isinstance(value, float) and math.isnan(value))
    assert err.expected
    assert str(err).startswith(f"{parameter} = ")


def test_no_steady_turn_names_both_lengths() -> None:
    spec = CommandSpec(CommandType.HARMONIC, 20.0, amplitude=0.2)
    with pytest.raises(SimParameterError) as info:
        TractorTrailerSim(L1=1.0, L2=9.0, commands=CommandSequence([spec]))
    assert (info.value.parameter, info.value.value, info.value.related) == ("L2", 9.0, {"L1": 1.0})
    assert "steady turn at the largest commanded curvature 0.2 1/m" in info.value.expected
    # oversteer raises the driven curvature: K v^2 = -0.5 doubles it
    eff = Effects(understeer_K=-0.5)
    with pytest.raises(SimParameterError, match="L2 = 4"):
        TractorTrailerSim(L1=1.0, L2=4.0, commands=CommandSequence([spec]), effects=eff)


@pytest.mark.parametrize(
    ("L1", "L2", "understeer_K"),
    [(1.25, 9.0, 0.0), (2.4, 2.48, 0.0), (0.9, 3.1, 0.0), (1.25, 2.48, -0.6), (-2.4, 2.48, 0.0)],
)
def test_presets_lower_the_command_for_trailers_near_their_limit(
    L1: float, L2: float, understeer_K: float
) -> None:
    for name in PresetName:
        cfg = preset(
            name,
            L1=L1,
            L2=L2,
            duration_s=600.0,
            rate_hz=5.0,
            noise_scale=0.0,
            effects=Effects(understeer_K=understeer_K),
        )
        assert cfg.kappa_peak() <= steady_state_kappa(PRESET_PSI_MAX_RAD, L1, L2) + 1e-12
        psi = simulate_tractor_trailer(cfg).truth["psi"].to_numpy()
        assert np.max(np.abs(psi)) < PSI_LIMIT_RAD


def test_default_geometry_keeps_the_full_command() -> None:
    assert harmonic().commands.specs[0].amplitude == 0.2
    assert [s.amplitude for s in patent_mixed().commands.specs] == [0.2, 0.2, 0.2, 0.15, -0.15]


def test_negative_l1_accepted() -> None:
    run = simulate_tractor_trailer(harmonic(L1=-0.02, L2=0.5, duration_s=20.0, rate_hz=20.0))
    assert run.params["L1"] == -0.02
    assert np.all(np.isfinite(run.truth["psi"].to_numpy()))


def test_simulator_accepts_long_hitch_but_presets_do_not() -> None:
    """|L1| >= L2 is a real vehicle (a steady turn exists at any curvature); only the presets,
    which follow the patent's geometry, ask for |L1| < L2."""
    spec = CommandSpec(CommandType.HARMONIC, 20.0, amplitude=0.1)
    cfg = TractorTrailerSim(L1=1.8, L2=1.4, commands=CommandSequence([spec]))
    assert np.all(np.isfinite(simulate_tractor_trailer(cfg).truth["psi"].to_numpy()))
    with pytest.raises(SimParameterError, match=r"L1 = 1\.8"):
        harmonic(L1=1.8, L2=1.4)


def test_speed_profile_and_table_commands_validated() -> None:
    with pytest.raises(SimParameterError, match="variation = 1"):
        SpeedProfile(variation=1.0)
    with pytest.raises(SimParameterError, match="duration_s = 0"):
        CommandSpec(CommandType.CONSTANT, 0.0)

    class Table(CommandSequence):
        def __call__(self, t_s: object) -> np.ndarray:
            return np.full(np.atleast_1d(np.asarray(t_s, dtype=float)).shape, 0.05)

    # a subclass replacing __call__ is judged by its values, not its specs' closed forms
    table = Table([CommandSpec(CommandType.LINEAR, 60.0, 0.1, 1.0)])
    assert table.peak_abs() == pytest.approx(0.05)
    assert TractorTrailerSim(commands=table).kappa_peak() == pytest.approx(0.05)


def test_jitter_below_the_period_keeps_stamps_increasing() -> None:
    cfg = harmonic(duration_s=60.0, rate_hz=10.0, timestamp_jitter_s=0.099, noise_scale=0.0)
    run = simulate_tractor_trailer(cfg, seed=3)
    for frame in run.frames.values():
        assert np.all(np.diff(frame["t_ns"].to_numpy()) > 0)
