"""The screenshot waits for the recorded robot's own colours (it waited for the tractor's on
every robot's recording and failed after its timeout on a differential drive's)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import polars as pl
import pytest
import rerun as rr

from calib.results import AnalysisResult
from viz.diff_drive.views import log_views
from viz.screenshot import ViewerScreenshotError, ready_colors_of
from viz.style import robot_of_application_id
from viz.tractor_trailer.recording import write_recording


def _diff_drive_rrd(out: Path) -> Path:
    t = np.linspace(0.0, 1.0, 20)
    result = AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=[],
        estimate=None,
        source={"path": "/logs/square_run-01.csv"},
        artifacts={"trajectories": {"/logs/square_run-01.csv": {"nominal": {"x": t, "y": t}}}},
    )
    frame = pl.DataFrame({"t_ns": np.arange(3, dtype=np.int64)})
    return log_views(out, SimpleNamespace(frame=frame, log=SimpleNamespace(topics={})), result)


def test_each_robot_waits_for_its_own_colours(case, tmp_path: Path) -> None:
    tractor = write_recording(tmp_path / "tt.rrd", case.frame, case.result)
    assert ready_colors_of(tractor) == ("C1", "C2", "kappa")
    assert ready_colors_of(_diff_drive_rrd(tmp_path / "dd.rrd")) == ("dd_nominal", "dd_calibrated")


def test_the_robot_is_read_from_the_application_id() -> None:
    assert robot_of_application_id("logcal_tractor_trailer_tt_mixed") == "tractor_trailer"
    assert robot_of_application_id("logcal_diff_drive_pooled_6_runs") == "diff_drive"
    assert robot_of_application_id("logcal_manipulator") == "manipulator"
    assert robot_of_application_id("someone_else") is None


def test_a_recording_of_no_logcal_robot_is_refused(tmp_path: Path) -> None:
    out = tmp_path / "other.rrd"
    rec = rr.RecordingStream("someone_else")
    rec.save(out)
    rec.log("x", rr.Points2D([[0.0, 0.0]]))
    rec.flush()
    rec.disconnect()
    with pytest.raises(ViewerScreenshotError, match="someone_else"):
        ready_colors_of(out)


@pytest.mark.parametrize("script", ["readme_screenshots.py", "screenshot_rrd.py"])
def test_screenshot_scripts_name_no_path_outside_the_repository(script: str) -> None:
    import ast

    source = Path(__file__).resolve().parents[2] / "scripts" / script
    strings = [
        n.value
        for n in ast.walk(ast.parse(source.read_text()))
        if isinstance(n, ast.Constant) and isinstance(n.value, str)
    ]
    assert not [s for s in strings if s.startswith(("/", "~")) or "/work/" in s]
