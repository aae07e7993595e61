"""State effects of the arm's catalogue: an elastic joint whose encoder reads the motor side
(the link is at q - c tau)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.manipulator.discovery.hooks import Array, FitterView, StateEffect

__all__ = ["COMPLIANCE_STEP_RAD", "ComplianceState"]

COMPLIANCE_STEP_RAD = 1e-3
"""Largest position change of the central difference along the torque (rad)."""


@dataclass(frozen=True)
class ComplianceState(StateEffect):
    """The link is at q_J - c tau_J (encoder on the motor side)."""

    joint: str

    def shift(self, fitter: FitterView, c: float, dq: Array, dqd: Array, dqdd: Array) -> None:
        s = fitter.sig
        j = fitter.model.joint_names.index(self.joint)
        a = -c
        tf = s.tau_f[:, j]
        td = np.gradient(tf, s.t_s)
        dq[:, j] += a * tf
        dqd[:, j] += a * td
        dqdd[:, j] += a * np.gradient(td, s.t_s)

    def step(self, fitter: FitterView) -> float:
        tf = fitter.sig.tau_f[:, fitter.model.joint_names.index(self.joint)]
        return COMPLIANCE_STEP_RAD / max(float(np.max(np.abs(tf))), 1e-9)
