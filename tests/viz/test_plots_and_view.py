"""The static PNG report, the viewer launch decision and ``logcal view``."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from matplotlib import image as mpimg
from rrd_read import read_rrd

from viz import viewer
from viz.style import COLORS
from viz.tractor_trailer.plots import write_report_png

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed.csv"


def _has_color(img: np.ndarray, name: str, tol: int = 12) -> bool:
    px = np.round(img[..., :3] * 255).astype(int).reshape(-1, 3)
    return bool((np.abs(px - np.array(COLORS[name])).max(axis=1) <= tol).any())


def test_report_png_shows_paths_series_and_bars(case, tmp_path):
    out = write_report_png(tmp_path / "sub" / "report.png", case.frame, case.result, dpi=80)
    img = mpimg.imread(out)
    assert img.shape[:2] == (10 * 80, 16 * 80)
    for name in ("C1", "P", "C2", "O", "psi", "kappa_cmd"):
        assert _has_color(img, name), name


def test_report_png_without_pose(case, tmp_path):
    out = write_report_png(tmp_path / "r.png", case.frame.select("t_ns", "psi"), case.result)
    assert out.stat().st_size > 0


def test_viewer_only_with_a_display(monkeypatch):
    monkeypatch.setattr(viewer.sys, "platform", "linux")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert not viewer.can_start_viewer()
    assert viewer.open_viewer("x.rrd") is None
    monkeypatch.setenv("DISPLAY", ":0")
    assert viewer.can_start_viewer()


@pytest.mark.slow  # the whole analysis of a sample log, then a .rrd
def test_cli_view_saves_and_says_where(tmp_path, monkeypatch, capsys):
    from logtools.cli.main import main

    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    log = tmp_path / SAMPLE.name
    shutil.copy(SAMPLE, log)
    assert main(["view", str(log), "--repeats", "2"]) == 0
    out = log.with_suffix(".rrd")
    assert str(out) in capsys.readouterr().out
    ents, n_bp = read_rrd(out)
    assert n_bp == 1
    assert {"/world/icr", "/signals/psi/measured"} <= set(ents)
    assert any(e.startswith("/methods/all/") for e in ents)
    assert main(["view", str(log), "--rrd", str(tmp_path / "o.rrd"), "--method", "nope"]) == 2
