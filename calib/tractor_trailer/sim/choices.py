"""Named choices of the simulator, importable without numpy (the CLI builds its options from
them at start-up)."""

from __future__ import annotations

from enum import StrEnum

__all__ = ["HitchModel", "PresetName"]


class HitchModel(StrEnum):
    """How the simulator moves the joint angle."""

    TRANSIENT = "transient"
    """The real kinematics d psi/dt = v kappa - (v sin psi - L1 v kappa cos psi)/L2."""
    STEADY = "steady"
    """psi on the patent's steady-state curve at every instant."""


class PresetName(StrEnum):
    """Names of the simulator presets (keys of
    :data:`calib.tractor_trailer.sim.presets.PRESETS`)."""

    HARMONIC = "harmonic"
    """The patent's harmonic command 0.2 sin(0.1 t) 1/m at a constant speed."""
    MIXED = "mixed"
    """Harmonic, curve, linear, constant and step commands in a repeating cycle of 249 s."""
