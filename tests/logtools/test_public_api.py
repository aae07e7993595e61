"""The small public API: ``import logtools`` gives load, analyse and the result types."""

from __future__ import annotations

from pathlib import Path

import pytest

import logtools

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "tt_mixed.mcap"


def test_every_public_name_resolves() -> None:
    for name in logtools.__all__:
        assert getattr(logtools, name) is not None
    with pytest.raises(AttributeError):
        _ = logtools.no_such_name  # type: ignore[attr-defined]


def test_a_log_is_analysed_through_the_public_names() -> None:
    loaded, result = logtools.analyze_log(
        SAMPLE, config=logtools.AnalysisConfig(discovery=False, repeats=1)
    )
    assert isinstance(loaded, logtools.LoadedLog)
    assert isinstance(result, logtools.AnalysisResult)
    assert result.estimate is not None
    l2 = result.estimate.parameters["L2"]
    assert isinstance(l2, logtools.Estimate)
    assert l2.ci95[0] < l2.value < l2.ci95[1]
