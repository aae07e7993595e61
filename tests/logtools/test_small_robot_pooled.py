"""Acceptance run: a small ROS 2 tractor-trailer (steering-angle /cmd_vel, hitch 2 cm
ahead of the axle, trailer mocap on /odom with a zero twist, recorder stalls), written as real
rosbag2 .db3 folders by the independent generator and read with the README's channel map.

One fixed seed: a check that the whole chain works on this robot class, not a coverage claim
(bench/path_coverage_study.py measures coverage).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from indgen import generate, small_robot_scenario, write_rosbag2

from logtools.analyze import AnalysisConfig, analyze_logs
from logtools.channel_map import load_channel_map

README = Path(__file__).resolve().parents[2] / "README.md"


def _readme_map(tmp_path: Path) -> Path:
    text = README.read_text(encoding="utf-8")
    m = re.search(r"```toml\n(# truck\.toml.*?)```", text, re.S)
    assert m, "the README's worked ROS example (truck.toml) is missing"
    p = tmp_path / "truck.toml"
    p.write_text(m.group(1), encoding="utf-8")
    return p


@pytest.mark.slow
def test_four_runs_pooled_and_a_run_that_did_not_move(tmp_path: Path) -> None:
    runs = []
    for k in range(5):
        scn = small_robot_scenario(np.random.default_rng(100 + k), barely_moves=(k == 4))
        folder = tmp_path / f"rosbag2_run{k}"
        write_rosbag2(folder, generate(scn, seed=k), storage="sqlite3")
        assert any(folder.glob("*.db3"))
        runs.append(folder)
    cmap = load_channel_map(_readme_map(tmp_path))
    _, res = analyze_logs(runs, channel_map=cmap, config=AnalysisConfig(repeats=1))
    est = res.estimate
    assert est is not None
    L1, L2 = est.parameters["L1"], est.parameters["L2"]
    assert L2.value == pytest.approx(0.537, rel=0.05)
    # whether the interval covers L1 = -0.02 is a coverage claim: bench/path_coverage_study.py
    assert L1.ci95[0] <= L1.value <= L1.ci95[1]
    assert res.source["runs_pooled"] == 4
    still = res.runs[4]
    assert still.estimate is None
    assert any("did not move" in s.reason for s in still.stages)
    for run in res.runs[:4]:
        assert run.source["path_source"] == "pose"
        stages = {s.stage: s for s in run.stages}
        assert stages["command-driven discovery"].status in ("ok", "skipped")
    doc = res.to_dict()
    assert doc["estimate"]["L2"]["value"] == pytest.approx(L2.value)
    assert len(doc["runs"]) == 5


def test_a_topic_mapped_to_the_trailer_is_not_also_the_tractor(tmp_path: Path) -> None:
    """/odom mapped to the trailer pose (x2, y2, yaw2): its pose must not also be read as the
    tractor's (x, y, yaw) by the default ROS names."""
    from logtools.load import load_log

    text = _readme_map(tmp_path).read_text(encoding="utf-8")
    text = re.sub(r"\[signals\.(x|y|yaw)\][^\[]*", "", text)  # no tractor pose
    cmap_path = tmp_path / "trailer_only.toml"
    cmap_path.write_text(text, encoding="utf-8")
    scn = small_robot_scenario(np.random.default_rng(100))
    folder = tmp_path / "rosbag2_run"
    write_rosbag2(folder, generate(scn, seed=0), storage="sqlite3")
    loaded = load_log(folder, load_channel_map(cmap_path))
    assert {"x2", "y2", "yaw2"} <= set(loaded.signals.signals)
    assert "x" not in loaded.signals.signals
