"""A robot's derived signals (``RobotPlugin.derived_signals``): the shared resolution asks every
plugin the same way, records each derived signal's origin, and knows no robot by name; the
tractor-trailer's kappa_cmd derivation works on the signals alone."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import polars as pl
import pytest

import logtools.robots as robots
from logtools.channel_map import ChannelMap, resolve_signals
from logtools.readers import read_log
from logtools.robots import RobotPlugin, SignalDerivation, SignalSpec
from logtools.robots.base import Derived, FoundSignals
from logtools.robots.tractor_trailer.curvature import (
    V_CMD_MIN,
    KappaCmdKind,
    derive_kappa_cmd,
    saturated_steer_notes,
)
from logtools.signals import DERIVED_TOPIC, OriginKind, RobotConfig, SignalOrigin, SignalSource

CALLS: list[str] = []


def _speed_magnitude(found: FoundSignals) -> Derived:
    CALLS.append(found.path)
    v = found.signals.get("v", None)
    if v is None:
        return Derived(notes=(f"{found.path}: no v, so no speed magnitude",))
    out = v.with_columns(pl.col("value").abs())
    origin = SignalOrigin("magnitude", "abs(v)", f"|v| from {found.sources['v'].describe()}")
    return Derived(
        out,
        SignalSource(DERIVED_TOPIC, "abs(v)", formula="abs(v)"),
        origin,
        ("speed magnitude derived",),
    )


PLUGIN = RobotPlugin(
    name="speed_robot",
    title="a robot that derives its speed magnitude",
    signals=(SignalSpec("speed", "m/s", "speed magnitude"),),
    identify=lambda signals: None,
    analyze=lambda *a: None,
    report=lambda result: [],
    derived_signals=(SignalDerivation("speed", derive=_speed_magnitude),),
)


@pytest.fixture
def speed_robot() -> Iterator[None]:
    saved = list(robots._registered)
    robots.register(PLUGIN)
    CALLS.clear()
    yield
    robots._registered[:] = saved


def _csv(tmp_path: Path, **columns: np.ndarray) -> Path:
    t = np.arange(0.0, 10.0, 0.1)
    path = tmp_path / "run.csv"
    pl.DataFrame({"t": t, **{k: v[: t.size] for k, v in columns.items()}}).write_csv(path)
    return path


def test_a_registered_plugin_derives_its_signal_with_an_origin(
    speed_robot: None, tmp_path: Path
) -> None:
    v = -np.linspace(0.2, 1.0, 100)
    res = resolve_signals(read_log(_csv(tmp_path, v=v, psi=np.zeros(100) + 0.1)))
    np.testing.assert_allclose(res.signals["speed"]["value"].to_numpy(), -v)
    assert res.sources["speed"].describe() == "= abs(v)"
    assert res.origins["speed"] == SignalOrigin("magnitude", "abs(v)", "|v| from csv:v")
    assert res.origins["speed"].by_robot
    assert "speed magnitude derived" in res.problems
    assert len(CALLS) == 1


def test_a_logged_signal_is_not_derived_and_its_origin_says_logged(
    speed_robot: None, tmp_path: Path
) -> None:
    res = resolve_signals(read_log(_csv(tmp_path, v=np.ones(100), speed=np.full(100, 2.0))))
    assert CALLS == []
    np.testing.assert_allclose(res.signals["speed"]["value"].to_numpy(), 2.0)
    assert res.origins["speed"].kind == OriginKind.LOGGED
    assert not res.origins["speed"].by_robot


def test_a_signal_switched_off_is_not_derived(speed_robot: None, tmp_path: Path) -> None:
    cmap = ChannelMap(off=frozenset({"speed"}))
    res = resolve_signals(read_log(_csv(tmp_path, v=np.ones(100))), cmap)
    assert CALLS == []
    assert "speed" not in res.signals
    assert "speed" not in res.origins


def test_notes_of_a_derivation_that_cannot_derive_reach_the_problems(
    speed_robot: None, tmp_path: Path
) -> None:
    res = resolve_signals(read_log(_csv(tmp_path, psi=np.full(100, 0.1))))
    assert "speed" not in res.signals
    assert any("no v, so no speed magnitude" in p for p in res.problems)


def _found(robot: RobotConfig | None = None, **values: np.ndarray) -> FoundSignals:
    t_ns = np.arange(100, dtype=np.int64) * 20_000_000
    signals = {
        n: pl.DataFrame({"t_ns": t_ns[: v.size], "value": v.astype(float)})
        for n, v in values.items()
    }
    sources = {n: SignalSource("/cmd", n) for n in values}
    return FoundSignals(
        "log.mcap", signals, sources, robot or RobotConfig(), {"wheelbase": "the test"}
    )


def test_tractor_kappa_cmd_from_steering_and_the_wheelbase() -> None:
    steer = np.linspace(-0.5, 0.5, 100)
    got = derive_kappa_cmd(_found(RobotConfig(params={"wheelbase": 0.5}), steer_cmd=steer))
    assert got.signal is not None
    assert got.origin is not None
    np.testing.assert_allclose(got.signal["value"].to_numpy(), np.tan(steer) / 0.5, rtol=1e-14)
    assert got.origin.kind is KappaCmdKind.STEERING
    assert got.origin.source == "tan(steer_cmd) / 0.5"
    assert "wheelbase 0.5 m from the test" in got.origin.description
    assert got.notes == ()


def test_tractor_kappa_cmd_needs_a_wheelbase_to_use_steering() -> None:
    got = derive_kappa_cmd(
        _found(steer_cmd=np.zeros(100), v_cmd=np.ones(100), omega_cmd=np.ones(100))
    )
    assert got.signal is None  # the steering command wins over the twist, and says why not
    assert any("no wheelbase is known" in n for n in got.notes)


def test_tractor_kappa_cmd_from_the_twist_where_the_speed_is_not_zero() -> None:
    v = np.where(np.arange(100) < 50, 1.0, V_CMD_MIN / 2)
    got = derive_kappa_cmd(_found(v_cmd=v, omega_cmd=np.full(100, 0.3)))
    assert got.signal is not None
    assert got.origin is not None
    assert got.signal.height == 50
    np.testing.assert_allclose(got.signal["value"].to_numpy(), 0.3)
    assert got.origin.kind is KappaCmdKind.TWIST
    assert any("map it as steer_cmd" in n for n in got.notes)


def test_tractor_reports_saturated_measured_steering() -> None:
    steer = np.full(100, 0.1)
    steer[:7] = math.radians(86)
    notes = saturated_steer_notes(_found(steer=steer))
    assert len(notes) == 1
    assert "7 of 100 samples of steer" in notes[0]
    assert saturated_steer_notes(_found(steer=np.full(100, 0.1))) == []
