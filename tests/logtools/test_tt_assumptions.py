"""The recommended tractor-trailer estimate says what its intervals take as given: on the sample
log the joint angle's gain is bounded by the log within its tolerance, so the link lengths'
intervals are those at gain 1, and the verdict says so with the lengths were the gain left free
(wider: a gain trades with L1 + L2)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from logtools.cli.main import main

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_gain_assumption_is_stated_with_the_free_gain_lengths(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(["analyze", str(ROOT / "sample_logs" / "tt_mixed.mcap"), "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    est = doc["estimate"]
    path = doc["path_discovery"]
    assert len(path["assumptions"]) == 1
    assumption = path["assumptions"][0]
    assert assumption.startswith("the joint angle's gain is 1")
    assert "These intervals assume " + assumption in est["verdict"]
    bound = re.search(r"bounds it only to \[([-\d.e]+), ([-\d.e]+)\]", assumption)
    assert bound is not None
    lo, hi = float(bound.group(1)), float(bound.group(2))
    assert lo < 1.0 < hi
    assert hi - lo < 2 * 0.05  # bounded within the 5 % tolerance
    free = re.search(r"L1 = ([-\d.e]+) m \[([-\d.e]+), ([-\d.e]+)\]", assumption)
    assert free is not None
    free_width = float(free.group(3)) - float(free.group(2))
    held_width = est["L1"]["ci95"][1] - est["L1"]["ci95"][0]
    assert free_width > 3 * held_width
    assert est["assumptions"] == ["the joint angle's gain is 1"]


@pytest.mark.slow
def test_pooled_windows_keep_the_assumption_every_window_makes(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code = main(
        ["analyze", str(ROOT / "sample_logs" / "tt_mixed.mcap"), "--json", "--window", "80"]
    )
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    runs = [r["estimate"] for r in doc["runs"]]
    assert len(runs) == 3
    assert all(r["assumptions"] == ["the joint angle's gain is 1"] for r in runs)
    est = doc["estimate"]
    assert est["assumptions"] == ["the joint angle's gain is 1"]
    assert est["verdict"].endswith(
        "These intervals assume the joint angle's gain is 1, as each window's do."
    )
