"""Catalogue-escaping physics ("kinds") of the independent generators: what each does, its
magnitude parameter and the range the magnitude is drawn from (log-uniform, from barely
detectable to large).

``HELD_OUT_KINDS`` are kept out of development: ``bench/adequacy_study.py`` leaves them out
unless ``--include-held-out``; do not tune anything on them before the final run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .robotlog import log_uniform

__all__ = ["HELD_OUT_KINDS", "KINDS", "ROBOTS", "KindDef", "draw_magnitude", "kinds_of"]

ROBOTS = ("tractor_trailer", "diff_drive", "arm")


@dataclass(frozen=True)
class KindDef:
    """A kind: ``robot``, magnitude ``param`` name and ``unit``, draw range [lo, hi] (log-uniform,
    ``signed``: a random sign), ``channels`` it changes (logical signals), ``doc``."""

    name: str
    robot: str
    param: str
    unit: str
    lo: float
    hi: float
    signed: bool
    channels: tuple[str, ...]
    doc: str


KINDS: dict[str, KindDef] = {
    k.name: k
    for k in (
        KindDef(
            "hitch_backlash",
            "tractor_trailer",
            "width",
            "rad",
            0.002,
            0.08,
            False,
            ("psi",),
            "play in the hitch encoder: the reading follows psi only once psi leaves a dead "
            "band of the given width around it (a backlash operator)",
        ),
        KindDef(
            "hitch_nonlinearity",
            "tractor_trailer",
            "a",
            "1",
            0.02,
            0.6,
            True,
            ("psi",),
            "encoder nonlinearity with unit gain at 0: psi_rec = psi + a (sin 2psi - 2psi)",
        ),
        KindDef(
            "trailer_swap",
            "tractor_trailer",
            "rel_change",
            "1",
            0.02,
            0.5,
            True,
            ("psi",),
            "the trailer is swapped mid-log: L2 -> L2 (1 + rel_change) at t_swap "
            "(30-70 % of the log); truth L2 is the first trailer's, L2_after the second's",
        ),
        KindDef(
            "clock_drift",
            "tractor_trailer",
            "drift",
            "s/s",
            1e-4,
            1e-2,
            True,
            ("psi",),
            "linear clock drift of the hitch topic: stamp = t (1 + drift)",
        ),
        KindDef(
            "trailer_slip",
            "tractor_trailer",
            "c",
            "s/m",
            0.002,
            0.1,
            False,
            ("psi",),
            "speed-dependent trailer side slip: psi' gets -c v^2 kappa",
        ),
        KindDef(
            "hitch_gain",
            "tractor_trailer",
            "gain_error",
            "1",
            0.005,
            0.15,
            True,
            ("psi",),
            "hitch-angle gain error: psi_rec = (1 + gain_error) psi",
        ),
        KindDef(
            "stuck_encoder",
            "diff_drive",
            "span",
            "s",
            0.2,
            10.0,
            False,
            ("wheel_left", "wheel_right"),
            "one wheel encoder is stuck for a span: its increments read 0 (the reading "
            "stays behind by the missed rotation afterwards)",
        ),
        KindDef(
            "dropped_increments",
            "diff_drive",
            "p",
            "1",
            0.002,
            0.1,
            False,
            ("wheel_left", "wheel_right"),
            "the encoder driver loses each reading's increment with probability p (a "
            "delta protocol): the cumulative angle of that wheel falls behind at random",
        ),
        KindDef(
            "wheel_slip",
            "diff_drive",
            "c",
            "s/m",
            0.005,
            0.3,
            False,
            ("x", "y", "yaw"),
            "speed-dependent longitudinal slip: ground speed of a wheel = r phi' (1 - c |r phi'|)",
        ),
        KindDef(
            "radius_change",
            "diff_drive",
            "rel_change",
            "1",
            0.003,
            0.1,
            True,
            ("x", "y", "yaw"),
            "one wheel's radius changes mid-log (tyre pressure): r -> r (1 + rel_change) at "
            "t_change (30-70 % of the log); truth radii are the ones before",
        ),
        KindDef(
            "joint_compliance",
            "arm",
            "compliance",
            "rad/(N*m)",
            1e-4,
            1e-2,
            False,
            ("q", "qd"),
            "elastic joints (quasi-static): the measured q is the motor side, q_m = q + "
            "tau_rigid / k, compliance = 1/k",
        ),
        KindDef(
            "torque_delay",
            "arm",
            "delay",
            "s",
            5e-4,
            3e-2,
            False,
            ("tau",),
            "actuation delay: the recorded effort is the command, which acts after a delay "
            "(effort(t) = tau(t + delay))",
        ),
        KindDef(
            "payload_pickup",
            "arm",
            "mass",
            "kg",
            0.02,
            2.0,
            False,
            ("tau",),
            "a point mass is picked up at the tip of the last link at t_pick (30-70 % of the log)",
        ),
        KindDef(
            "stribeck",
            "arm",
            "excess",
            "N*m",
            0.01,
            2.0,
            False,
            ("tau",),
            "Stribeck/stiction friction: (Fs - Fc) exp(-(qd/vs)^2) sign(qd) on top of "
            "Coulomb + viscous, excess = Fs - Fc",
        ),
        KindDef(
            "cogging",
            "arm",
            "amplitude",
            "N*m",
            0.005,
            1.0,
            False,
            ("tau",),
            "position-dependent cogging torque A sin(N q + phase) per joint (N 6-24)",
        ),
    )
}
"""Every kind by name."""

HELD_OUT_KINDS = frozenset({"hitch_nonlinearity", "dropped_increments", "cogging"})
"""One kind per robot that developers must not look at until the final run."""


def kinds_of(robot: str, *, include_held_out: bool = False) -> tuple[str, ...]:
    """The kinds of ``robot`` (held-out ones only with ``include_held_out``)."""
    return tuple(
        k
        for k, d in KINDS.items()
        if d.robot == robot and (include_held_out or k not in HELD_OUT_KINDS)
    )


def draw_magnitude(rng: np.random.Generator, kind: str) -> float:
    """A magnitude of ``kind``: log-uniform in [lo, hi], with a random sign if ``signed``."""
    d = KINDS[kind]
    m = log_uniform(rng, d.lo, d.hi)
    if d.signed and rng.random() < 0.5:
        m = -m
    return m
