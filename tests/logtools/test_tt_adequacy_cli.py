"""``logcal analyze --json`` of tractor-trailer logs carries the adequacy of the recommended
estimate (top-level ``adequacy``) and discovery along the measured path (``discovery`` when the
command-driven discovery did not run, else ``path_discovery``)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from indgen import Effects, generate, random_scenario, write_mcap_json

from logtools.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT / ".." / "shared"


def _analyze(path: Path, capsys: pytest.CaptureFixture[str], *extra: str) -> dict[str, Any]:
    code = main(["analyze", str(path), "--json", "--repeats", "1", *extra])
    assert code == 0
    out: dict[str, Any] = json.loads(capsys.readouterr().out)
    return out


def _covers(est: dict[str, Any], truth: float) -> bool:
    return (not est["identifiable"]) or est["ci95"][0] <= truth <= est["ci95"][1]


def test_clean_sample_log_is_explained(capsys: pytest.CaptureFixture[str]) -> None:
    doc = _analyze(ROOT / "sample_logs" / "tt_mixed.mcap", capsys)
    assert doc["adequacy"]["verdict"] == "explains"
    assert doc["adequacy"]["channels"][0]["heldout_ratio"] is not None
    assert doc["estimate"]["identifiable"]
    assert doc["path_discovery"]["engine"] == "path"  # command-driven discovery ran too
    assert doc["path_discovery"]["accepted"] == []
    for name in ("L1", "L2"):
        assert _covers(doc["estimate"][name], doc["truth"][name])


def test_psi_offset_log_names_the_offset(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rng = np.random.default_rng(26)
    scn = random_scenario(rng, L1=0.8, L2=1.6, duration_s=60.0)
    scn = dataclasses.replace(scn, effects=Effects(sensor_offset={"psi": 0.035}))
    log = tmp_path / "offset.mcap"
    write_mcap_json(log, generate(scn, seed=3))
    doc = _analyze(log, capsys)
    ad = doc["adequacy"]
    assert ad["before"]["model"] == "transient path"
    assert ad["before"]["verdict"] == "does not explain"
    assert ad["verdict"] == "explains"
    assert "sensor_offset(psi)" in ad["model"]
    found = doc["path_discovery"]
    assert "sensor_offset(psi)" in found["accepted"]
    assert abs(found["effects"]["sensor_offset(psi)"]["offset"]["value"] - 0.035) < 0.002
    assert "sensor_offset(psi)" in doc["estimate"]["method"]
    for name in ("L1", "L2"):
        assert _covers(doc["estimate"][name], {"L1": 0.8, "L2": 1.6}[name])


def test_short_log_is_judged_without_discovery(capsys: pytest.CaptureFixture[str]) -> None:
    doc = _analyze(ROOT / "sample_logs" / "tt_mixed.mcap", capsys, "--no-discovery")
    assert doc["adequacy"]["verdict"] == "explains"
    assert "path_discovery" not in doc
    assert doc["discovery"] is None


def _real_runs() -> list[Path]:
    """Real tractor-trailer recordings under ../shared (rosbag2 folders or ROS 1 bags with the
    truck's hitch encoder), with a channel map beside them named truck.toml."""
    if not SHARED.is_dir():
        return []
    found = []
    for meta in sorted(SHARED.rglob("metadata.yaml")):
        text = meta.read_text(errors="replace")
        if "/encoder/angle" in text and (meta.parent.parent / "truck.toml").exists():
            found.append(meta.parent)
    return found


@pytest.mark.slow
@pytest.mark.skipif(not _real_runs(), reason="no real tractor-trailer recording in ../shared")
def test_real_run_is_never_confidently_wrong(capsys: pytest.CaptureFixture[str]) -> None:
    run = _real_runs()[0]
    doc = _analyze(run, capsys, "--channel-map", str(run.parent / "truck.toml"))
    ad = doc["adequacy"]
    assert ad["verdict"] in ("explains", "does not explain")
    if ad["verdict"] == "does not explain":
        assert not doc["estimate"]["identifiable"]
        assert not doc["estimate"]["sum_L1_L2"]["identifiable"]
