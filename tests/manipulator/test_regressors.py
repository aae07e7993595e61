"""Deterministic facts of the arm regressors: regressor x theta is the simulator's / pinocchio's
torque, the momentum form is M(q) qd and -(C^T qd - tau_g), base parameters regroup the payload."""

from __future__ import annotations

from pathlib import Path

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


DFKI_URDF = (
    Path(__file__).resolve().parents[3]
    / "shared/realworld_arm/dfki_double_pendulum/design_C.0_model_3.1_acrobot.urdf"
)


@pytest.mark.skipif(not DFKI_URDF.is_file(), reason="shared real recordings not present")
def test_published_dfki_model_with_gear_coupling_is_in_the_base_parameters() -> None:
    """The source's model (rotor inertia Ir through gear gr: (gr^2+1) Ir in M11, -gr Ir in M12,
    gr^2 Ir in M22) is exactly some theta of our design: the coupling needs no new column."""
    pytest.importorskip("pinocchio")
    from calib.manipulator.serial import load_serial_arm

    arm = load_serial_arm(str(DFKI_URDF), ("Joint1", "Joint2"), 2)
    d = make_design(arm, ())
    q, qd, qdd = _states(2, k=50, seed=4)
    m1, m2, l1, r1, r2, i1, i2, ir, gr, g = 0.64, 0.56, 0.2, 0.2, 0.32, 0.027, 0.054, 1e-4, 6, 9.81
    k, c2, s2 = m2 * l1 * r2, np.cos(q[:, 1]), np.sin(q[:, 1])
    m11 = i1 + i2 + m2 * l1**2 + 2 * k * c2 + (gr**2 + 1) * ir
    m12, m22 = i2 + k * c2 - gr * ir, i2 + gr**2 * ir
    g2 = g * m2 * r2 * np.sin(q[:, 0] + q[:, 1])
    tau = np.stack(
        [
            m11 * qdd[:, 0]
            + m12 * qdd[:, 1]
            - k * s2 * (2 * qd[:, 0] + qd[:, 1]) * qd[:, 1]
            + g * (m1 * r1 + m2 * l1) * np.sin(q[:, 0])
            + g2,
            m12 * qdd[:, 0] + m22 * qdd[:, 1] + k * s2 * qd[:, 0] ** 2 + g2,
        ],
        axis=1,
    )
    X = d.classic(q, qd, qdd)[0].reshape(-1, len(d.base))
    th, *_ = np.linalg.lstsq(X, tau.reshape(-1), rcond=None)
    np.testing.assert_allclose(X @ th, tau.reshape(-1), atol=1e-10)
    # and the coupling matters: without the armature columns it is not representable
    Xr = X[:, [i for i, n in enumerate(d.names) if "Ia[" not in n]]
    th_r, *_ = np.linalg.lstsq(Xr, tau.reshape(-1), rcond=None)
    assert np.abs(Xr @ th_r - tau.reshape(-1)).max() > 1e-4


def test_smooth_coulomb_is_an_alternative_column() -> None:
    arm = Planar2Link(PAPER_ARM)
    d = make_design(arm, (Term.COULOMB_SMOOTH, Term.VISCOUS))
    assert [n for n in d.names if n.startswith("Fcs")] == ["Fcs[joint1]", "Fcs[joint2]"]
    q, qd, qdd = _states(2)
    X = d.classic(q, qd, qdd)[0]
    k = d.term_slice(Term.COULOMB_SMOOTH)[0]
    np.testing.assert_allclose(X[:, 0, k], np.tanh(qd[:, 0] / 0.1))
