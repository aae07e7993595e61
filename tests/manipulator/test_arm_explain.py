"""The arm explains its log: physics the catalogue lacks is described by terms of the arm's own
signals and refitted with the dynamic parameters; a spring and gear play are named as such (not
absorbed into gravity, not taken for a payload); a catalogue name is given only when its model
is what explains; the findings come in the shared discovery shape.

Logs: the planar 2-link simulator (fixed seed), with the physics added to the logged torque or
the logged angle the way the machine would produce it (a spring's torque k q the motor supplies;
a drift of the torque reading; play: the motor-side encoder reads the link plus the gap on the
flank the torque pushes against)."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from calib.manipulator.adequacy import assess_arm
from calib.manipulator.design import Term
from calib.manipulator.discovery import ArmDiscovery, ArmFitter, run_discovery
from calib.manipulator.discovery.described import arm_library, physics_hint
from calib.manipulator.explain import arm_discovery_report, described_alternative
from calib.manipulator.identify import IdentifyConfig
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.signals import prepare_signals
from calib.manipulator.simulate import ArmRun, Friction, Sensors, simulate_planar

ARM = Planar2Params()
TERMS = (Term.COULOMB, Term.VISCOUS)
CFG = IdentifyConfig(terms=TERMS, cutoff_hz=20.0)
DRIFT = 0.5
"""N*m over the log on joint 1: 1/2 of the torques' spread at rest would be a warm-up."""
SPRING = 0.5
"""N*m/rad on joint 1."""
PLAY = 0.01
"""rad on joint 1 (0.6 degrees)."""
QD_SQUARED = 0.3
"""N*m/(rad/s)^2 on joint 2: drag growing with speed squared."""
STICTION = 0.5
"""N*m on joint 1 of friction beyond Coulomb below about 0.1 rad/s (a Stribeck curve)."""


@cache
def _clean() -> ArmRun:
    return simulate_planar(ARM, Friction(), duration_s=20.0, sensors=Sensors(), seed=3)


def _with(kind: str) -> ArmRun:
    run = _clean()
    tau, q = run.tau.copy(), run.q.copy()
    if kind == "drift":
        tau[:, 0] += DRIFT * run.t_s / run.t_s[-1]
    elif kind == "spring":
        tau[:, 0] += SPRING * run.q[:, 0]
    elif kind == "square":
        qd = np.gradient(run.q[:, 1], run.t_s)
        tau[:, 1] += QD_SQUARED * qd * np.abs(qd)
    elif kind == "stiction":
        qd = np.gradient(run.q[:, 0], run.t_s)
        tau[:, 0] += STICTION * np.sign(qd) * np.exp(-((qd / 0.1) ** 2))
    elif kind == "play":
        t1 = run.tau[:, 0]
        q[:, 0] = run.q[:, 0] + PLAY * np.tanh(t1 / (0.05 * np.sqrt(np.mean(t1**2))))
    return replace(run, tau=tau, q=q)


def _fitter(run: ArmRun, nominal: bool = False) -> ArmFitter:
    sig = prepare_signals(run.t_s, run.q, run.tau, cutoff_hz=CFG.cutoff_hz)
    model = Planar2Link(ARM)
    return ArmFitter(model, sig, TERMS, model.nominal if nominal else None, CFG)


@cache
def _discovered(kind: str, nominal: bool = False) -> tuple[ArmFitter, ArmDiscovery]:
    f = _fitter(_with(kind) if kind != "clean" else _clean(), nominal)
    return f, run_discovery(f)


def _inside(e: object, truth: float) -> bool:
    lo, hi = e.ci95  # type: ignore[attr-defined]
    return bool(lo <= truth <= hi)


def test_a_drift_is_described_and_the_model_then_explains() -> None:
    f, d = _discovered("drift")
    desc = d.description
    assert desc is not None
    assert desc.accepted
    terms = {t.term.name: t for t in desc.terms}
    assert "t" in terms
    assert terms["t"].entry == "joint1 torque"
    assert d.final is not None
    coef = d.final.effect_parameters[desc.spec.key]["joint1 torque: t"]
    assert _inside(coef, DRIFT)
    assert f.explained(d.final)
    assert not f.explained(d.selection.base)  # type: ignore[union-attr]
    # a catalogue effect the description makes redundant is not named
    assert all(e.key not in d.dropped for e in d.final.effects)
    assert desc.spec in d.final_effects


