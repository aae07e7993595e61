"""A slice of bench/explanation_study.py: a few random logs end to end, and the metrics computed
as defined on constructed records and results (deterministic facts only; no statistical
assertion on one seed)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str) -> ModuleType:
    path = ROOT / "bench" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None
    assert spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(name, mod)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def study() -> ModuleType:
    _load("adequacy_study")
    return _load("explanation_study")


FIELDS = (
    "shape",
    "named",
    "described_effects",
    "described",
    "verdict_before",
    "verdict_after",
    "heldout_before",
    "heldout_after",
    "verdict",
    "found",
    "improved",
    "explains_after",
    "false_names",
    "accepted_names",
    "intervals",
    "intervals_without_truth",
    "heldout_effect_size",
)


@pytest.fixture(scope="module")
def records(study: ModuleType) -> list[dict[str, Any]]:
    # seed 5, logs 0-3 of the new kinds: a clean log and kind logs of more than one robot
    recs: list[dict[str, Any]] = study.run_study(
        4, 5, ("tractor_trailer", "diff_drive", "arm"), list(study.NEW_KINDS), False, repeats=3
    )
    return recs


def test_slice_runs_end_to_end(records: list[dict[str, Any]], study: ModuleType) -> None:
    assert len(records) == 4
    for r in records:
        assert r["error"] is None, r.get("traceback")
        for key in FIELDS:
            assert key in r, key
        assert set(r["false_names"]) <= set(r["named"])
        for iv in r["intervals"]:
            assert iv["truth"]
            assert iv["confident_wrong"] == (
                iv["identifiable"]
                and not any(iv["ci95"][0] <= t <= iv["ci95"][1] for t in iv["truth"])
            )
        assert not r["held_out"]
    kinds = [r["kind"] for r in records]
    assert None in kinds
    assert any(k is not None for k in kinds)
    summary = study.summarise(records)
    assert summary["n_logs"] == 4
    assert summary["n_errors"] == 0
    assert sum(c["n"] for c in summary["cells"].values()) == 4


def test_clean_logs_carry_no_kind(records: list[dict[str, Any]], study: ModuleType) -> None:
    for r in records:
        if r["kind"] is None:
            assert r["truth_kind"] is None
            assert r["heldout_effect_size"] == 0.0
            assert r["effect_size"] == 0.0
            assert r["accepted_names"] == sorted(study.BASELINE_NAMES[r["robot"]])
        else:
            assert r["truth_kind"] == r["kind"]
            assert r["new_kind"]


def test_draws_use_the_study_clean_share(study: ModuleType) -> None:
    specs = [study.draw(9, i, study.ROBOTS, None, False, study.CLEAN_SHARE) for i in range(400)]
    clean = sum(s["kind"] is None for s in specs)
    assert 0.15 * 400 < clean < 0.35 * 400
    assert not {s["kind"] for s in specs} & study.HELD_OUT_KINDS


def _doc(named: list[str], *, est_ci: tuple[float, float], alt_ident: bool) -> dict[str, Any]:
    est = {"name": "L1", "value": 1.0, "ci95": list(est_ci), "identifiable": True}
    alt = {"name": "L2", "value": 2.0, "ci95": [1.0, 1.1], "identifiable": alt_ident}
    return {
        "adequacy": {"verdict": "explains"},
        "estimate": {"L1": est, "method": "x"},
        "discovery": {
            "effects": [{"key": k, "status": "named", "parameters": {}} for k in named]
            + [{"key": "described(psi)", "status": "described", "parameters": {}}],
            "named": named,
            "described": True,
            "remaining": "",
            "verdict_before": {"verdict": "does not explain", "ratio": 3.0, "channel": "psi"},
            "verdict_after": {"verdict": "explains", "ratio": 1.0, "channel": "psi"},
            "heldout_before": 10.0,
            "heldout_after": 4.0,
            "alternatives": [{"label": "other", "parameters": {"L2": alt}}],
        },
    }


TRUTH = {"robot": "tractor_trailer", "kind": "hitch_backlash", "L1": 1.0, "L2": 2.0}


def test_record_reads_names_and_intervals_as_defined(study: ModuleType) -> None:
    spec = {"robot": "tractor_trailer", "kind": "hitch_backlash"}
    doc = _doc(["backlash(psi)", "sensor_offset(psi)"], est_ci=(0.9, 1.1), alt_ident=True)
    r = study.analyse_record(dict(spec), doc, TRUTH)
    assert r["named"] == ["backlash(psi)", "sensor_offset(psi)"]
    assert r["false_names"] == ["sensor_offset(psi)"]  # backlash(psi) is the kind's name
    assert r["found"]
    assert r["improved"]
    assert r["explains_after"]
    assert r["described"]
    assert study.modelled_and_improved(r)
    by = {iv["source"]: iv for iv in r["intervals"]}
    assert not by["estimate"]["confident_wrong"]  # 1.0 in [0.9, 1.1]
    assert by["alternative: other"]["confident_wrong"]  # 2.0 outside [1.0, 1.1], identifiable
    # the same alternative marked not identifiable is no confident claim
    doc = _doc([], est_ci=(1.2, 1.3), alt_ident=False)
    r = study.analyse_record(dict(spec), doc, TRUTH)
    by = {iv["source"]: iv for iv in r["intervals"]}
    assert by["estimate"]["confident_wrong"]
    assert not by["alternative: other"]["confident_wrong"]
    # on a clean log every catalogue name is false (the tractor has no baseline names)
    clean = study.analyse_record(
        {"robot": "tractor_trailer", "kind": None},
        _doc(["backlash(psi)"], est_ci=(0.9, 1.1), alt_ident=False),
        {**TRUTH, "kind": None},
    )
    assert clean["false_names"] == ["backlash(psi)"]


def test_a_wildcard_accepted_name_takes_any_target(study: ModuleType) -> None:
    rec = {
        "robot": "diff_drive",
        "kind": "stuck_encoder",
        "error": None,
        "named": ["encoder_stuck(wheel_right t 13.4-14.0 s)", "wheel_slip(wheels)"],
    }
    assert study.rescore_names(rec)["false_names"] == ["wheel_slip(wheels)"]
    rec["kind"] = None  # on a clean log the span is a false name
    assert study.rescore_names(rec)["false_names"] == rec["named"]


def test_unbounded_interval_ends_count_as_unbounded(study: ModuleType) -> None:
    doc = _doc([], est_ci=(1.2, 1.3), alt_ident=True)
    doc["estimate"]["L1"]["ci95"] = [1.2, None]
    doc["discovery"]["alternatives"][0]["parameters"]["L2"]["ci95"] = [None, 1.5]
    r = study.analyse_record({"robot": "tractor_trailer", "kind": None}, doc, TRUTH)
    by = {iv["source"]: iv for iv in r["intervals"]}
    assert by["estimate"]["confident_wrong"]  # [1.2, inf) excludes 1.0
    assert by["alternative: other"]["ci95"] == [-math.inf, 1.5]
    assert by["alternative: other"]["confident_wrong"]  # (-inf, 1.5] excludes 2.0


def _rec(**kw: Any) -> dict[str, Any]:
    base: dict[str, Any] = {
        "robot": "diff_drive",
        "kind": "yaw_slip",
        "new_kind": True,
        "error": None,
        "shape": "shared",
        "heldout_effect_size": 5.0,
        "found": True,
        "improved": True,
        "explains_after": True,
        "described": False,
        "named": [],
        "false_names": [],
        "intervals": [],
        "intervals_without_truth": 0,
        "verdict": "explains",
    }
    return base | kw


def test_metrics_on_a_constructed_record_set(study: ModuleType) -> None:
    iv_ok = {"identifiable": True, "confident_wrong": False}
    iv_cw = {"identifiable": True, "confident_wrong": True}
    iv_free = {"identifiable": False, "confident_wrong": False}
    recs = [
        _rec(),  # modelled and improved
        _rec(explains_after=False, described=True),  # modelled and improved (described)
        _rec(improved=False),  # held-out not lower
        _rec(found=False, improved=False),  # nothing found
        _rec(explains_after=False),  # not explained, not described
        _rec(heldout_effect_size=1.0, found=False),  # below the threshold: not counted
        _rec(kind=None, new_kind=False, heldout_effect_size=0.0, verdict="does not explain"),
        _rec(kind=None, new_kind=False, heldout_effect_size=0.0, named=["a"], false_names=["a"]),
        _rec(named=["b", "c"], false_names=["c"], intervals=[iv_ok, iv_cw, iv_free]),
        _rec(error="boom"),
    ]
    s = study.summarise(recs)
    m = s["overall"]
    assert s["n_errors"] == 1
    assert m["n_big"] == 6
    assert (m["modelled_and_improved"]["k"], m["modelled_and_improved"]["n"]) == (3, 6)
    assert m["failures_big"] == {
        "held-out not lower": 1,
        "nothing found": 1,
        "not explained, not described": 1,
    }
    assert (m["confident_wrong"]["k"], m["confident_wrong"]["n"]) == (1, 2)
    assert (m["false_name_logs"]["k"], m["false_name_logs"]["n"]) == (2, 9)
    assert (m["false_names"]["k"], m["false_names"]["n"]) == (2, 3)
    assert (m["false_alarm_clean"]["k"], m["false_alarm_clean"]["n"]) == (1, 2)
    lo, hi = m["false_alarm_clean"]["lo"], m["false_alarm_clean"]["hi"]
    assert (lo, hi) == study.wilson(1, 2)
    assert set(s["cells"]) == {"diff_drive/yaw_slip", "diff_drive/clean"}
