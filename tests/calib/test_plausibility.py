"""Plausibility: answers no real machine gives are not determined, with the likely cause; a
plausible answer and a noise-free simulation are left alone."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from calib.adequacy import PhysicalRange, implausible, mark_implausible
from calib.results import CalibrationResult, Estimate
from logtools.cli.main import main

SAMPLES = Path(__file__).resolve().parents[2] / "sample_logs"

RANGE = PhysicalRange("L2", 0.1, 30.0, "m", "a unit")


def _result(l2: float) -> CalibrationResult:
    est = Estimate("L2", l2, 0.01, (l2 - 0.02, l2 + 0.02), True, "m")
    return CalibrationResult("fit", {"L2": est}, "This log determines L2.")


def test_a_length_outside_its_range_is_not_determined_and_says_why() -> None:
    found = implausible(_result(0.05), None, [RANGE])
    assert [f.quantity for f in found] == ["L2"]
    marked = mark_implausible(_result(0.05), found)
    assert marked.parameters["L2"].identifiable is False
    assert marked.verdict.startswith("Not determined: implausible")
    assert "a unit" in marked.verdict


def test_a_length_inside_its_range_is_left_alone() -> None:
    res = _result(2.5)
    assert implausible(res, None, [RANGE]) == []
    assert mark_implausible(res, []) is res


def _analyze(capsys: pytest.CaptureFixture[str], *args: str) -> dict[str, Any]:
    assert main(["analyze", *args, "--json", "--repeats", "1", "--no-discovery"]) == 0
    doc: dict[str, Any] = json.loads(capsys.readouterr().out)
    return doc


def test_a_joint_angle_read_in_the_wrong_unit_is_implausible(
    capsys: pytest.CaptureFixture[str],
) -> None:
    doc = _analyze(capsys, str(SAMPLES / "tt_mixed.mcap"), "--signal", "psi=/hitch/angle:angle:deg")
    est = doc["estimate"]
    assert est["verdict"].startswith("Not determined: implausible")
    assert "degrees" in est["verdict"]
    assert not est["L1"]["identifiable"]
    assert not est["L2"]["identifiable"]


@pytest.mark.parametrize("name", ["tt_mixed.mcap", "tt_harmonic_clean.mcap"])
def test_a_plausible_log_and_a_noise_free_one_are_not_flagged(
    name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    doc = _analyze(capsys, str(SAMPLES / name))
    assert "implausible" not in doc["estimate"]["verdict"]
    assert doc["estimate"]["L2"]["identifiable"]
