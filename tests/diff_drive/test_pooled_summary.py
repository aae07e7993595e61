"""The pooled differential-drive report shows each run's dead reckoning before and after and
UMBmark, and says plainly which runs calibration made worse (the JSON said it; the text hid it)."""

from __future__ import annotations

import io
import json

import pytest
from rich.console import Console

from logtools.cli.main import main
from logtools.report import print_analysis

from .conftest import REAL

SQUARE = REAL / "square"


@pytest.mark.skipif(not SQUARE.is_dir(), reason="shared real recordings not present")
def test_pooled_report_shows_each_runs_dead_reckoning_and_the_worse_ones(capsys) -> None:
    runs = sorted(p for p in SQUARE.glob("*/*_run-*.csv"))
    assert main(["analyze", "--json", *map(str, runs)]) == 0
    doc = json.loads(capsys.readouterr().out)
    rows = doc["dead_reckoning"]["runs"]
    worse = [
        r for r in rows if r["calibrated"]["end_point_error_m"] > r["nominal"]["end_point_error_m"]
    ]
    assert main(["analyze", *map(str, runs)]) == 0
    text = capsys.readouterr().out
    assert "Dead reckoning, end-point error nominal -> calibrated" in text
    for r in rows:
        assert r["run"].rsplit("/", 1)[-1] in text
    assert text.count("WORSE") == len(worse)
    if worse:
        assert f"worse on {len(worse)} of {len(rows)} run(s)" in text
    assert "UMBmark" in text


def test_summary_lines_flag_a_worse_run() -> None:
    from calib.results import AnalysisResult
    from logtools.robots.diff_drive.report import summary_lines

    res = AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=[],
        estimate=None,
        sections={
            "dead_reckoning": {
                "calibrated_with": "LSQ",
                "runs": [
                    {
                        "run": "a/run-1.csv",
                        "nominal": {"end_point_error_m": 0.1},
                        "calibrated": {"end_point_error_m": 0.02},
                    },
                    {
                        "run": "a/run-2.csv",
                        "nominal": {"end_point_error_m": 0.01},
                        "calibrated": {"end_point_error_m": 0.05},
                    },
                ],
            }
        },
    )
    lines = summary_lines(res)
    assert any("run-2.csv" in x and "WORSE" in x for x in lines)
    assert not any("run-1.csv" in x and "WORSE" in x for x in lines)
    assert "worse on 1 of 2 run(s): run-2.csv" in lines[-1]
    out = io.StringIO()
    print_analysis(res, Console(file=out, width=100), detail="answer")
    assert "WORSE" in out.getvalue()
