"""The report's answer first and whole (issue 33, items 2 and 3): discovery's named effects and
its verdict before -> after are never cut behind "--methods"; ``--quiet`` prints the answer
without the signal list; a report written to a file or a pipe is not wrapped at 80 columns."""

from __future__ import annotations

import io
import re

from calib.discovery.report import DiscoveryReport, FoundEffect
from calib.results import AnalysisResult, CalibrationResult, Estimate
from logtools.console import report_console
from logtools.report import SHORT_DISCOVERY, _discovery_lines, print_analysis

DELAY = Estimate("clock_offset(odom)", 0.301, 0.0056, (0.290, 0.312), unit="s")
LONG_NAME = "Transient-path with a method name long enough to be cut in a narrow column"


def _discovery(n_more: int) -> DiscoveryReport:
    effect = FoundEffect(
        "clock_offset(odom)", "clock_offset", "odom", "clock", "named", "a late clock", "odom",
        {DELAY.name: DELAY}, 12.0, -40.0,
    )  # fmt: skip
    return DiscoveryReport(
        "tractor_trailer",
        "the nominal model",
        (effect,),
        more=tuple(f"  miss region {i}: residual above its floor" for i in range(n_more)),
    )


def _result() -> AnalysisResult:
    est = Estimate("L1", 1.25, 0.002, (1.246, 1.254))
    return AnalysisResult(
        robot="tractor_trailer",
        segments=[],
        methods=[],
        estimate=CalibrationResult(LONG_NAME, {"L1": est}, "ok"),
        discovery=_discovery(3 * SHORT_DISCOVERY),
        source={
            "path": "run.mcap",
            "duration_s": 249.0,
            "samples": 4980,
            "signals": {"psi": "/hitch/angle:angle", "v": "/odom:v"},
        },
    )


def test_the_named_effect_shows_however_long_the_engines_details() -> None:
    lines = _discovery_lines(_discovery(3 * SHORT_DISCOVERY), "answer")
    assert any("named clock_offset(odom)" in x and "0.301" in x for x in lines)
    assert sum("miss region" in x for x in lines) == SHORT_DISCOVERY
    assert lines[-1] == "... (the engines' details: --methods)"
    assert sum("miss region" in x for x in _discovery_lines(_discovery(20), "methods")) == 20
    quiet = _discovery_lines(_discovery(20), "quiet")
    assert not any("miss region" in x for x in quiet)
    assert any("0.301" in x for x in quiet)


def test_quiet_prints_the_answer_without_the_signal_list() -> None:
    out = io.StringIO()
    print_analysis(_result(), console=report_console(file=out), detail="quiet")
    text = out.getvalue()
    assert "robot: tractor_trailer" in text
    assert "L1 = 1.25" in text
    assert "clock_offset(odom)" in text
    assert "signals:" not in text
    assert "miss region" not in text


def test_a_report_to_a_file_is_not_wrapped(monkeypatch) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)
    out = io.StringIO()  # not a terminal, as with "> file" or "| cat"
    print_analysis(_result(), console=report_console(file=out), detail="quiet")
    lines = out.getvalue().splitlines()
    assert lines[0].startswith("run.mcap")
    assert lines[0].rstrip().endswith("samples: 4980")
    assert any(LONG_NAME in x for x in lines)  # the method's name whole, on one line
    assert max(len(x) for x in lines) > 80


def test_a_terminal_keeps_its_width(monkeypatch) -> None:
    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    monkeypatch.setenv("COLUMNS", "80")
    out = Terminal()
    print_analysis(_result(), console=report_console(file=out), detail="quiet")
    plain = re.sub(r"\x1b\[[0-9;]*m", "", out.getvalue())  # a terminal's colours
    assert max(len(x) for x in plain.splitlines()) <= 80


def test_the_cli_writes_unwrapped_lines_to_a_pipe(capsys, monkeypatch) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)
    from logtools.report import print_analysis as printed

    printed(_result(), detail="quiet")  # stdout captured: not a terminal
    assert capsys.readouterr().out.splitlines()[0].rstrip().endswith("samples: 4980")


def test_each_run_is_one_line_in_a_file(monkeypatch) -> None:
    monkeypatch.delenv("COLUMNS", raising=False)

    def run(name: str, value: float) -> AnalysisResult:
        est = Estimate("L1", value, 0.002, (value - 0.004, value + 0.004))
        return AnalysisResult(
            "tractor_trailer", [], [], CalibrationResult("LSQ", {"L1": est}, "ok"),
            source={"path": f"/logs/{name}"},
        )  # fmt: skip

    pooled = AnalysisResult(
        "tractor_trailer", [], [], None, runs=[run("run-01.csv", 1.25), run("run-02.csv", 1.26)]
    )  # fmt: skip
    out = io.StringIO()
    print_analysis(pooled, console=report_console(file=out), detail="quiet")
    (row,) = [x for x in out.getvalue().splitlines() if "run-02.csv" in x]
    assert "1.26 [1.256, 1.264]" in row
