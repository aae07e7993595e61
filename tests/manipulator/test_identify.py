"""Identification: exact without noise, the paper's scenario, discovery on concealed terms."""

from __future__ import annotations

import numpy as np

from calib.manipulator.design import Term
from calib.manipulator.discovery import discover_arm
from calib.manipulator.identify import IdentifyConfig, identify_arm
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.reproduce import reproduce_momentum
from calib.manipulator.signals import prepare_signals
from calib.manipulator.simulate import IDEAL, Friction, Sensors, simulate_planar


def test_noise_free_identification_is_exact() -> None:
    p = Planar2Params(payload=0.2)
    fr = Friction(coulomb=(0.1, 0.15), viscous=(0.1, 0.05))
    run = simulate_planar(p, fr, duration_s=10.0, sensors=IDEAL)
    no_filter = IdentifyConfig(cutoff_hz=1e6)  # exact signals: nothing to filter
    res = identify_arm(
        Planar2Link(p), run.t_true, run.q_true, run.tau_true, no_filter, qd=run.qd_true
    )
    d = res.design
    truth = d.to_base(np.r_[p.theta(), fr.coulomb, fr.viscous])  # payload in a1..a5
    est = np.array([e.value for e in res.recommended.parameters.values()])
    np.testing.assert_allclose(est, truth, rtol=2e-3, atol=2e-4)
    assert res.feasibility.feasible
    assert res.holdout.ratio < 0.01


def test_paper_reproduction_facts() -> None:
    rep = reproduce_momentum()
    assert rep.omega_rank == 9
    s = rep.summary()
    assert s["paper-constrained on base parameters_median_s"] < s["RLS_median_s"]
    for row in rep.rows:
        for est in rep.trajectories:
            assert abs(row.final[est] - row.truth) < 0.01 * abs(row.truth)


def test_discovery_names_concealed_friction_and_is_quiet_on_clean() -> None:
    p = Planar2Params()
    run = simulate_planar(p, Friction(), duration_s=20.0, sensors=Sensors(), seed=5)
    sig = prepare_signals(run.t_s, run.q, run.tau)
    model = Planar2Link(p)
    hidden = discover_arm(model, sig, (), p.theta())
    assert hidden.named
    assert hidden.named[0].effect in ("viscous_friction", "coulomb_friction")
    # effects are per joint now (shared engine): together the named ones remove over half
    assert 1 - hidden.named[-1].rms_after / hidden.named[0].rms_before >= 0.5
    clean = discover_arm(model, sig, (Term.COULOMB, Term.VISCOUS), p.theta())
    assert clean.named == []
