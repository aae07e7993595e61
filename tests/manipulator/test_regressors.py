"""Deterministic facts of the arm regressors: regressor x theta is the simulator's / pinocchio's
torque, the momentum form is M(q) qd and -(C^T qd - tau_g), base parameters regroup the payload."""

from __future__ import annotations

import numpy as np
import pytest

from calib.manipulator.design import Term, make_design
from calib.manipulator.planar import PAPER_ARM, Planar2Link
from calib.manipulator.simulate import Friction, simulate_planar


def _states(n: int, k: int = 7, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.normal(size=(k, n)), rng.normal(size=(k, n)), rng.normal(size=(k, n))


def test_planar_regressor_is_simulator_torque() -> None:
    fr = Friction(coulomb=(0.1, 0.2), viscous=(0.3, 0.05))
    run = simulate_planar(PAPER_ARM, fr, duration_s=1.0)
    arm = Planar2Link(PAPER_ARM)
    tau = arm.regressor(run.q_true, run.qd_true, run.qdd_true) @ PAPER_ARM.theta()
    tau = tau + fr.torque(run.qd_true)
    np.testing.assert_allclose(tau, run.tau_true, atol=1e-10)


def test_planar_momentum_forms() -> None:
    arm = Planar2Link(PAPER_ARM)
    th = PAPER_ARM.theta()
    q, qd, _ = _states(2)
    M = arm.mass_matrix(q, th)
    np.testing.assert_allclose(arm.momentum(q, qd) @ th, np.einsum("kij,kj->ki", M, qd))
    a3, s2, d1, d2 = th[2], np.sin(q[:, 1]), qd[:, 0], qd[:, 1]
    mdot_qd = np.stack([-a3 * s2 * d2 * (2 * d1 + d2), -a3 * s2 * d2 * d1], axis=1)
    expected = arm.bias(q, qd, th) - mdot_qd  # C qd + g - Mdot qd = -(C^T qd - g)
    np.testing.assert_allclose(arm.rest(q, qd) @ th, expected, atol=1e-12)


def test_planar_base_parameters_regroup_payload() -> None:
    d = make_design(Planar2Link(PAPER_ARM), (Term.COULOMB, Term.VISCOUS, Term.PAYLOAD))
    assert len(d.base) == 9
    assert d.names[0] == "a1 + 0.25·payload"
    assert d.names[3] == "a4 + 0.5·payload"


@pytest.fixture(scope="module")
def panda():
    pin = pytest.importorskip("pinocchio")
    from calib.manipulator.serial import load_serial_arm

    arm = load_serial_arm("panda", tuple(f"panda_joint{i}" for i in range(1, 8)), 7)
    return pin, arm


def test_pinocchio_regressor_and_momentum(panda) -> None:
    pin, arm = panda
    q, qd, qdd = _states(7, k=4, seed=3)
    th = arm.nominal
    m, d = arm.model, arm.model.createData()
    for k in range(len(q)):
        Q, V, A = arm._q(q[k : k + 1])[0], arm._q(qd[k : k + 1])[0], arm._q(qdd[k : k + 1])[0]
        tau = pin.rnea(m, d, Q, V, A)[arm._order]
        np.testing.assert_allclose(
            arm.regressor(q[k : k + 1], qd[k : k + 1], qdd[k : k + 1])[0] @ th, tau, atol=1e-9
        )
        M = pin.crba(m, d, Q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(
            arm.momentum(q[k : k + 1], qd[k : k + 1])[0] @ th, (M @ V)[arm._order], atol=1e-9
        )
        C = pin.computeCoriolisMatrix(m, d, Q, V)
        g = pin.computeGeneralizedGravity(m, d, Q)
        rest = -(C.T @ V - g)
        np.testing.assert_allclose(
            arm.rest(q[k : k + 1], qd[k : k + 1])[0] @ th, rest[arm._order], atol=1e-5
        )
