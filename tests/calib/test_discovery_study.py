"""bench/discovery_confusion_study.py: a tiny random slice runs and gives well-formed tables,
and the scoring counts what it says. Deterministic facts only: no statistical pass on a seed
(the study's numbers are in its own output)."""

from __future__ import annotations

import json
from pathlib import Path
from types import ModuleType

import pytest
from bench_scripts import load_bench


def _study() -> ModuleType:
    return load_bench("discovery_confusion_study")


@pytest.mark.slow
def test_tiny_slice_runs_and_tabulates(tmp_path: Path) -> None:
    study = _study()
    out_json = tmp_path / "records.json"
    text = study.main(["--n", "2", "--seed", "0", "--quiet", "--json", str(out_json)])
    for head in (
        "logs: 2;",
        "Confusion matrix",
        "Naming accuracy where the effect raises",
        "False alarms on clean logs",
        "Coverage of 95 % intervals",
    ):
        assert head in text, text
    header = next(line for line in text.splitlines() if "true \\ named" in line)
    assert header.split()[-1] == "nothing"
    recs = json.loads(out_json.read_text())
    assert [r["i"] for r in recs] == [0, 1]
    for r in recs:
        assert r["status"] in ("ok", "partial", "not_run"), r.get("reason")
        assert set(r["truth"]) <= {*study.CATALOGUE, study.UNCATALOGUED}
    # the same slice again gives the same draws (each log has its own seed)
    again = study.run_one(0, 1, "indgen", "transient")
    assert again["truth"] == recs[1]["truth"]
    assert again.get("named") == recs[1].get("named")
    # merging record files re-tabulates without running anything
    assert "logs: 2;" in study.main(["--merge", str(out_json)])


def _rec(truth: dict, named: list, alts: list | None = None, excess: float = 5.0) -> dict:
    return {
        "seed": 0,
        "i": 0,
        "baseline": "transient",
        "status": "ok",
        "truth": truth,
        "named": named,
        "alternatives": alts or [],
        "params": {},
        "excess": {"omega": excess, "psi": excess},
        "conditions": {"v_mean": 1.0, "command": "H", "speed_kind": "constant"},
        "residual_model": False,
    }


def test_scoring_counts_exact_and_equivalent_names() -> None:
    study = _study()
    delay = {"actuator_delay": {"delay": 0.3}}
    assert study.correct(_rec(delay, ["actuator_delay"])) == (True, True)
    clocks = [["actuator_delay"], ["clock_offset(odom)", "clock_offset(hitch)"]]
    two = {"clock_offset(odom)": {"offset": 0.3}, "clock_offset(hitch)": {"offset": 0.3}}
    assert study.correct(_rec(two, ["actuator_delay"], [clocks])) == (False, True)
    assert study.correct(_rec(delay, ["actuator_lag"])) == (False, False)
    assert study.correct(_rec({}, [])) == (True, True)
    # a pair is as strong as its weaker effect on the outputs it changes
    pair = _rec({"sensor_offset(psi)": {"offset": 0.1}, "understeer": {"K": 0.1}}, [])
    pair["excess"] = {"omega": 9.0, "psi": 1.5}
    assert study.strength(pair) == 1.5
    text = study.tables(
        [_rec({}, []), _rec({}, ["sensor_offset(psi)"]), _rec(delay, ["actuator_delay"])]
    )
    assert "False alarms on clean logs (target <= 5 %):  50.0 %" in text
    assert "single: actuator_delay" in text


@pytest.mark.slow
def test_detectable_means_after_refitting_the_link_lengths() -> None:
    """Log 89 of seed 0 (fixed draw of the independent generator): a joint-angle scale 1.131
    with a joint-angle offset. At small angles the scale is a change of L1 + L2, so with the
    link lengths refitted it adds nothing to the held-out RMS and the log is not scored against
    naming, though with L1, L2 held at the truth it changes the recordings by 160x the noise.
    The offset is not absorbed. The refitted L1 is the equivalent one, s (L1 + L2) - L2."""
    study = _study()
    rec = study.run_one(0, 89, "indgen", "transient")
    assert rec["status"] == "ok", rec.get("reason")
    assert set(rec["truth"]) == {"sensor_scale(psi)", "sensor_offset(psi)"}
    sig = rec["conditions"]["effect_signal"]
    fixed = rec["conditions"]["effect_signal_fixed_L"]
    assert sig["sensor_scale(psi)"] <= study.DETECTABLE < fixed["sensor_scale(psi)"]
    assert sig["sensor_offset(psi)"] > 10 * study.DETECTABLE
    assert study.strength(rec) <= study.DETECTABLE
    s = rec["truth"]["sensor_scale(psi)"]["scale"]
    L1, L2 = rec["truth_L"]["L1"], rec["truth_L"]["L2"]
    _, lo, hi = rec["joint"]["L1"]
    assert lo - 0.01 <= s * (L1 + L2) - L2 <= hi + 0.01
    text = study.tables([rec])
    assert "absorbed by the link lengths): 1 logs" in text
    assert "sensor_offset(psi) + sensor_scale(psi) x1" in text
