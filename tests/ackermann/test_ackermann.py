"""The Ackermann car joins with one registration line each (the robot, its effect), touching no
shared file: ``logcal analyze`` recognises its log, calibrates wheelbase and steering offset
through the shared bicycle kinematics, and the shared engine accepts the car's own effect (a
gyro bias) only once it is registered."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import logtools.robots as robots
from ackermann.car import CAR_EFFECTS, GYRO_BIAS, PLUGIN, CarData, CarFitter, simulate
from calib.discovery import EffectKind, EffectSpec
from logtools.cli.main import main

WHEELBASE, OFFSET, BIAS = 2.7, 0.02, 0.05


@pytest.fixture
def car() -> Iterator[None]:
    saved = list(robots._registered)
    robots.register(PLUGIN)  # the robot's one registration line
    yield
    robots._registered[:] = saved


@pytest.fixture
def gyro_bias() -> Iterator[None]:
    CAR_EFFECTS.register(GYRO_BIAS)  # the effect's one registration line
    yield
    CAR_EFFECTS.unregister(GYRO_BIAS)


def _analyze(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> dict[str, object]:
    log = tmp_path / "car.csv"
    log.write_text(simulate(WHEELBASE, OFFSET, BIAS, seed=4))
    assert main(["analyze", str(log), "--json"]) == 0
    doc: dict[str, object] = json.loads(capsys.readouterr().out)
    return doc


@pytest.mark.usefixtures("car", "gyro_bias")
def test_the_registered_effect_is_found_and_the_geometry_calibrated(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = _analyze(tmp_path, capsys)
    assert doc["robot"] == "ackermann"
    discovery = doc["discovery"]  # type: ignore[index]
    assert discovery["accepted"] == ["gyro_bias(omega)"]
    bias = discovery["effects"]["gyro_bias(omega)"]["bias"]
    assert bias["ci95"][0] < BIAS < bias["ci95"][1]
    est = doc["estimate"]  # type: ignore[index]
    for name, truth in (("wheelbase", WHEELBASE), ("steering_offset", OFFSET)):
        lo, hi = est[name]["ci95"]
        assert lo < truth < hi, (name, lo, hi)


@pytest.mark.usefixtures("car")
def test_without_the_registration_the_catalogue_is_empty(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert CAR_EFFECTS.entries() == ()
    doc = _analyze(tmp_path, capsys)
    assert doc["discovery"]["accepted"] == []  # type: ignore[index]


def test_an_effect_without_the_car_s_hook_is_refused() -> None:
    hookless = EffectSpec("stuck", "omega", EffectKind.SENSOR, (), "a stuck reading")
    with pytest.raises(ValueError, match="no yaw_rate"):
        CAR_EFFECTS.register(hookless)


def test_the_fitter_s_folds_are_the_shared_alternate_blocks() -> None:
    n = 1234
    data = CarData(np.zeros(n), np.ones(n), np.zeros(n))
    fitter = CarFitter(data)
    assert fitter.train.size + fitter.test.size == n
    assert np.intersect1d(fitter.train, fitter.test).size == 0
    assert fitter.train[:3].tolist() == [0, 1, 2]
    assert fitter.test[0] == 250
