"""load_log on logs written by our own writers from simulated runs with known truth."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest

from calib.tractor_trailer.results import CommandType as C
from calib.tractor_trailer.sim.commands import CommandSequence
from calib.tractor_trailer.sim.commands import CommandSpec as S
from calib.tractor_trailer.sim.tractor_trailer import TractorTrailerSim, simulate_tractor_trailer
from logtools.errors import LogcalInputError
from logtools.load import load_log, metadata_truth
from logtools.signals import SignalSource
from logtools.writers.tractor_trailer import write_run


@pytest.fixture(scope="module")
def run():
    seq = CommandSequence([S(C.HARMONIC, 25, 0.2, 0.25), S(C.CURVE, 15, -0.15, 0.3)])
    return simulate_tractor_trailer(TractorTrailerSim(commands=seq), seed=3)


def _truth_at(run, frame: pl.DataFrame, name: str) -> np.ndarray:
    """Truth at the frame's rows (both start at the simulation start; CSV time starts at 0)."""
    tt = run.truth["t_ns"].to_numpy()
    tf = frame["t_ns"].to_numpy()
    return np.interp(tf - tf[0], tt - tt[0], run.truth[name].to_numpy())


@pytest.mark.parametrize("encoding", ["json", "ros2", "csv"])
def test_load_aligns_and_derives_kappa(run, tmp_path, encoding):
    path = tmp_path / ("log.csv" if encoding == "csv" else "log.mcap")
    write_run(path, run, encoding=encoding)
    loaded = load_log(path)
    frame = loaded.frame
    assert loaded.robot == "tractor_trailer"
    assert loaded.truth == ({} if encoding == "csv" else {"L1": 1.25, "L2": 2.48})
    for col in ("kappa_cmd", "v", "omega", "x", "y", "yaw", "psi", "kappa", "kappa_source"):
        assert col in frame.columns
    t = frame["t_ns"].to_numpy()
    assert np.all(np.diff(t) == 10_000_000)  # 100 Hz grid, the fastest sensor's rate
    # commands are held exactly; psi within its sensor noise (0.005 rad)
    cmd = run.frames["cmd"]["kappa_cmd"].to_numpy()
    np.testing.assert_allclose(frame["kappa_cmd"].to_numpy(), cmd[: frame.height], atol=1e-12)
    psi_err = frame["psi"].to_numpy() - _truth_at(run, frame, "psi")
    assert np.std(psi_err) == pytest.approx(0.005, rel=0.1)
    # kappa = omega / v once moving: noise 0.002 rad/s on omega over v ~ 1 m/s
    moving = _truth_at(run, frame, "v") > 0.5
    src = np.asarray(frame["kappa_source"].to_list(), dtype=object)
    assert np.all(src[moving] == "omega/v")
    k_err = frame["kappa"].to_numpy()[moving] - _truth_at(run, frame, "kappa")[moving]
    assert abs(np.mean(k_err)) < 1e-3
    assert np.std(k_err) < 0.005
    assert not loaded.problems


def test_channel_map_takes_precedence(run, tmp_path):
    path = tmp_path / "log.mcap"
    write_run(path, run, encoding="json")
    loaded = load_log(path, {"psi": SignalSource("/odom", "omega")})
    np.testing.assert_array_equal(loaded.frame["psi"].to_numpy(), loaded.frame["omega"].to_numpy())
    assert loaded.signals.sources["psi"] == SignalSource("/odom", "omega")


def test_rate_and_missing_file(run, tmp_path):
    path = tmp_path / "log.mcap"
    write_run(path, run, encoding="json")
    loaded = load_log(path, rate_hz=10.0)
    assert np.all(np.diff(loaded.frame["t_ns"].to_numpy()) == 100_000_000)
    with pytest.raises(LogcalInputError, match="no such file"):
        load_log(tmp_path / "absent.mcap")


def test_metadata_truth_keeps_numbers_only():
    meta = {
        "logcal": {
            "robot": "tractor_trailer",
            "seed": "4",
            "L1": "1.25",
            "preset": "mixed",
            "sensor_offset.psi": "0.02",
            "bad": "nan",
        }
    }
    assert metadata_truth(meta) == {"L1": 1.25, "sensor_offset.psi": 0.02}
    assert metadata_truth({}) == {}
