"""What a person sees in the viewer, checked on the recording itself: lines that read on the
light theme and on the dark one (the ground truth was white, invisible on the light theme), planes
drawn with y up (rerun's 2-D views draw y down), grid labels apart, and screenshots that wait
only for colours the viewer draws flat (the arm's shaded joints made it time out)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import polars as pl
import pytest
from rerun.chunk import RrdReader

from calib.results import AnalysisResult
from viz.diff_drive.views import grid_labels, log_views
from viz.manipulator import style as _arm_style  # noqa: F401  (registers its colours)
from viz.style import COLORS, MIN_LINE_CONTRAST, THEME_BACKGROUNDS, contrast_ratio, y_up_bounds
from viz.tractor_trailer.recording import write_recording

#: Neutral colours drawn as lines or paths in the viewer (the others are Okabe-Ito colours).
LINE_NEUTRALS = ("truth", "links", "arm_measured")


def _dd_result(paths: dict[str, dict[str, np.ndarray]]) -> AnalysisResult:
    return AnalysisResult(
        robot="diff_drive",
        segments=[],
        methods=[],
        estimate=None,
        source={"path": "/logs/run-01.csv"},
        artifacts={"trajectories": {"/logs/run-01.csv": paths}},
    )


def _dd_rrd(out: Path, paths: dict[str, dict[str, np.ndarray]]) -> Path:
    frame = pl.DataFrame({"t_ns": np.arange(3, dtype=np.int64)})
    loaded = SimpleNamespace(frame=frame, log=SimpleNamespace(topics={}))
    return log_views(out, loaded, _dd_result(paths))


def _static(rrd: Path) -> dict[str, dict[str, object]]:
    """Entity path -> static component -> its last value."""
    out: dict[str, dict[str, object]] = {}
    for chunk in RrdReader(rrd).stream().to_chunks():
        if not chunk.is_static:
            continue
        rb = chunk.to_record_batch()
        comps = out.setdefault(chunk.entity_path, {})
        for name in rb.schema.names:
            if ":" in name:
                comps[name] = rb.column(name).to_pylist()[-1]
    return out


@pytest.mark.parametrize("name", LINE_NEUTRALS)
@pytest.mark.parametrize("theme", sorted(THEME_BACKGROUNDS))
def test_neutral_lines_read_on_both_themes(name: str, theme: str) -> None:
    assert contrast_ratio(COLORS[name], THEME_BACKGROUNDS[theme]) >= MIN_LINE_CONTRAST


def test_contrast_ratio_is_wcags() -> None:
    assert contrast_ratio((0, 0, 0), (255, 255, 255)) == pytest.approx(21.0)
    assert contrast_ratio((250, 250, 250), (255, 255, 255)) < 1.1  # the old truth: unseen
    assert contrast_ratio((119, 119, 119), (255, 255, 255)) == pytest.approx(4.48, abs=0.01)


def test_the_diff_drives_truth_is_drawn_grey_and_wider(tmp_path: Path) -> None:
    t = np.linspace(0.0, 1.0, 5)
    rrd = _dd_rrd(tmp_path / "dd.rrd", {"truth": {"x": t, "y": t}, "nominal": {"x": t, "y": 0 * t}})
    ents = _static(rrd)
    truth, nominal = ents["/world/run-01/truth"], ents["/world/run-01/nominal"]
    r, g, b = COLORS["truth"]
    assert truth["LineStrips2D:colors"] == [(r << 24) | (g << 16) | (b << 8) | 0xFF]
    # radii in ui points are negative: the truth, drawn under the others, is the wider line
    assert abs(truth["LineStrips2D:radii"][0]) > abs(nominal["LineStrips2D:radii"][0])


def test_each_robots_plane_is_drawn_with_y_up(tmp_path: Path, case) -> None:
    t = np.linspace(0.0, 1.0, 5)
    dd = _static(_dd_rrd(tmp_path / "dd.rrd", {"truth": {"x": t, "y": t}}))
    tt = _static(write_recording(tmp_path / "tt.rrd", case.frame, case.result))
    for ents in (dd, tt):
        scale = np.asarray(ents["/world"]["Transform3D:scale"], dtype=float).ravel()
        assert scale.tolist() == [1.0, -1.0, 1.0]


def test_y_up_bounds_mirror_the_planes_y_range() -> None:
    assert y_up_bounds((0.0, 2.0), (-1.0, 3.0)) == ((0.0, 2.0), (-3.0, 1.0))


def test_the_grids_corner_has_one_label_naming_both_coordinates() -> None:
    anchors, labels = grid_labels([0.0, 0.5, 1.0], [-1.0, 0.0])
    assert labels == ["x 0 m, y -1 m", "x 0.5 m", "x 1 m", "y 0 m"]
    assert len({tuple(a) for a in anchors}) == len(anchors)  # no two labels at one place
    assert anchors[0] == [0.0, -1.0]
