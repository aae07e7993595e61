"""Arm adequacy and discovery through the shared engine: a clean log is explained and
determined; a torque delay, an elastic joint and a payload picked up mid-log are not explained
by the nominal model, and are named (or the change located and the log split) with estimates that
cover the truth or are not determined; a real DFKI run gets a verdict."""

from __future__ import annotations

import json
import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest

import logtools.robots as robots
from calib.manipulator.adequacy import assess_arm, find_change, piece_fits, spanned, widened
from calib.manipulator.design import Term
from calib.manipulator.discovery import ArmFitter, arm_catalogue, run_discovery
from calib.manipulator.identify import IdentifyConfig
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.signals import prepare_signals
from calib.manipulator.simulate import Friction, Sensors, simulate_planar
from logtools.analyze import AnalysisConfig
from logtools.load import load_log
from logtools.robots.manipulator import PLUGIN
from logtools.robots.manipulator.options import ManipulatorOptions

DFKI = Path(__file__).resolve().parents[3] / "shared/realworld_arm/dfki_double_pendulum"
ARM = Planar2Params()
TERMS = (Term.COULOMB, Term.VISCOUS)
# the paper torque holds a 7.7 Hz component, which the default 10 Hz zero-phase filter attenuates
# by ~10 % (held-out 1.5x the floor on joint 2 of a clean log: the filter's own misfit); 20 Hz
# passes it, so a clean log is judged on the model alone
CFG = IdentifyConfig(terms=TERMS, cutoff_hz=20.0)


@pytest.fixture(autouse=True)
def _plugin() -> None:
    robots.register(PLUGIN)


@cache
def _fitter(case: str, nominal: bool = False) -> ArmFitter:
    switches: dict[str, dict[str, object]] = {
        "clean": {},
        "delay": {"delay_s": 0.02},
        "compliance": {"compliance": (0.0, 0.02)},
        "change": {"payload_change": (10.0, 0.5)},
    }
    run = simulate_planar(
        ARM, Friction(), duration_s=20.0, sensors=Sensors(), seed=3, **switches[case]
    )  # type: ignore[arg-type]
    sig = prepare_signals(run.t_s, run.q, run.tau, cutoff_hz=CFG.cutoff_hz)
    return ArmFitter(Planar2Link(ARM), sig, TERMS, ARM.theta() if nominal else None, CFG)


def _truth_base(f: ArmFitter, payload: float = 0.0) -> dict[str, float]:
    p = Planar2Params(payload=payload)
    fr = Friction()
    full = np.r_[p.theta(), fr.coulomb, fr.viscous]
    return dict(zip(f.design.names, f.design.to_base(full).tolist(), strict=True))


def _covers_or_not_determined(est: dict, truth: dict[str, float]) -> None:
    """Each estimate covers the truth (up to the filter's bias, 1e-3 relative) or is not
    determined."""
    for name, value in truth.items():
        e = est[name]
        slack = 1e-3 * abs(value)
        assert (not e.identifiable) or e.ci95[0] - slack <= value <= e.ci95[1] + slack, (
            name,
            e,
            value,
        )


def test_clean_log_is_explained_and_determined() -> None:
    f = _fitter("clean")
    judged = assess_arm(f)
    assert judged is not None
    assert judged.adequacy.verdict == "explains"
    assert [c.channel for c in judged.adequacy.channels] == ["tau1", "tau2"]
    assert run_discovery(f).named == []
    pieces = piece_fits(f)
    assert find_change(f, pieces) is None
    est = widened(judged.whole.estimates(), judged.adequacy, pieces)
    assert all(e.identifiable for e in est.values())
    truth = _truth_base(f)
    _covers_or_not_determined(est, {k: v for k, v in truth.items() if k[0] == "a"})


def test_torque_delay_is_named_and_explains() -> None:
    f = _fitter("delay")
    base = assess_arm(f)
    assert base is not None
    assert base.adequacy.verdict == "does not explain"
    disc = run_discovery(f)
    assert disc.named[0].key == "actuator_delay(tau)"
    d = disc.named[0].estimates[0]
    assert d.ci95[0] - 1e-3 <= 0.02 <= d.ci95[1] + 1e-3
    after = assess_arm(f, disc.accepted, before=base.adequacy)
    assert after is not None
    assert after.adequacy.misfit_factor < base.adequacy.misfit_factor / 4
    est = widened(after.whole.estimates(), after.adequacy)
    _covers_or_not_determined(est, {k: v for k, v in _truth_base(f).items() if k[0] == "a"})


@pytest.mark.parametrize("nominal", [False, True])
def test_compliance_is_named_not_a_payload(nominal: bool) -> None:
    f = _fitter("compliance", nominal)
    base = assess_arm(f)
    assert base is not None
    assert base.adequacy.verdict == "does not explain"
    disc = run_discovery(f)
    keys = [x.key for x in disc.named]
    confounded = {c.alternative for c in disc.selection.confounds} if disc.selection else set()
    # a payload is named only as one side of a reported confound
    assert "payload_mass(tool)" not in keys or confounded
    assert keys[0] == "joint_compliance(joint2)"
    c = disc.named[0].estimates[0]
    assert c.ci95[0] - 5e-4 <= 0.02 <= c.ci95[1] + 5e-4


