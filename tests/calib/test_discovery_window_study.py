"""bench/discovery_window_study.py: a one-log random slice runs both modes and tabulates.
Deterministic facts only (which span each mode used, the table's rows); the study's numbers are
in its own output."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from bench_scripts import load_bench


@pytest.mark.slow
def test_one_random_log_runs_both_modes(tmp_path: Path) -> None:
    load_bench("discovery_confusion_study")
    study = load_bench("discovery_window_study")
    i = int(np.random.default_rng().integers(0, 1000))  # any log of the study, seed 8
    rec = study.run_one(8, i)
    assert rec["windows"]["status"] in ("ok", "partial", "not_run")
    assert rec["whole"]["status"] in ("ok", "partial", "not_run")
    if rec["windows"]["status"] != "not_run":
        assert rec["windows"]["used_s"] == pytest.approx(600.0)  # logs are 15-30 min long
        assert rec["whole"]["used_s"] is None
    path = tmp_path / "recs.json"
    path.write_text(json.dumps([rec]))
    text = study.main(["--merge", str(path)])
    assert "same named set, windows vs whole: " in text
    assert text.count("named right") == 2
