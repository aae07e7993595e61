"""State effects of the arm's catalogue, the encoder on the motor side: an elastic joint (the
link at q - c tau) and play in the joint's gear (the link at q - c sign(tau))."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.manipulator.discovery.hooks import Array, FitterView, StateEffect
from calib.manipulator.signals import zero_phase_lowpass

__all__ = ["COMPLIANCE_STEP_RAD", "PLAY_SMOOTHING", "ComplianceState", "PlayState"]

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


PLAY_SMOOTHING = 0.05
"""The play's switch between flanks is smoothed over this fraction of the joint torque's RMS
(a tanh of the torque: through zero torque the link crosses the gap)."""


@dataclass(frozen=True)
class PlayState(StateEffect):
    """Play in the joint's gear, the encoder on the motor side: the link sits on the flank the
    transmitted torque pushes it against, ``c`` rad behind the motor's reading (the link at
    ``q_J - c tanh(tau_J / (0.05 rms tau_J))``), its rates the motor's less the crossing of
    the gap."""

    joint: str

    def _side(self, fitter: FitterView) -> tuple[Array, Array, Array]:
        """The flank (+-1) from the logged torque, and how the motor-side reading's filtered
        angle, rate and acceleration follow it (the chain the signals went through)."""

        def make() -> tuple[Array, Array, Array]:
            s = fitter.sig
            tr = s.tau[:, fitter.model.joint_names.index(self.joint)]
            rms = float(np.sqrt(np.mean(tr**2)))
            side = np.tanh(tr / max(PLAY_SMOOTHING * rms, 1e-12))
            dt = 1.0 / s.rate_hz

            def low(x: Array) -> Array:
                return zero_phase_lowpass(x, s.rate_hz, s.cutoff_hz)

            rate = low(np.gradient(side, dt))
            return low(side), rate, low(np.gradient(rate, dt))

        out: tuple[Array, Array, Array] = fitter.cached(("play", self.joint), make)
        return out

    def shift(self, fitter: FitterView, c: float, dq: Array, dqd: Array, dqdd: Array) -> None:
        j = fitter.model.joint_names.index(self.joint)
        side, rate, acc = self._side(fitter)
        dq[:, j] -= c * side
        dqd[:, j] -= c * rate
        dqdd[:, j] -= c * acc

    def step(self, fitter: FitterView) -> float:
        return COMPLIANCE_STEP_RAD
