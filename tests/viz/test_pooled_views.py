"""A pooled analysis's ``.rrd``: one recording per run and one for the pooled answer, each under
its own application id with its own blueprint (rerun keeps one layout per application id: with
one id for all, every run was shown through the last run's layout: its title, its path panel's
entity ("No data") and the table of whichever run was open)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import polars as pl
import pytest
from rerun.chunk import RrdReader

from calib.results import AnalysisResult, CalibrationResult, Estimate
from logtools.views import write_views


@pytest.fixture(autouse=True)
def _diff_drive_plugin() -> None:
    from logtools.robots import plugins, register
    from logtools.robots.diff_drive import PLUGIN

    if not any(p.name == "diff_drive" for p in plugins()):
        register(PLUGIN)


def _run(name: str, track_m: float) -> tuple[SimpleNamespace, AnalysisResult]:
    """A one-run result whose path and track width are its own (``track_m``)."""
    t = np.linspace(0.0, 2 * np.pi, 50)
    path = {"x": np.cos(t) * track_m * 10, "y": np.sin(t)}
    est = Estimate("track_width", track_m, 1e-4, (track_m - 2e-4, track_m + 2e-4))
    result = AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=[CalibrationResult("LSQ", {"track_width": est}, "ok")],
        estimate=None,
        source={"path": f"/logs/{name}.csv"},
        artifacts={"trajectories": {f"/logs/{name}.csv": {"truth": path}}},
    )
    frame = pl.DataFrame({"t_ns": np.arange(3, dtype=np.int64) * 10**8})
    return SimpleNamespace(frame=frame, log=SimpleNamespace(topics={})), result


def _pooled(runs: list[AnalysisResult]) -> AnalysisResult:
    est = Estimate("track_width", 0.2005, 1e-4, (0.2003, 0.2007))
    trajectories = {k: v for r in runs for k, v in r.artifacts["trajectories"].items()}
    return AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=[CalibrationResult("LSQ", {"track_width": est}, "ok")],
        estimate=None,
        runs=runs,
        artifacts={"trajectories": trajectories},
    )


def _contents(rrd: Path) -> dict[str, tuple[set[str], str]]:
    """application id -> (entity paths under world/, the methods table's text)."""
    reader = RrdReader(rrd)
    out: dict[str, tuple[set[str], str]] = {}
    for store in reader.recordings():
        world: set[str] = set()
        text: dict[str, str] = defaultdict(str)
        for chunk in reader.stream(store=store).to_chunks():
            if chunk.entity_path.startswith("/world/"):
                world.add(chunk.entity_path.split("/")[2])
            if chunk.entity_path == "/methods":
                rb = chunk.to_record_batch()
                text["methods"] = str(rb.column("TextDocument:text").to_pylist()[-1])
        out[store.application_id] = (world, text["methods"])
    return out


def test_each_run_and_the_pooled_answer_have_their_own_recording(tmp_path: Path) -> None:
    (lo1, r1), (lo2, r2) = _run("run-01", 0.2010), _run("run-02", 0.1990)
    written = write_views([lo1, lo2], _pooled([r1, r2]), rrd=tmp_path / "p.rrd", png=None)
    assert written.rrd is not None
    contents = _contents(written.rrd)
    assert set(contents) == {
        "logcal_diff_drive_run-01",
        "logcal_diff_drive_run-02",
        "logcal_diff_drive_pooled_2_runs",
    }
    assert contents["logcal_diff_drive_run-01"][0] == {"run-01"}
    assert contents["logcal_diff_drive_run-02"][0] == {"run-02"}
    assert contents["logcal_diff_drive_pooled_2_runs"][0] == {"run-01", "run-02"}
    assert "201.000" in contents["logcal_diff_drive_run-01"][1]
    assert "199.000" in contents["logcal_diff_drive_run-02"][1]
    assert "200.500" in contents["logcal_diff_drive_pooled_2_runs"][1]
    start = "Time: seconds from the log's start, its clock starts at 0.000 s."
    assert start in contents["logcal_diff_drive_run-01"][1]  # the timeline's zero, once
    assert "log's start" not in contents["logcal_diff_drive_pooled_2_runs"][1]
    blueprints = {b.application_id for b in RrdReader(written.rrd).blueprints()}
    assert blueprints == set(contents)  # each recording's layout is its own
    assert "and the pooled answer" in written.messages[0][1]


def test_each_path_view_has_a_labelled_metric_grid(tmp_path: Path) -> None:
    """The 2D path view has no axes of its own: grid lines labelled in metres give its scale."""
    from viz.diff_drive.views import grid_lines

    step, gx, gy = grid_lines({"a": {"x": np.array([0.0, 1.7]), "y": np.array([-1.7, 0.05])}})
    assert step == 0.5
    assert gx == [0.0, 0.5, 1.0, 1.5, 2.0]
    assert gy == [-2.0, -1.5, -1.0, -0.5, 0.0, 0.5]
    lo, res = _run("run-01", 0.2)
    written = write_views([lo], res, rrd=tmp_path / "one.rrd", png=None)
    assert written.rrd is not None
    labels = []
    for chunk in RrdReader(written.rrd).stream().to_chunks():
        if chunk.entity_path == "/world/run-01/grid/labels":
            labels = chunk.to_record_batch().column("Points2D:labels").to_pylist()[-1]
    assert "x 0 m" in labels
    assert any(x.startswith("y ") and x.endswith(" m") for x in labels)
