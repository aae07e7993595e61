"""A robot is a plugin: a new one needs its own module plus one registration, and then
``analyze`` (text and JSON), ``info`` and robot inference go through it. Shown with a small
plugin defined here (a pendulum whose only signal is ``theta``)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rich.text import Text

import logtools.robots as robots
from calib.results import AnalysisResult, CalibrationResult, Estimate, StageStatus
from logtools.cli.main import main
from logtools.load import LoadedLog
from logtools.robots import RobotPlugin, SignalSpec, plugin_for


def _analyze(loaded: LoadedLog, config: Any, progress: Any) -> AnalysisResult:
    theta = loaded.frame["theta"].to_numpy()
    mean, std = float(theta.mean()), float(theta.std(ddof=1) / np.sqrt(theta.size))
    est = Estimate("theta0", mean, std, (mean - 1.96 * std, mean + 1.96 * std), unit="rad")
    return AnalysisResult(
        robot="test_pendulum",
        segments=[],
        methods=[],
        estimate=CalibrationResult("mean", {"theta0": est}, "the mean angle"),
        source={"path": loaded.path},
        stages=[StageStatus("mean", "ok")],
        sections={"samples": int(theta.size)},
    )


PLUGIN = RobotPlugin(
    name="test_pendulum",
    title="test pendulum",
    signals=(SignalSpec("theta", "rad", "swing angle", required=True),),
    identify=lambda found: "signal theta" if "theta" in found else None,
    analyze=_analyze,
    report=lambda result: [Text(f"pendulum samples: {result.sections['samples']}")],
)


@pytest.fixture
def pendulum() -> Iterator[None]:
    saved = list(robots._registered)
    robots.register(PLUGIN)  # the one registration line
    yield
    robots._registered[:] = saved


def _csv(tmp_path: Path) -> Path:
    t = np.arange(200) * 0.01
    path = tmp_path / "swing.csv"
    rows = "\n".join(f"{a:.3f},{0.1 + 0.01 * np.sin(7 * a):.6f}" for a in t)
    path.write_text("t,theta\n" + rows + "\n")
    return path


@pytest.mark.usefixtures("pendulum")
def test_a_registered_plugin_is_found_analysed_and_reported(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _csv(tmp_path)
    assert main(["analyze", str(log), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["robot"] == "test_pendulum"
    assert doc["samples"] == 200
    assert doc["estimate"]["theta0"]["value"] == pytest.approx(0.1, abs=2e-3)
    assert "sum_L1_L2" not in doc["estimate"]
    assert main(["analyze", str(log), "--methods"]) == 0  # the plugin's own part: --methods
    text = capsys.readouterr().out
    assert "pendulum samples: 200" in text
    assert "theta0 = 0.1" in text
    assert main(["info", str(log)]) == 0
    info = capsys.readouterr().out
    assert "robot: test_pendulum (signal theta)" in info
    assert "test pendulum; it reads theta (rad)" in info


@pytest.mark.usefixtures("pendulum")
def test_views_missing_is_said_not_crashed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["analyze", str(_csv(tmp_path)), "--rrd", str(tmp_path / "o.rrd")]) == 0
    assert "has no rerun recording yet" in capsys.readouterr().err
    assert not (tmp_path / "o.rrd").exists()


def test_unknown_robot_type_names_the_known_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cmap = tmp_path / "map.toml"
    cmap.write_text('[robot]\ntype = "hovercraft"\n')
    assert main(["analyze", str(_csv(tmp_path)), "--channel-map", str(cmap)]) == 2
    err = capsys.readouterr().err
    assert "robot.type" in err
    assert "'hovercraft'" in err
    assert "tractor_trailer" in err


def test_plugin_lookup_by_alias_and_error_fields() -> None:
    assert plugin_for("tractor_trailer").title == "tractor with an off-axle trailer"
    with pytest.raises(robots.UnknownRobotError) as info:
        plugin_for("hovercraft", where="somewhere")
    assert info.value.name == "hovercraft"
    assert "tractor_trailer" in info.value.known
