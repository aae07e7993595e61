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


def _diff_drive_rrd(out: Path, labels: tuple[str, ...] = ("nominal", "calibrated")) -> Path:
    t = np.linspace(0.0, 1.0, 20)
    result = AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=[],
        estimate=None,
        source={"path": "/logs/square_run-01.csv"},
        artifacts={
            "trajectories": {"/logs/square_run-01.csv": {k: {"x": t, "y": t} for k in labels}}
        },
    )
    frame = pl.DataFrame({"t_ns": np.arange(3, dtype=np.int64)})
    return log_views(out, SimpleNamespace(frame=frame, log=SimpleNamespace(topics={})), result)


def test_each_robot_waits_for_its_own_colours(case, tmp_path: Path) -> None:
    tractor = write_recording(tmp_path / "tt.rrd", case.frame, case.result)
    assert ready_colors_of(tractor) == ("C1", "C2", "kappa")
    assert ready_colors_of(_diff_drive_rrd(tmp_path / "dd.rrd")) == ("dd_nominal", "dd_calibrated")


def test_a_colour_the_recording_does_not_draw_is_not_waited_for(tmp_path: Path) -> None:
    """A diff drive without a calibrated path (its fit did not run): the screenshot waits for
    the nominal path only (it waited for the calibrated one until its timeout)."""
    rrd = _diff_drive_rrd(tmp_path / "dd.rrd", labels=("nominal",))
    assert ready_colors_of(rrd) == ("dd_nominal",)


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


def _arm_rrd(out: Path) -> Path:
    from viz.manipulator.views import log_views as arm_views

    t = np.linspace(0.0, 1.0, 4)
    pts = np.stack([np.zeros((4, 3)), np.c_[np.cos(t), np.sin(t), 0 * t]], axis=1)
    torque = np.c_[np.sin(t), np.cos(t)]
    result = AnalysisResult(
        robot="manipulator",
        segments=[],
        methods=[],
        estimate=None,
        source={"path": "/logs/arm.mcap"},
        artifacts={
            "t_s": t,
            "points": pts,
            "holdout_t_s": t,
            "holdout_measured": torque,
            "holdout_predicted": torque,
            "joint_names": ["j1", "j2"],
        },
    )
    frame = pl.DataFrame({"t_ns": np.arange(3, dtype=np.int64)})
    return arm_views(out, SimpleNamespace(frame=frame, log=SimpleNamespace(topics={})), result)


def _colours_by_archetype(rrd: Path) -> dict[str, set[tuple[int, int, int]]]:
    """Archetype ("LineStrips3D", "Points3D", ...) -> the RGB colours it is logged with."""
    out: dict[str, set[tuple[int, int, int]]] = {}
    for chunk in rr.chunk.RrdReader(rrd).stream().to_chunks():
        rb = chunk.to_record_batch()
        for name in rb.schema.names:
            if not name.endswith(":colors"):
                continue
            for row in rb.column(name).to_pylist():
                for packed in row or []:
                    rgb = ((packed >> 24) & 255, (packed >> 16) & 255, (packed >> 8) & 255)
                    out.setdefault(name.split(":")[0], set()).add(rgb)
    return out


@pytest.mark.parametrize("robot", ["tractor_trailer", "diff_drive", "manipulator"])
def test_every_robot_waits_only_for_colours_its_recording_draws_flat(
    robot: str, case, tmp_path: Path
) -> None:
    """A ready colour must be drawn by a flat archetype (lines, 2-D points, plot lines): rerun
    shades 3-D points as spheres, so their exact colour may cover no pixel (the arm's joints:
    the screenshot waited for them until its timeout)."""
    from viz.style import COLORS

    rrd = {
        "tractor_trailer": lambda p: write_recording(p, case.frame, case.result),
        "diff_drive": _diff_drive_rrd,
        "manipulator": _arm_rrd,
    }[robot](tmp_path / f"{robot}.rrd")
    drawn = _colours_by_archetype(rrd)
    flat = set().union(*(c for kind, c in drawn.items() if kind != "Points3D"))
    ready = ready_colors_of(rrd)
    assert len(ready) >= 2  # two of its own panels drew, not the viewer's own UI
    assert [n for n in ready if tuple(COLORS[n]) not in flat] == []
    if robot == "manipulator":  # the joints are shaded 3-D points: never waited for
        assert tuple(COLORS["arm_joints"]) in drawn["Points3D"]
        assert "arm_joints" not in ready
