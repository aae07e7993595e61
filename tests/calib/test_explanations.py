"""Intervals across explanations (calib.discovery.across): the union of the plausible
explanations' intervals, determined only where they agree and the final model explains the
log; under a misfit each interval is widened by the misfit and nothing is determined."""

from __future__ import annotations

import pytest

from calib.discovery import Explanation, ModelFit, across
from calib.results import Estimate


def _fit(sse: float) -> ModelFit:
    return ModelFit((), {}, {}, sse, sse, 1000, 3)


def _est(value: float, std: float) -> Estimate:
    return Estimate("L2", value, std, (value - 1.96 * std, value + 1.96 * std), True, "m")


def _two(second: float) -> list[Explanation]:
    return [
        Explanation("final", _fit(1000.0), {"L2": _est(2.00, 0.01)}),
        Explanation("nominal", _fit(1001.0), {"L2": _est(second, 0.01)}),
    ]


def test_explanations_that_agree_determine_the_value_with_their_union() -> None:
    ex = _two(2.005)
    got = across(ex, ex[0])["L2"]
    assert got.agree
    assert got.estimate.identifiable
    assert got.estimate.ci95 == pytest.approx((2.00 - 0.0196, 2.005 + 0.0196))


def test_explanations_that_disagree_are_spanned_but_not_determined() -> None:
    ex = _two(2.10)
    got = across(ex, ex[0])["L2"]
    assert not got.agree
    assert not got.estimate.identifiable
    assert got.estimate.ci95[1] == pytest.approx(2.10 + 0.0196)


def test_under_a_misfit_every_interval_is_widened_and_nothing_is_determined() -> None:
    ex = _two(2.005)
    got = across(ex, ex[0], misfit=2.0)["L2"]
    assert not got.estimate.identifiable
    assert got.estimate.ci95 == pytest.approx((2.00 - 2 * 0.0196, 2.005 + 2 * 0.0196))
    assert "does not explain" in got.estimate.note


def test_a_rejected_explanation_is_not_spanned() -> None:
    ex = [
        Explanation("final", _fit(1000.0), {"L2": _est(2.00, 0.01)}),
        Explanation("nominal", _fit(5000.0), {"L2": _est(2.50, 0.01)}),
    ]
    got = across(ex, ex[0])["L2"]
    assert list(got.values) == ["final"]
    assert got.estimate.ci95 == pytest.approx((2.00 - 0.0196, 2.00 + 0.0196))
