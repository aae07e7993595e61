"""A small random slice of bench/path_coverage_study.py runs in CI: two logs drawn afresh each
run. It checks that the study's machinery works end to end (generate, write, analyse, score),
not a statistical claim: coverage is shown by the full study (closing note of issue #8)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _study():  # type: ignore[no-untyped-def]
    spec = importlib.util.spec_from_file_location("path_coverage_study",
                                                  ROOT / "bench" / "path_coverage_study.py")
    assert spec is not None
    assert spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["path_coverage_study"] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
def test_a_random_slice_of_the_coverage_study_runs() -> None:
    study = _study()
    picks = np.random.default_rng().integers(0, 500, size=2)
    rows = [study.one(int(i), 2026) for i in picks]
    for r in rows:
        assert "error" not in r, r.get("error")
        assert set(r["truth"]) == {"L1", "L2", "sum_L1_L2"}
    summary = study.summarise(rows)
    assert summary["logs"] == 2
    for q in ("L1", "L2", "sum_L1_L2"):
        if q not in summary["coverage"]:
            continue
        for cell in summary["coverage"][q].values():
            assert cell["covered"] <= cell["determined"]
            if cell["coverage"] is not None:
                lo, hi = cell["wilson95"]
                assert 0.0 <= lo <= cell["coverage"] <= hi <= 1.0
