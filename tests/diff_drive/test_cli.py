"""CLI: exit codes of ``simulate diff-drive`` and ``reproduce wmr``; discovery names the
concealed effects of the logs it writes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from logtools.cli.main import launch


def test_simulate_diff_drive_writes_a_log_and_refuses_bad_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "dd.mcap"
    assert launch(["simulate", "diff-drive", "--out", str(out), "--duration", "30"]) == 0
    assert out.stat().st_size > 0
    assert launch(["simulate", "diff-drive", "--out", str(out), "--radius", "0"]) == 2
    assert "--radius 0.0: expected > 0 m" in capsys.readouterr().err


def test_reproduce_wmr_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert launch(["reproduce", "wmr", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    names = [r["name"] for r in rows]
    assert "planned, case 2" in names
    assert any(n.startswith("feedback only") for n in names)
    case2 = next(r for r in rows if r["name"] == "planned, case 2")
    assert case2["ours"]["t_heading_s"] == 0.0  # no offset: the straight line, nothing to settle


@pytest.mark.parametrize(
    ("options", "effect"),
    [
        (["--asymmetry", "0.01"], "wheel_radius_asymmetry"),
        (["--skid", "1.3", "--gyro"], "effective_track"),
    ],
)
def test_discovery_names_concealed_effects(tmp_path: Path, options: list[str], effect: str) -> None:
    from logtools.analyze import analyze_log

    out = tmp_path / "c.mcap"
    args = ["simulate", "diff-drive", "--out", str(out), "--conceal", "--seed", "3", *options]
    assert launch(args) == 0
    _, result = analyze_log(out)
    assert "track_width" not in result.truth
    assert [k.split("(")[0] for k in result.discovery.named] == [effect]
