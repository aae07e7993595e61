"""ICR construction checked against its geometric definition (not against its own formulas)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.models.icr import icr_construction


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


@settings(max_examples=60, deadline=None)
@given(
    x=st.floats(-100, 100),
    y=st.floats(-100, 100),
    yaw=st.floats(-np.pi, np.pi),
    psi=st.floats(-1.2, 1.2),
    kappa=st.floats(0.01, 0.5) | st.floats(-0.5, -0.01),
    L1=st.floats(0.3, 3.0),
    L2=st.floats(0.3, 3.0),
)
def test_definition(x, y, yaw, psi, kappa, L1, L2):
    c = icr_construction([x], [y], [yaw], [psi], [kappa], L1, L2)
    assert c.valid[0]
    heading = np.array([np.cos(yaw), np.sin(yaw)])
    oc1 = c.O[0] - c.C1[0]
    # O at distance |R| = 1/|kappa| from C1, on the perpendicular to the heading, turn side.
    assert np.linalg.norm(oc1) == pytest.approx(1 / abs(kappa), rel=1e-9)
    assert oc1 @ heading == pytest.approx(0.0, abs=1e-9 * (1 + abs(1 / kappa)))
    assert np.sign(_cross(heading, oc1)) == np.sign(kappa)
    # Link lengths.
    assert np.linalg.norm(c.C1[0] - c.P[0]) == pytest.approx(L1)
    assert np.linalg.norm(c.P[0] - c.C2[0]) == pytest.approx(L2)
    # Q on line O C1 and on line C2 P.
    scale = 1 + np.abs(c.Q[0]).max() + np.abs(c.O[0]).max()
    assert _cross(c.Q[0] - c.C1[0], oc1) == pytest.approx(0.0, abs=1e-9 * scale**2)
    assert _cross(c.Q[0] - c.P[0], c.C2[0] - c.P[0]) == pytest.approx(0.0, abs=1e-9 * scale**2)


def test_steady_state_o_on_rear_axle_line():
    """At the steady state the velocity of C2 is along link 2, so O C2 is perpendicular to it
    (right angle of triangle O Q C2 at C2)."""
    L1, L2 = 1.25, 2.48
    kappa = np.linspace(-0.35, 0.35, 41)
    kappa = kappa[np.abs(kappa) > 1e-2]
    psi = steady_state_psi(kappa, L1, L2)
    yaw = np.linspace(-3, 3, kappa.size)
    c = icr_construction(np.zeros_like(kappa), np.ones_like(kappa), yaw, psi, kappa, L1, L2)
    link2 = c.P - c.C2
    oc2 = c.O - c.C2
    dots = np.einsum("ij,ij->i", oc2, link2)
    np.testing.assert_allclose(dots, 0.0, atol=1e-9)
    # Triangle Q C1 P: right angle at C1.
    np.testing.assert_allclose(np.einsum("ij,ij->i", c.Q - c.C1, c.P - c.C1), 0.0, atol=1e-9)
    # Pythagoras twice (right angles at C1 and C2): |O C2|^2 = |O P|^2 - L2^2 = R^2 + L1^2 - L2^2.
    r2 = np.sqrt(c.R**2 + L1**2 - L2**2)
    np.testing.assert_allclose(np.linalg.norm(oc2, axis=1), r2, rtol=1e-9)


def test_hidden_where_kappa_near_zero():
    c = icr_construction(
        [0, 0, 0], [0, 0, 0], [0, 0, 0], [0.0, 0.1, np.pi / 2], [0.0, 1e-4, 0.2], 1.0, 2.0
    )
    assert c.valid.tolist() == [False, False, False]
    assert np.isnan(c.O).all()
    assert np.isnan(c.R).all()
    assert np.isfinite(c.C2).all()
