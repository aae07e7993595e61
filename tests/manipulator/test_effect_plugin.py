"""An effect added to the arm the way a user would: its catalogue entry and its hook defined
here, in the test, registered with one line; nothing else of the package knows it.

The effect: a position-dependent torque ripple on joint 1 (gear cogging), a sin(8 q1): the
motor supplies it on top of what the link's dynamics need, so the logged torque carries it. The
log carrying it is a clean simulated log whose logged torque this test transforms with its own
code. Deterministic (fixed seeds)."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace
from functools import cache

import numpy as np
import pytest

from calib.discovery import EffectKind, EffectParam, EffectSpec, select_effects
from calib.manipulator.design import Term
from calib.manipulator.discovery import (
    ArmEffectModel,
    ArmFitter,
    Column,
    ColumnEffect,
    arm_catalogue,
    register_effect,
    run_discovery,
    unregister_effect,
)
from calib.manipulator.identify import IdentifyConfig
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.signals import prepare_signals
from calib.manipulator.simulate import ArmRun, Friction, Sensors, simulate_planar

ARM = Planar2Params()
TERMS = (Term.COULOMB, Term.VISCOUS)
CFG = IdentifyConfig(terms=TERMS, cutoff_hz=20.0)
AMPLITUDE = 0.2
"""N*m: four times the simulated torque sensor's noise."""
PERIODS = 8.0
KEY = "torque_ripple(joint1)"


@dataclass(frozen=True)
class Ripple(ColumnEffect):
    """sin(k q_J) on joint J: a column of the regressor (no momentum part)."""

    joint: str
    k: float

    def column(self, fitter: ArmFitter) -> Column | None:
        j = fitter.model.joint_names.index(self.joint)
        col = np.zeros((fitter.N, fitter.n, 1))
        col[:, j, 0] = np.sin(self.k * fitter.sig.q[:, j])
        return Column(np.zeros_like(col), col, col)


RIPPLE: EffectSpec[ArmEffectModel] = EffectSpec(
    "torque_ripple",
    "joint1",
    EffectKind.DYNAMICS,
    (EffectParam("ripple[joint1]", "N*m", 0.0, -np.inf, np.inf, 0.0),),
    "a position-dependent torque ripple (gear cogging), a sin(8 q)",
    model=Ripple("joint1", PERIODS),
)


@pytest.fixture
def registered() -> Iterator[None]:
    register_effect(RIPPLE)
    yield
    unregister_effect(RIPPLE)


@cache
def _clean() -> ArmRun:
    return simulate_planar(ARM, Friction(), duration_s=20.0, sensors=Sensors(), seed=3)


def _fitter(run: ArmRun) -> ArmFitter:
    sig = prepare_signals(run.t_s, run.q, run.tau, cutoff_hz=CFG.cutoff_hz)
    return ArmFitter(Planar2Link(ARM), sig, TERMS, None, CFG)


def _with_ripple(run: ArmRun) -> ArmRun:
    tau = run.tau.copy()
    tau[:, 0] += AMPLITUDE * np.sin(PERIODS * run.q[:, 0])
    return replace(run, tau=tau)


def test_registration_is_one_line_and_reversible(registered: None) -> None:
    keys = [e.key for e in arm_catalogue(("joint1", "joint2"), TERMS)]
    assert keys[-1] == KEY
    unregister_effect(RIPPLE)
    assert KEY not in [e.key for e in arm_catalogue(("joint1", "joint2"), TERMS)]
    with pytest.raises(ValueError, match="no model hook"):
        register_effect(EffectSpec("no_hook", "x", EffectKind.SENSOR, (), "nothing"))


def test_log_with_the_effect_names_it_and_the_heldout_fit_improves(registered: None) -> None:
    run = _with_ripple(_clean())
    joint1_turn = float(np.ptp(run.q[:, 0]))
    assert joint1_turn > 2 * np.pi / PERIODS  # the joint sweeps at least one ripple period
    d = run_discovery(_fitter(run))
    found = d.named[0]
    assert found.key == KEY
    assert found.rms_after < 0.8 * found.rms_before
    (a,) = found.estimates
    assert a.name == "ripple[joint1]"
    assert a.ci95[0] < AMPLITUDE < a.ci95[1]
    assert a.ci95[0] > 0


def test_clean_log_does_not_accept_it(registered: None) -> None:
    f = _fitter(_clean())
    assert run_discovery(f).named == []
    # tried even though the baseline explains the clean log: the engine does not take it
    sel = select_effects(f, (RIPPLE,), max_effects=1)
    assert sel is not None
    (t,) = sel.tried
    assert t.key == KEY
    assert not t.accepted


def test_extra_argument_and_the_fitter_take_it_without_registration() -> None:
    run = _with_ripple(_clean())
    f = _fitter(run)
    cat = {e.key: e for e in arm_catalogue(f.model.joint_names, TERMS, extra=(RIPPLE,))}
    assert KEY in cat
    with_r = f.fit_arm((cat[KEY],), 0, f.cut)
    without = f.fit_arm((), 0, f.cut)
    assert with_r is not None
    assert without is not None
    assert float(with_r.heldout_rms()[0]) < 0.8 * float(without.heldout_rms()[0])
    assert f.addable((RIPPLE,)) == [RIPPLE]
