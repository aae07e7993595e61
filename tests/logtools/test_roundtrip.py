"""Round trip: simulate -> write (JSON MCAP, ROS 2 MCAP, CSV) -> read_log gives back the
simulated signals, timestamps exactly and values within float precision."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import polars as pl
import pytest

from calib.tractor_trailer.sim.presets import patent_mixed
from calib.tractor_trailer.sim.tractor_trailer import (
    SENSOR_GROUPS,
    Effects,
    SimulatedRun,
    simulate_tractor_trailer,
)
from logtools.readers import read_log
from logtools.robots.tractor_trailer import JSON_SOURCES, ROS2_SOURCES
from logtools.signals import DEFAULT_JSON_MAP, DEFAULT_ROS2_MAP
from logtools.writers.tractor_trailer import write_csv, write_mcap_json, write_mcap_ros2


@pytest.fixture(scope="module")
def run() -> SimulatedRun:
    """A short mixed run with noise, jittered stamps and a clock offset on the hitch sensor (so
    the groups' timestamps differ and the CSV rows are a true union)."""
    cfg = patent_mixed(
        duration_s=24.9,
        rate_hz=20.0,
        effects=Effects(clock_offset_s={"hitch": 0.013}),
    )
    return simulate_tractor_trailer(replace(cfg, timestamp_jitter_s=0.002), seed=11)


def _expected(run: SimulatedRun, signal: str) -> pl.DataFrame:
    group = next(g for g, sigs in SENSOR_GROUPS.items() if signal in sigs)
    return run.frames[group].select("t_ns", pl.col(signal).alias("value"))


def _yaw(frame: pl.DataFrame, base: str) -> np.ndarray:
    q = {c: frame[f"{base}.{c}"].to_numpy() for c in "xyzw"}
    return np.arctan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))


@pytest.mark.parametrize("encoding", ["json", "ros2"])
def test_mcap_round_trip(run: SimulatedRun, tmp_path: Path, encoding: str) -> None:
    path = tmp_path / f"run_{encoding}.mcap"
    (write_mcap_json if encoding == "json" else write_mcap_ros2)(path, run)
    log = read_log(path)
    assert log.problems == []
    assert log.metadata["logcal"] == {
        "robot": "tractor_trailer",
        "L1": "1.25",
        "L2": "2.48",
        "seed": "11",
    }
    shared, own = (
        (DEFAULT_JSON_MAP, JSON_SOURCES) if encoding == "json" else (DEFAULT_ROS2_MAP, ROS2_SOURCES)
    )
    mapping = {**shared, **own}
    for signal in ("kappa_cmd", "v_cmd", "v", "omega", "x", "y", "yaw", "psi"):
        src = mapping[signal]
        frame = log.topics[src.topic]
        exp = _expected(run, signal)
        np.testing.assert_array_equal(frame["t_ns"].to_numpy(), exp["t_ns"].to_numpy())
        if src.transform == "yaw_from_quaternion":
            got = _yaw(frame, src.field)
            diff = np.angle(np.exp(1j * (got - exp["value"].to_numpy())))
            assert np.max(np.abs(diff)) < 1e-12, signal
        else:
            np.testing.assert_array_equal(frame[src.field].to_numpy(), exp["value"].to_numpy())
    omega_cmd = log.topics["/cmd/vel"][mapping["omega_cmd"].field].to_numpy()
    cmd = run.frames["cmd"]
    np.testing.assert_allclose(omega_cmd, (cmd["v_cmd"] * cmd["kappa_cmd"]).to_numpy(), rtol=0)


def test_csv_round_trip(run: SimulatedRun, tmp_path: Path) -> None:
    path = tmp_path / "run.csv"
    write_csv(path, run)
    frame = read_log(path).topics["csv"]
    t0 = min(int(f["t_ns"].min()) for f in run.frames.values())  # type: ignore[arg-type]
    union = np.unique(np.concatenate([f["t_ns"].to_numpy() for f in run.frames.values()]))
    np.testing.assert_array_equal(frame["t_ns"].to_numpy(), union - t0)
    for signal in ("kappa_cmd", "v_cmd", "v", "omega", "x", "y", "yaw", "psi"):
        exp = _expected(run, signal).with_columns(pl.col("t_ns") - t0)
        got = frame.select("t_ns", signal).drop_nulls()
        np.testing.assert_array_equal(got["t_ns"].to_numpy(), exp["t_ns"].to_numpy())
        np.testing.assert_array_equal(got[signal].to_numpy(), exp["value"].to_numpy())
