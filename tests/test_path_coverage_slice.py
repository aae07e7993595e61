"""A small random slice of bench/path_coverage_study.py runs in CI: two logs drawn afresh each
run. It checks that the study's machinery works end to end (generate, write, analyse, score),
not a statistical claim: coverage is shown by the full study (bench/path_coverage_study.py)."""

from __future__ import annotations

from types import ModuleType

import numpy as np
import pytest
from bench_scripts import load_bench


def _study() -> ModuleType:
    return load_bench("path_coverage_study")


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
