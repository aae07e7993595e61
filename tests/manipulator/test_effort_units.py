"""The logged effort against what the model's nominal masses need: a motor current (effort in
another unit) is said plainly; a torque in N·m is not; a prismatic joint's force is in N."""

from __future__ import annotations

import numpy as np

from calib.manipulator.serial import load_serial_arm
from calib.manipulator.units import effort_scale, effort_unit


def _motion(n: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 8.0, n)[:, None]
    w = np.arange(1, 8)[None, :] * 0.3
    q = 0.4 * np.sin(w * t)
    return q, 0.4 * w * np.cos(w * t), -0.4 * w * w * np.sin(w * t)


def test_a_torque_in_n_m_passes_and_a_current_is_flagged() -> None:
    arm = load_serial_arm("panda", None, 7)
    q, qd, qdd = _motion()
    tau = np.einsum("njp,p->nj", arm.regressor(q, qd, qdd), arm.nominal)
    ok = effort_scale(arm, q, qd, qdd, tau)
    assert ok is not None
    assert ok.suspect == ()
    assert ok.note == ""
    judged = [f for f in ok.factors.values() if f is not None]
    assert judged
    assert np.allclose(judged, 1.0)
    current = effort_scale(arm, q, qd, qdd, tau / 40.0)  # amperes: 40 N·m per A after the gear
    assert current is not None
    assert set(current.suspect) == {k for k, f in current.factors.items() if f is not None}
    assert "torque constant x gear ratio" in current.note


def test_units_by_joint_kind() -> None:
    assert effort_unit("prismatic") == "N"
    assert effort_unit("revolute") == "N·m"
    tiago = load_serial_arm("tiago", ("torso_lift_joint", "arm_1_joint"), 2)
    assert tiago.joint_kinds() == ("prismatic", "revolute")
