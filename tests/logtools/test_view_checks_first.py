"""``logcal view`` says there is no display (or no viewer) before any work (issue 33, item 5):
the message is out before the log is read or analysed, so a user can stop there."""

from __future__ import annotations

from pathlib import Path

import logtools.analyze
from logtools.cli.main import main

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed.csv"


class AnalysisStartedError(Exception):
    """Raised where the analysis would start."""


def _no_analysis(*args: object, **kwargs: object) -> None:
    raise AnalysisStartedError


def test_no_display_is_said_before_the_analysis(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    monkeypatch.setattr(logtools.analyze, "analyze_logs", _no_analysis)
    assert main(["view", str(SAMPLE), "--rrd", str(tmp_path / "v.rrd")]) == 1
    said = capsys.readouterr()
    assert "AnalysisStartedError" in said.err  # the analysis was reached, after the message
    assert "no display here" in said.out


def test_no_viewer_installed_is_said_before_the_analysis(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.setenv("DISPLAY", ":0")
    real = __import__("importlib.util").util.find_spec
    monkeypatch.setattr(
        "importlib.util.find_spec", lambda name, *a: None if name == "rerun" else real(name, *a)
    )
    monkeypatch.setattr(logtools.analyze, "analyze_logs", _no_analysis)
    assert main(["view", str(SAMPLE), "--rrd", str(tmp_path / "v.rrd")]) == 1
    said = capsys.readouterr()
    assert "AnalysisStartedError" in said.err  # the analysis was reached, after the message
    assert "no rerun viewer is installed" in said.out


def test_no_viewer_flag_says_nothing_of_a_display(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr(logtools.analyze, "analyze_logs", _no_analysis)
    assert main(["view", str(SAMPLE), "--rrd", str(tmp_path / "v.rrd"), "--no-viewer"]) == 1
    said = capsys.readouterr()
    assert "AnalysisStartedError" in said.err  # the analysis was reached, after the message
    assert "display" not in said.out
