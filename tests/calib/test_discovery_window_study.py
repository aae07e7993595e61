"""bench/discovery_window_study.py: a one-log random slice runs both modes and tabulates.
Deterministic facts only (which span each mode used, the table's rows); the study's numbers are
in its own output and the closing note of issue 14."""

from __future__ import annotations

import importlib.util
import json
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _load(name: str) -> ModuleType:
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "bench" / f"{name}.py")
    assert spec is not None
    assert spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
def test_one_random_log_runs_both_modes(tmp_path: Path) -> None:
    _load("discovery_confusion_study")
    study = _load("discovery_window_study")
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
