"""The robots' judgement in calib (calib.tractor_trailer.judgement, calib.diff_drive.judgement):
which estimate is recommended and why, when the measured path rejects a confounded explanation,
when the estimate spans one, which stuck encoder spans are left out. Plain values in; the fits
are stand-ins with only the attributes the judgement reads."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from calib.diff_drive.adequacy import StuckSpan
from calib.diff_drive.judgement import LSQ_MODEL, excluded_stuck_spans, model_label
from calib.results import CalibrationResult, Estimate
from calib.tractor_trailer.judgement import (
    judge_plausible,
    recommend,
    recommended_estimate,
    span_confounds,
)


def _estimate(l1: float, l2: float, method: str = "path-driven transient") -> CalibrationResult:
    return CalibrationResult(
        method=method,
        verdict="fitted.",
        parameters={
            "L1": Estimate("L1", l1, 0.01, (l1 - 0.0196, l1 + 0.0196), unit="m"),
            "L2": Estimate("L2", l2, 0.01, (l2 - 0.0196, l2 + 0.0196), unit="m"),
        },
    )


def _fit(result: CalibrationResult, rms: float, *, sound: bool = True, **kw: Any) -> Any:
    return SimpleNamespace(
        result_=result,
        sound_=sound,
        residual_rms_=rms,
        residual_=np.random.default_rng(0).normal(0.0, rms, 2000),
        converged_=kw.get("converged", True),
        on_bound_=kw.get("on_bound", ()),
        name="path-driven transient",
    )


def _choice(report: str) -> Any:
    return SimpleNamespace(confound=SimpleNamespace(report=lambda: report))


def test_no_path_fit_and_no_eiv_says_why_the_path_fit_failed() -> None:
    est, notes = recommend(None, None, "the robot stood still")
    assert est is None
    assert notes == ["transient fit along the path not possible: the robot stood still"]


def test_an_unsound_path_fit_gives_way_to_the_eiv_estimate_with_the_reason() -> None:
    eiv = _estimate(0.5, 2.0, method="EIV-ML")
    bad = _fit(_estimate(0.4, 2.1), 0.01, sound=False, converged=False, on_bound=("L1",))
    est, notes = recommend(bad, eiv, None)
    reason = (
        "transient fit along the path not used: the optimiser did not converge; "
        "estimate on a bound of L1"
    )
    assert est is not None
    assert est.method == "EIV-ML"
    assert est.verdict == f"fitted. ({reason}.)"
    assert notes == [reason]


def test_a_robot_that_did_not_move_has_no_estimate() -> None:
    good = _fit(_estimate(0.5, 2.0), 0.01)
    assert recommended_estimate("the robot did not move", None, good, None, None) == (
        None,
        ["the robot did not move"],
    )


def test_confounds_without_a_sound_refit_leave_the_estimate_and_say_nothing() -> None:
    est = _estimate(0.5, 2.0)
    nominal = _fit(est, 0.01)
    failed = [("dead time", None), ("clock offset", _fit(_estimate(0.6, 2.0), 0.01, sound=False))]
    assert span_confounds(est, nominal, failed, [_choice("dead time vs clock")]) == (est, [])


def test_the_measured_path_rejects_an_explanation_that_fits_it_twice_as_badly() -> None:
    est = _estimate(0.5, 2.0)
    nominal = _fit(est, 0.01)
    worse = _fit(_estimate(0.7, 2.0), 0.02)  # chi-square about 2000 x 3 >> REJECT_CHI2
    out, notes = span_confounds(est, nominal, [("clock offset", worse)], [_choice("c")])
    assert out is est
    assert notes[0] == "c"
    assert notes[1].startswith("the measured path rejects clock offset (joint-angle residual 2x")


def test_an_explanation_the_path_cannot_reject_is_spanned() -> None:
    est = _estimate(0.5, 2.0)
    nominal = _fit(est, 0.01)
    alike = _fit(_estimate(0.7, 2.0), 0.01)
    out, notes = span_confounds(est, nominal, [("clock offset", alike)], [_choice("c")])
    assert notes == ["c"]
    lo, hi = out.parameters["L1"].ci95
    assert lo <= 0.5 - 0.0196
    assert hi >= 0.7 + 0.0196
    assert out.parameters["L1"].value == 0.5
    assert out.verdict.endswith("the intervals span them (see the notes).")


def test_an_implausible_link_length_is_marked_and_named() -> None:
    est, notes = judge_plausible(_estimate(0.5, 80.0), None)
    assert est is not None
    assert not est.parameters["L2"].identifiable
    assert len(notes) == 1
    assert notes[0].startswith("implausible: ")
    same, none = judge_plausible(_estimate(0.5, 2.0), None)
    assert none == []
    assert same is not None
    assert same.parameters["L2"].identifiable


def test_every_detected_stuck_span_is_left_out_when_discovery_did_not_run() -> None:
    spans = [
        StuckSpan(0, "wheel_right", 300, 400, 3.0, 4.0, 0.2),
        StuckSpan(0, "wheel_left", 900, 910, 9.0, 9.1, -0.05),
    ]
    assert excluded_stuck_spans(spans, None) == spans
    assert excluded_stuck_spans([], None) == []
    assert model_label([]) == LSQ_MODEL
    assert model_label(spans) == (
        f"{LSQ_MODEL}, samples of wheel_right t 3.0-4.0 s, wheel_left t 9.0-9.1 s excluded"
    )