def test_drag_is_described_with_its_coefficient() -> None:
    f, d = _discovered("square")
    desc = d.description
    assert desc is not None
    assert desc.accepted
    fit = d.final or desc.fit
    pars = fit.effect_parameters[desc.spec.key]
    coef = pars["joint2 torque: qd2·|qd2|"]
    assert _inside(coef, QD_SQUARED)
    assert f.explained(fit)


def test_stiction_is_described_as_low_speed_friction() -> None:
    _, d = _discovered("stiction")
    desc = d.description
    assert desc is not None
    assert desc.accepted
    assert desc.heldout_gain >= 0.5
    words = [physics_hint(t.term) for t in desc.terms if t.entry == "joint1 torque"]
    assert any("stiction" in w for w in words)


def test_a_spring_is_named_a_spring_not_absorbed_into_gravity() -> None:
    f, d = _discovered("spring")
    assert [e.key for e in d.named] == ["joint_spring(joint1)"]
    (k,) = d.named[0].estimates
    assert _inside(k, SPRING)
    assert f.explained(d.selection.final)  # type: ignore[union-attr]


def test_play_is_named_play_not_a_payload() -> None:
    _f, d = _discovered("play", nominal=True)
    keys = [e.key for e in d.named]
    assert "gear_play(joint1)" in keys
    assert "payload(tool)" not in keys
    b = next(e for e in d.named if e.key == "gear_play(joint1)").estimates[0]
    assert _inside(b, PLAY)


def test_clean_log_names_and_describes_nothing() -> None:
    _, d = _discovered("clean")
    assert d.named == []
    assert d.description is None or not d.description.accepted


def test_report_in_the_shared_shape_names_only_what_explains() -> None:
    f, d = _discovered("spring")
    base = assess_arm(f)
    final = assess_arm(f, d.final_effects)
    assert base is not None
    assert final is not None
    assert not base.adequacy.explains
    assert final.adequacy.explains
    rep = arm_discovery_report(d, base.adequacy, final.adequacy, None, None).to_dict()
    assert rep["engine"] == "calib.discovery"
    assert rep["robot"] == "manipulator"
    assert rep["named"] == ["joint_spring(joint1)"]
    assert rep["verdict_before"]["verdict"] == "does not explain"
    assert rep["verdict_after"]["verdict"] == "explains"
    assert rep["details"]["named_keys"] == ["joint_spring(joint1)"]
    # the same effect, judged against a model that still does not explain: not a name
    partial = arm_discovery_report(d, base.adequacy, base.adequacy, None, None).to_dict()
    assert partial["named"] == []
    assert [e["status"] for e in partial["effects"]] == ["partial"]


def test_described_terms_read_as_physics() -> None:
    f, _ = _discovered("clean")
    lib = {t.name: t for t in arm_library(f)}
    assert "spring" in physics_hint(lib["q1"])
    assert "play" in physics_hint(lib["sign(qd2)·cos(q2)"])
    assert "friction" in physics_hint(lib["sign(qd1)"])
    assert "drift" in physics_hint(lib["t"])


def test_a_description_not_kept_but_not_rejected_is_an_alternative_to_span() -> None:
    f, d = _discovered("drift")
    desc = d.description
    assert desc is not None
    assert described_alternative(f, d, ()) is None  # kept: it is the model, not an alternative
    held_back = replace(d, description=replace(desc, accepted=False))
    alt = described_alternative(f, held_back, ())
    assert alt is not None
    label, pars = alt
    assert label == "described (not kept)"
    assert set(f.design.names) <= set(pars)
    rejected = replace(d, description=replace(desc, accepted=False, delta_bic=+1.0))
    assert described_alternative(f, rejected, ()) is None
