"""Discovery on logs of the independent generator (tests/indgen), the failures found on them,
equivalent explanations, the acceptance rule, the joint fit and robustness on odd data.

The indgen logs are aligned here with numpy (command held, outputs interpolated onto a uniform
grid at the fastest topic's rate), independently of logtools, and the raw topics are handed
to ``discover`` as ``signals``.
"""

from __future__ import annotations

import inspect
import json
import math
import sys
from dataclasses import replace
from pathlib import Path
from typing import Literal

import numpy as np
import polars as pl
import pytest
from discovery_logs import LOG_DIR, read_aligned
from sim_frame import aligned_frame_from_run  # type: ignore[import-not-found]

from calib.tractor_trailer.discovery import DEFAULT_BASELINE, DiscoveryResult, catalogue, discover
from calib.tractor_trailer.discovery.model import BASE_PARAMS
from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.sim.commands import CommandSequence, CommandSpec
from calib.tractor_trailer.sim.tractor_trailer import (
    Effects,
    SpeedProfile,
    TractorTrailerSim,
    simulate_tractor_trailer,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import indgen  # type: ignore[import-not-found]

_SIGNALS = {
    "/cmd/curvature": {"curvature": "kappa_cmd"},
    "/odom": {"v": "v", "omega": "omega"},
    "/hitch/angle": {"angle": "psi"},
}


def indgen_log(scn: indgen.Scenario, seed: int) -> tuple[pl.DataFrame, dict[str, pl.DataFrame]]:
    """(aligned frame, raw signals) of an indgen run."""
    gen = indgen.generate(scn, seed=seed)
    raw: dict[str, pl.DataFrame] = {}
    for topic, fields in _SIGNALS.items():
        td = gen.topics[topic]
        for field, name in fields.items():
            raw[name] = pl.DataFrame({"t_ns": td.stamps_ns, "value": td.fields[field]})
    t0 = max(int(f["t_ns"][0]) for f in raw.values())
    t1 = min(int(f["t_ns"][-1]) for f in raw.values())
    rate = max(s.rate_hz for s in scn.topics.values())
    grid = np.arange(t0, t1, round(1e9 / rate), dtype=np.int64)
    cols: dict[str, np.ndarray] = {"t_ns": grid}
    for name, f in raw.items():
        t, y = f["t_ns"].to_numpy(), f["value"].to_numpy()
        if name == "kappa_cmd":  # a logger holds the last command
            cols[name] = y[np.clip(np.searchsorted(t, grid, side="right") - 1, 0, y.size - 1)]
        else:
            cols[name] = np.interp(grid.astype(float), t.astype(float), y)
    return pl.DataFrame(cols), raw


def scenario(
    effects: indgen.Effects,
    speed: indgen.Speed,
    *,
    M: float = 0.08,
    duration_s: float = 60.0,
    L1: float = 1.25,
    L2: float = 2.48,
) -> indgen.Scenario:
    """Random smooth curvature (3 sines), 50 Hz topics with the default noise."""
    command = indgen.Command(
        "random",
        M=M,
        freqs_hz=(0.03, 0.07, 0.12),
        phases=(0.0, 1.0, 2.0),
        weights=(0.4, 0.35, 0.25),
    )
    topics = {
        "cmd": indgen.TopicSpec(50.0),
        "odom": indgen.TopicSpec(50.0, noise={"v": 0.02, "omega": 0.005}),
        "hitch": indgen.TopicSpec(50.0, noise={"angle": 0.005}),
    }
    return indgen.Scenario(
        L1=L1,
        L2=L2,
        duration_s=duration_s,
        command=command,
        speed=speed,
        effects=effects,
        topics=topics,
    )


def random_speed(lo: float, hi: float) -> indgen.Speed:
    return indgen.Speed(
        "random", lo=lo, hi=hi, freqs_hz=(0.02, 0.05), phases=(0.3, 1.1), weights=(0.6, 0.4)
    )


def labels(res: DiscoveryResult, drop: tuple[str, ...] = ()) -> list[str]:
    return sorted(e.label for e in res.effects if e.label not in drop)


def inside(res: DiscoveryResult, label: str, param: str, value: float) -> bool:
    e = next(e for e in res.effects if e.label == label)
    lo, hi = e.ci95[param]
    return lo <= value <= hi


def test_default_baseline_is_transient() -> None:
    assert DEFAULT_BASELINE == "transient"
    assert inspect.signature(discover).parameters["baseline"].default == "transient"


def test_L1_may_be_negative_or_zero() -> None:
    """A hitch ahead of the axle (L1 = -0.02 m on a real robot) is inside the fit's bounds."""
    assert BASE_PARAMS[0].lower < -0.5 < 0.0 < BASE_PARAMS[0].upper


@pytest.mark.slow
def test_hitch_clock_late_at_high_speed_is_named() -> None:
    """A joint-angle topic stamped 0.4 s late at 5-8 m/s was not named."""
    scn = scenario(indgen.Effects(clock_offset_s={"hitch": 0.4}), random_speed(5.0, 8.0), M=0.05)
    frame, raw = indgen_log(scn, seed=1)
    res = discover(frame, 1.3, 2.4, signals=raw)
    assert labels(res) == ["clock_offset(hitch)"], res.report()
    assert inside(res, "clock_offset(hitch)", "offset", 0.4)


def test_understeer_with_varying_speed_is_named() -> None:
    """Understeer K = 0.05 s^2/m^2 at 1-5 m/s was not named."""
    scn = scenario(indgen.Effects(understeer_K=0.05), random_speed(1.0, 5.0))
    frame, raw = indgen_log(scn, seed=2)
    res = discover(frame, 1.3, 2.4, signals=raw)
    assert labels(res) == ["understeer"], res.report()
    assert inside(res, "understeer", "K", 0.05)


@pytest.mark.slow
@pytest.mark.parametrize("baseline", ["transient", "steady"])
def test_dead_time_is_one_cause_with_clock_offsets_as_alternative(baseline: str) -> None:
    """A 0.6 s actuator dead time was reported as two clock offsets. At constant
    speed the two explanations are equivalent: one cause is reported, the other listed."""
    scn = scenario(indgen.Effects(actuator_delay_s=0.6), indgen.Speed(base=1.5))
    frame, raw = indgen_log(scn, seed=3)
    res = discover(frame, 1.3, 2.4, baseline=baseline, signals=raw)  # type: ignore[arg-type]
    assert labels(res, drop=("hitch_transient",)) == ["actuator_delay"], res.report()
    assert inside(res, "actuator_delay", "delay", 0.6)
    delay = res.effect("actuator_delay")
    assert delay is not None
    assert "clock_offset(odom) + clock_offset(hitch)" in delay.alternatives
    alt = next(a for a in res.alternatives if a.rule == "dead_time_vs_clock_offsets")
    assert alt.reported == ("actuator_delay",)
    assert set(alt.alternative) == {"clock_offset(odom)", "clock_offset(hitch)"}
    for p in alt.parameters.values():
        assert p["offset"] == pytest.approx(0.6, abs=0.05)
    assert "one physical cause" in alt.note
    assert "could also be" in res.report()


def test_understeer_at_constant_speed_lists_the_yaw_rate_gain() -> None:
    """At one speed understeer and a yaw-rate gain look alike: whichever is reported, the
    other is listed as an equivalent explanation."""
    scn = scenario(indgen.Effects(understeer_K=0.05), indgen.Speed(base=2.0))
    frame, raw = indgen_log(scn, seed=4)
    res = discover(frame, 1.3, 2.4, signals=raw)
    named = labels(res)
    assert named in (["understeer"], ["sensor_scale(omega)"]), res.report()
    other = "sensor_scale(omega)" if named == ["understeer"] else "understeer"
    assert other in res.effects[0].alternatives, res.report()


def step_scenario(effects: indgen.Effects) -> indgen.Scenario:
    """Curvature steps (true jumps between command samples) at 2 m/s, 50 Hz topics."""
    base = scenario(effects, indgen.Speed(base=2.0), duration_s=80.0)
    steps = indgen.Command(
        "steps",
        M=0.1,
        step_times=(12.0, 24.0, 36.0, 48.0, 60.0, 72.0),
        step_levels=(0.0, 0.08, -0.05, 0.1, -0.08, 0.03, -0.1),
    )
    return replace(base, command=steps)


@pytest.mark.slow
def test_dead_time_on_step_commands_is_fitted() -> None:
    """A dead time across held command jumps: with point samples of the command the fit had
    no gradient and stayed at its start; averaged over each row's interval it is continuous."""
    frame, raw = indgen_log(step_scenario(indgen.Effects(actuator_delay_s=0.15)), seed=6)
    res = discover(frame, 1.3, 2.4, signals=raw)
    assert labels(res) == ["actuator_delay"], res.report()
    assert inside(res, "actuator_delay", "delay", 0.15), res.report()


@pytest.mark.slow
def test_steering_lag_of_a_few_samples_is_named_as_a_lag() -> None:
    """A first-order lag of 0.06 s (three samples at 50 Hz) on step commands: the lag's exact
    discretisation fits it; the trapezoidal one smeared it so that a dead time fitted better
    and was named instead."""
    frame, raw = indgen_log(step_scenario(indgen.Effects(actuator_lag_s=0.06)), seed=7)
    res = discover(frame, 1.3, 2.4, signals=raw)
    assert labels(res) == ["actuator_lag"], res.report()
    assert inside(res, "actuator_lag", "time_constant", 0.06), res.report()


def test_clean_indgen_log_reports_nothing() -> None:
    scn = scenario(indgen.Effects(), random_speed(0.5, 3.0))
    frame, raw = indgen_log(scn, seed=5)
    res = discover(frame, 1.3, 2.4, signals=raw)
    assert res.effects == [], res.report()
    assert res.status == "ok"


@pytest.mark.slow
@pytest.mark.parametrize("baseline", ["transient", "steady"])
def test_noise_free_sample_log_reports_only_effects_that_exclude_their_null(
    baseline: str,
) -> None:
    """The sample tt_harmonic_clean.mcap reported two clock offsets and a gain of 1.0000 whose
    intervals contained the null value. Now nothing against the transient baseline, and
    against the steady one only the hitch transient the log really has."""
    frame = read_aligned(LOG_DIR / "tt_harmonic_clean.mcap")
    res = discover(frame, 1.3, 2.4, baseline=baseline)  # type: ignore[arg-type]
    expected = [] if baseline == "transient" else ["hitch_transient"]
    assert labels(res) == expected, res.report()
    base: Literal["steady", "transient"] = "steady" if baseline == "steady" else "transient"
    nulls = {(e.key, p.name): p.null for e in catalogue(base) for p in e.params}
    for e in res.effects:
        for name, (lo, hi) in e.ci95.items():
            assert not lo <= nulls[(e.label, name)] <= hi


@pytest.mark.slow
def test_reported_effects_exclude_null_and_improve_holdout() -> None:
    """The acceptance rule on a log with two effects: every reported effect's interval
    excludes its null value and removing it makes the held-out RMS of a channel worse."""
    cmds = CommandSequence(
        [
            CommandSpec(CommandType.HARMONIC, 50.0, 0.15, 0.2),
            CommandSpec(CommandType.STEP, 30.0, 0.12),
        ]
    )
    cfg = TractorTrailerSim(
        commands=cmds,
        speed=SpeedProfile(1.2, variation=0.3),
        effects=Effects(sensor_offset={"psi": 0.02}, clock_offset_s={"odom": 0.15}),
    )
    res = discover(aligned_frame_from_run(simulate_tractor_trailer(cfg, seed=9)), 1.3, 2.4)
    assert labels(res) == ["clock_offset(odom)", "sensor_offset(psi)"], res.report()
    nulls = {(e.key, p.name): p.null for e in catalogue("transient") for p in e.params}
    for e in res.effects:
        for name, (lo, hi) in e.ci95.items():
            assert not lo <= nulls[(e.label, name)] <= hi
        assert any(e.rms_after[c] < e.rms_before[c] for c in e.channels)
        assert e.delta_bic < 0


@pytest.mark.slow
def test_joint_fit_carries_the_model_with_its_effects() -> None:
    """A hitch 2 cm ahead of the axle (L1 < 0) with a joint-angle offset: the joint fit holds
    L1, L2 with intervals and covariance from the model with the accepted effect."""
    cmds = CommandSequence([CommandSpec(CommandType.HARMONIC, 80.0, 0.4, 0.25)])
    cfg = TractorTrailerSim(
        L1=-0.02,
        L2=0.537,
        commands=cmds,
        speed=SpeedProfile(0.3, variation=0.3),
        effects=Effects(sensor_offset={"psi": 0.03}),
    )
    res = discover(aligned_frame_from_run(simulate_tractor_trailer(cfg, seed=4)), 0.05, 0.6)
    assert labels(res) == ["sensor_offset(psi)"], res.report()
    jf = res.joint_fit
    assert jf is not None
    assert jf.model == "transient + sensor_offset(psi)"
    assert jf.effects == ("sensor_offset(psi)",)
    for name, truth in (("L1", -0.02), ("L2", 0.537)):
        lo, hi = jf.ci95[name]
        assert lo <= truth <= hi, (name, jf.parameters[name], (lo, hi))
        assert jf.std[name] == pytest.approx(
            math.sqrt(jf.covariance[0 if name == "L1" else 1][0 if name == "L1" else 1])
        )
    assert jf.covariance[0][1] == pytest.approx(jf.covariance[1][0])
    assert jf.effect_parameters["sensor_offset(psi)"]["offset"] == pytest.approx(0.03, abs=0.005)
    doc = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert doc["joint_fit"]["model"] == "transient + sensor_offset(psi)"
    assert set(doc["joint_fit"]) >= {"parameters", "std", "ci95", "covariance", "effects"}
    assert doc["status"] == "ok"
    assert doc["alternatives"] == [] or isinstance(doc["alternatives"], list)


def _frames() -> dict[str, pl.DataFrame]:
    n = 400
    t = np.arange(n, dtype=np.int64) * 10_000_000
    k = 0.1 * np.sin(np.arange(n) / 50.0)
    good = pl.DataFrame({"t_ns": t, "kappa_cmd": k, "v": np.ones(n), "psi": 3.0 * k})
    return {
        "empty": good.head(0),
        "five rows": good.head(5),
        "no outputs": good.drop("psi"),
        "no speed": good.drop("v"),
        "all-NaN psi": good.with_columns(psi=pl.lit(float("nan"))),
        "standing still": good.with_columns(v=pl.lit(0.0)),
        "constant everything": good.with_columns(kappa_cmd=pl.lit(0.0), psi=pl.lit(0.0)),
        "duplicate stamps": pl.concat([good, good]),
        "reversed rows": good.reverse(),
        "huge values": good.with_columns(psi=pl.col("psi") * 1e12),
        "nulls": good.with_columns(
            psi=pl.when(pl.col("t_ns") % 3 == 0).then(None).otherwise(pl.col("psi"))
        ),
        "short and reversing": good.with_columns(v=pl.Series(np.linspace(-1, 1, n))),
    }


@pytest.mark.parametrize("case", list(_frames()))
def test_discover_never_raises_on_odd_data(case: str) -> None:
    frame = _frames()[case]
    for L1, L2 in ((1.25, 2.48), (float("nan"), -1.0), (-0.02, 0.0)):
        res = discover(frame, L1, L2)
        assert res.status in ("ok", "partial", "not_run")
        if res.status != "ok":
            assert res.reason
        json.dumps(res.to_dict(), allow_nan=False)
        assert res.report()
