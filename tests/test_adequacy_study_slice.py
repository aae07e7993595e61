"""A slice of bench/adequacy_study.py: a few random logs end to end (deterministic facts only;
no statistical assertion on one seed)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _study() -> ModuleType:
    path = ROOT / "bench" / "adequacy_study.py"
    spec = importlib.util.spec_from_file_location("adequacy_study", path)
    assert spec is not None
    assert spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("adequacy_study", mod)
    spec.loader.exec_module(mod)
    return mod


@pytest.fixture(scope="module")
def study() -> ModuleType:
    return _study()


@pytest.fixture(scope="module")
def records(study: ModuleType) -> list[dict[str, Any]]:
    recs: list[dict[str, Any]] = study.run_study(
        5, 20261126, ("tractor_trailer", "diff_drive", "arm"), None, False, repeats=3
    )
    return recs


def test_draws_are_deterministic_and_exclude_held_out(study: ModuleType) -> None:
    a = [study.draw(3, i, study.ROBOTS, None, False) for i in range(60)]
    assert a == [study.draw(3, i, study.ROBOTS, None, False) for i in range(60)]
    assert not {r["kind"] for r in a} & study.HELD_OUT_KINDS
    assert any(r["kind"] is None for r in a)
    assert any(r["kind"] for r in a)
    assert {r["robot"] for r in a} == set(study.ROBOTS)
    b = [study.draw(3, i, study.ROBOTS, None, True) for i in range(200)]
    assert {r["kind"] for r in b} & study.HELD_OUT_KINDS


def test_slice_runs_end_to_end(records: list[dict[str, Any]], study: ModuleType) -> None:
    assert len(records) == 5
    for r in records:
        assert r["error"] is None, r.get("traceback")
        for key in (
            "verdict",
            "located",
            "changes",
            "is_located",
            "named",
            "params",
            "effect_size",
            "refit_effect_size",
            "heldout_effect_size",
            "held_out",
            "seconds",
        ):
            assert key in r
        assert r["verdict"] in ("explains", "does not explain", "not assessed")
        assert not r["held_out"]
        if r["kind"] is None:
            assert r["effect_size"] == 0.0
            assert r["refit_effect_size"] == 0.0
            assert r["heldout_effect_size"] == 0.0
        else:
            assert r["effect_size"] > 0.0
            assert r["refit_effect_size"] >= 0.0
            assert r["heldout_effect_size"] >= 0.0
        for p in r["params"]:
            assert p["confident_wrong"] == (
                p["identifiable"] and not any(p["ci95"][0] <= t <= p["ci95"][1] for t in p["truth"])
            )
    s = study.summarise(records)
    assert s["n_logs"] == 5
    big = [r for r in records if r["kind"] and r["heldout_effect_size"] > study.EFFECT_THRESHOLD]
    big_raw = [r for r in records if r["kind"] and r["effect_size"] > study.EFFECT_THRESHOLD]
    assert s["flagged_located_big"]["n"] == len(big)
    assert s["flagged_located_big_raw"]["n"] == len(big_raw)
    for c in s["cells"].values():
        for key in ("median_effect", "median_refit_effect", "median_heldout_effect"):
            assert key in c
    assert set(s["cells"])
    assert s["n_errors"] == 0
    study.print_table(s, 0.0)


def test_truth_of_estimates_maps_every_robot(study: ModuleType) -> None:
    from indgen.robots import generate_log

    arm = generate_log("arm", 1, None, duration_s=5.0).truth
    full = arm["params"]
    name = "Izz[joint1] + 0.25·m[joint2] - mx[joint2] + Ia[joint1]"
    want = full["Izz[joint1]"] + 0.25 * full["m[joint2]"] - full["mx[joint2]"]
    assert study.true_values(arm, name) == [pytest.approx(want)]
    assert study.true_values(arm, "unknown[joint1]") == []
    dd = generate_log("diff_drive", 1, "radius_change", 0.05, duration_s=5.0).truth
    side = "wheel_radius_left" if dd["wheel"] == "left" else "wheel_radius_right"
    assert len(study.true_values(dd, side)) == 2
    tt = generate_log("tractor_trailer", 1, "trailer_swap", 0.2, duration_s=30.0).truth
    assert study.true_values(tt, "sum_L1_L2") == [
        pytest.approx(tt["L1"] + tt["L2"]),
        pytest.approx(tt["L1"] + tt["L2_after"]),
    ]


def test_wilson() -> None:
    st = _study()
    lo, hi = st.wilson(0, 20)
    assert lo == 0.0
    assert 0.15 < hi < 0.17
    lo, hi = st.wilson(10, 10)
    assert hi == 1.0
    assert 0.69 < lo < 0.73