def test_payload_picked_up_mid_log_is_located_and_split() -> None:
    f = _fitter("change")
    judged = assess_arm(f)
    assert judged is not None
    assert judged.adequacy.verdict == "does not explain"
    pieces = piece_fits(f)
    split = find_change(f, pieces)
    assert split is not None
    assert abs(split.change.t_s - 10.0) <= 20.0 / len(pieces)
    before, after = split.pieces[0][2], split.pieces[1][2]
    for name, value in _truth_base(f, 0.0).items():
        if name[0] == "a":
            assert abs(before[name].value - value) <= 0.05 * abs(value), name
    for name, value in _truth_base(f, 0.5).items():
        if name[0] == "a":
            assert abs(after[name].value - value) <= 0.05 * abs(value), name
    # one set of parameters for the whole log is not determined
    adq = judged.adequacy.with_(changes=(split.change,))
    est = widened(judged.whole.estimates(), adq, pieces)
    assert not any(e.identifiable for e in est.values())


def test_pipeline_reports_delay_adequacy(tmp_path: Path) -> None:
    from logtools.writers.manipulator import arm_metadata, write_arm_run

    run = simulate_planar(ARM, Friction(), duration_s=12.0, sensors=Sensors(), seed=4, delay_s=0.02)
    nominal = {k: getattr(ARM, k) for k in ("m1", "m2", "r1", "r2", "I1", "I2")}
    meta = arm_metadata(run, model_terms=("coulomb_friction", "viscous_friction"), nominal=nominal)
    write_arm_run(tmp_path / "delay.mcap", run, metadata=meta)
    loaded = load_log(tmp_path / "delay.mcap")
    cfg = AnalysisConfig(robot_options={"manipulator": ManipulatorOptions(cutoff_hz=20.0)})
    res = PLUGIN.analyze(loaded, cfg, lambda _m: None)
    doc = json.loads(json.dumps(res.to_dict()))
    adq = doc["adequacy"]
    assert adq["before"]["verdict"] == "does not explain"
    assert "actuator_delay(tau)" in adq["model"]
    assert "actuator_delay(tau)" in doc["discovery"]["named"]
    assert doc["discovery"]["engine"] == "calib.discovery"
    assert doc["discovery"]["details"]["named_keys"] == doc["discovery"]["named"]
    assert doc["estimate"]["method"].endswith("actuator_delay(tau)")
    d = doc["estimate"]["d"]
    assert d["identifiable"] is False or d["ci95"][0] - 1e-3 <= 0.02 <= d["ci95"][1] + 1e-3


@pytest.mark.skipif(not DFKI.is_dir(), reason="shared real recordings not present")
def test_dfki_run_gets_a_verdict() -> None:
    loaded = load_log(DFKI / "dp_C0_20220914_trajectory_00.mcap")
    cfg = AnalysisConfig(
        discovery=False,  # the verdict alone; discovery is the slow part
        robot_options={
            "manipulator": ManipulatorOptions(urdf=str(DFKI / "design_C.0_model_3.1_acrobot.urdf"))
        },
    )
    res = PLUGIN.analyze(loaded, cfg, lambda _m: None)
    adq = res.adequacy
    assert adq is not None
    assert adq.verdict == "does not explain"
    assert [c.channel for c in adq.channels] == ["tau1", "tau2"]
    assert adq.located
    assert all(c.heldout_ratio is not None and c.heldout_ratio > 1.5 for c in adq.channels)
    # under the misfit no parameter is reported as determined
    assert res.estimate is not None
    assert not any(e.identifiable for e in res.estimate.parameters.values())
    assert all(math.isfinite(e.std) for e in res.estimate.parameters.values())


def test_confounded_explanations_span_or_are_not_determined() -> None:
    f = _fitter("compliance")
    cat = {e.key: e for e in arm_catalogue(f.model.joint_names, f.baseline)}
    with_c = f.fit_arm((cat["joint_compliance(joint2)"],))
    without = f.fit_arm(())
    assert with_c is not None
    assert without is not None
    est = spanned(
        with_c.estimates(), [("payload", without.estimates())], "joint_compliance(joint2)"
    )
    for name in ("a1", "a2", "a3", "a4", "a5"):
        e = est[name]
        lo = min(with_c.estimates()[name].ci95[0], without.estimates()[name].ci95[0])
        hi = max(with_c.estimates()[name].ci95[1], without.estimates()[name].ci95[1])
        assert e.ci95 == (lo, hi)
        assert "cannot tell apart" in e.note
    assert not all(e.identifiable for k, e in est.items() if k[0] == "a")
