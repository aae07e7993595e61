"""The shared result type of every robot: named parameters with an N x N covariance and
correlations, robot-specific derived quantities, its JSON and its report."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from calib.results import CalibrationResult, Estimate, correlations_of


def _est(name: str, value: float, std: float, identifiable: bool = True) -> Estimate:
    return Estimate(name, value, std, (value - 1.96 * std, value + 1.96 * std), identifiable)


PARAMS = {"a": _est("a", 1.0, 0.1), "b": _est("b", 2.0, 0.2), "c": _est("c", 3.0, 0.3)}
COV = np.array([[0.01, 0.012, 0.0], [0.012, 0.04, -0.03], [0.0, -0.03, 0.09]])


def _result(**kw: object) -> CalibrationResult:
    args: dict[str, object] = {
        "method": "LSQ",
        "parameters": PARAMS,
        "verdict": "all determined",
        "covariance": COV,
        "derived": {"a_plus_b": _est("a+b", 3.0, 0.25)},
    }
    args.update(kw)
    return CalibrationResult(**args)  # type: ignore[arg-type]


def test_correlations_from_the_covariance() -> None:
    res = _result()
    assert res.covariance == tuple(tuple(r) for r in COV.tolist())  # stored as floats, frozen
    assert res.parameter_names == ("a", "b", "c")
    corr = np.array(res.correlations)
    sd = np.sqrt(np.diag(COV))
    np.testing.assert_allclose(corr, COV / np.outer(sd, sd), rtol=1e-12)
    assert corr[0, 1] == pytest.approx(0.6)
    assert corr[1, 2] == pytest.approx(-0.5)
    # rounding past a perfect correlation is clipped
    assert correlations_of(((1.0, 1.0 + 1e-12), (1.0 + 1e-12, 1.0)))[0][1] == 1.0
    np.testing.assert_allclose(np.diag(corr), 1.0)


def test_correlations_are_nan_where_a_variance_is_not_positive() -> None:
    cov = ((0.01, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, math.nan))
    corr = correlations_of(cov)
    assert corr[0][0] == 1.0
    assert all(math.isnan(corr[1][j]) and math.isnan(corr[j][1]) for j in range(3))
    assert math.isnan(corr[2][2])
    assert math.isnan(corr[0][2])
    doc = json.loads(json.dumps(_result(covariance=cov).to_dict(), allow_nan=False))
    assert doc["correlations"][1] == [None, None, None]
    assert doc["covariance"][2][2] is None


def test_json_keys_parameters_then_derived_at_top_level() -> None:
    doc = json.loads(json.dumps(_result().to_dict(), allow_nan=False))
    assert list(doc)[:4] == ["a", "b", "c", "a_plus_b"]
    assert doc["b"]["value"] == 2.0
    assert doc["a_plus_b"]["name"] == "a+b"
    assert doc["parameter_names"] == ["a", "b", "c"]
    assert doc["derived_names"] == ["a_plus_b"]
    assert doc["covariance"] == COV.tolist()
    assert doc["correlations"][0][1] == pytest.approx(0.6)
    assert doc["method"] == "LSQ"
    assert doc["identifiable"] is True


def test_without_covariance_or_derived_quantities() -> None:
    res = _result(covariance=None, derived={})
    assert res.correlations is None
    doc = res.to_dict()
    assert doc["covariance"] is None
    assert doc["correlations"] is None
    assert doc["derived_names"] == []
    assert set(doc) >= {"a", "b", "c"}
    assert "a_plus_b" not in doc


def test_report_prints_parameters_then_derived_then_verdict() -> None:
    lines = _result(parameters={**PARAMS, "c": _est("c", 3.0, 0.3, False)}).report().splitlines()
    assert lines[0] == "Recommended estimate (LSQ):"
    assert [ln.split()[0] for ln in lines[1:5]] == ["a", "b", "c", "a+b"]
    assert "(not determined by this log)" in lines[3]
    assert lines[5].strip() == "all determined"
    assert not _result(parameters={**PARAMS, "c": _est("c", 3.0, 0.3, False)}).identifiable


@pytest.mark.parametrize(
    ("kw", "message"),
    [
        ({"covariance": np.eye(2)}, "2 x 2 but there are 3 parameters"),
        ({"covariance": [[1.0, 0.0], [0.0]]}, "square"),
        ({"derived": {"a": _est("a", 1.0, 0.1)}}, "clash"),
        ({"derived": {"method": _est("m", 1.0, 0.1)}}, "clash"),
    ],
)
def test_inconsistent_results_are_refused(kw: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        _result(**kw)


def test_tractor_sum_is_a_derived_quantity_under_its_json_key() -> None:
    from calib.tractor_trailer.derived import SUM_KEY, derived_sum, link_sum
    from calib.tractor_trailer.estimators._result import calibration_result
    from calib.tractor_trailer.estimators.identifiability import identifiability

    cov = np.array([[0.04, -0.039], [-0.039, 0.04]])
    verdict = identifiability(cov, (1.2, 2.5))
    res = calibration_result("EIV", verdict, cov, converged=True)
    assert res.parameter_names == ("L1", "L2")
    assert link_sum(res) is verdict.sum_L1_L2
    doc = res.to_dict()
    assert doc[SUM_KEY] == verdict.sum_L1_L2.to_dict()
    assert doc["derived_names"] == [SUM_KEY]
    assert doc["correlations"][0][1] == pytest.approx(-0.975)
    assert derived_sum(None, res.derived) == {}
    assert link_sum(_result()) is None
