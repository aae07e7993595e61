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

__all__ = [
    "BASELINE_NAMES",
    "HELD_OUT_KINDS",
    "KINDS",
    "NEW_KINDS",
    "ROBOTS",
    "KindDef",
    "draw_magnitude",
    "is_correct_name",
    "kinds_of",
]

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
    accepted_names: tuple[str, ...] = ()
    """logcal catalogue effect keys that are a correct name for this physics (empty: only a
    described residual, or no name, is correct; ``id(*)``: that effect with any target).
    Written from the catalogues' meanings (``EffectSpec.physics``), not from what logcal
    happens to report."""


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
            accepted_names=("backlash(psi)",),
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
            accepted_names=("sensor_nonlinearity(psi)",),
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
            accepted_names=("clock_drift(hitch)",),
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
            accepted_names=("sensor_scale(psi)",),
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
            accepted_names=("encoder_stuck(*)",),
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
            accepted_names=("encoder_stuck(*)",),
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
            accepted_names=("wheel_slip(wheels)",),
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
            accepted_names=("joint_compliance(joint1)", "joint_compliance(joint2)"),
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
            accepted_names=("actuator_delay(tau)",),
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
            accepted_names=("payload_mass(tool)",),
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
        # ---- kinds added for the explanation study (issue 30): causes real machines have
        KindDef(
            "tyre_saturation",
            "tractor_trailer",
            "c",
            "rad",
            0.1,
            30.0,
            False,
            ("psi",),
            "the trailer's tyres leave their linear range: the axle's slip angle grows with the "
            "square of the lateral acceleration a = v^2 kappa and saturates at 0.15 rad, alpha = "
            "0.15 tanh(c (a/g) |a/g| / 0.15), psi' gets -v alpha / L2 (c: slip angle at 1 g if it "
            "did not saturate; large c: slippery ground, the tyres saturate at a fraction of g)",
        ),
        KindDef(
            "hitch_hysteresis",
            "tractor_trailer",
            "h",
            "rad",
            0.003,
            0.1,
            False,
            ("psi",),
            "friction hysteresis of the hitch-angle sensor, a smooth play (a Duhem model): z' = "
            "|psi'| / a (sign psi' - z), psi_rec = psi - h z, a = 2.5-5 h the angle over which "
            "the reading relaxes after a reversal (so the reading never runs backwards)",
            accepted_names=("backlash(psi)",),
        ),
        KindDef(
            "hitch_ripple",
            "tractor_trailer",
            "amplitude",
            "rad",
            0.001,
            0.05,
            False,
            ("psi",),
            "encoder eccentricity on a geared shaft: psi_rec = psi + A sin(N psi + phase), N 4-12 "
            "shaft turns per hitch radian",
        ),
        KindDef(
            "hitch_lowpass",
            "tractor_trailer",
            "time_constant",
            "s",
            0.03,
            1.0,
            False,
            ("psi",),
            "the hitch sensor's electronics low-pass filter the reading (first order, time "
            "constant tau): at low frequency a lag of tau",
            accepted_names=("clock_offset(hitch)",),
        ),
        KindDef(
            "tyre_growth",
            "diff_drive",
            "g",
            "s^2/m^2",
            0.01,
            0.5,
            False,
            ("x", "y", "yaw"),
            "centrifugal tyre growth: a wheel's rolling radius grows with its speed, ground "
            "speed u = r phi' (1 + g (r phi')^2) on both wheels",
        ),
        KindDef(
            "wheel_backlash",
            "diff_drive",
            "width",
            "rad",
            0.005,
            0.3,
            False,
            ("wheel_left", "wheel_right"),
            "gear backlash on one wheel (encoder on the motor side): the encoder leads the "
            "wheel by half the play in the direction of rotation, reading = phi + (w / 2) "
            "tanh(phi' / 0.02 rad/s)",
        ),
        KindDef(
            "yaw_slip",
            "diff_drive",
            "c",
            "s/rad",
            0.01,
            0.6,
            False,
            ("yaw",),
            "the wheels slide sideways more the faster the robot turns: yaw rate = omega_w (1 - "
            "c |omega_w|), omega_w the wheels' rolling yaw rate",
            accepted_names=("turn_slip(track)",),
        ),
        KindDef(
            "skid_varying",
            "diff_drive",
            "a",
            "1",
            0.01,
            0.5,
            False,
            ("yaw",),
            "the ground changes under a skid steer: the effective track varies over the log, "
            "b_eff(t) = b (1 + a (1 - cos(2 pi t / P)) / 2), P 8-25 s",
        ),
        KindDef(
            "wheel_eccentricity",
            "diff_drive",
            "amplitude",
            "rad",
            0.001,
            0.1,
            False,
            ("wheel_left", "wheel_right"),
            "an eccentric encoder disc on one wheel: once per revolution ripple, reading = phi + "
            "A sin(phi + phase)",
        ),
        KindDef(
            "joint_spring",
            "arm",
            "stiffness",
            "N*m/rad",
            0.1,
            10.0,
            False,
            ("tau",),
            "a torsion spring (cable, gravity-balancer) on one joint: the motor also supplies "
            "k (q - q_s), linear in the joint angle, q_s in [-0.5, 0.5] rad",
        ),
        KindDef(
            "gearbox_backlash",
            "arm",
            "width",
            "rad",
            0.001,
            0.05,
            False,
            ("q",),
            "gearbox play on one joint (encoder on the motor side): the measured angle leads "
            "the link by half the play in the direction of motion, q_rec = q + (w / 2) "
            "tanh(qd / 0.02 rad/s)",
        ),
        KindDef(
            "friction_drift",
            "arm",
            "rel_drop",
            "1",
            0.05,
            0.8,
            False,
            ("tau",),
            "the gearboxes warm up: Coulomb and viscous friction fall over the log, F(t) = F "
            "(1 - a (1 - exp(-t / (T / 3))))",
        ),
        KindDef(
            "load_friction",
            "arm",
            "mu",
            "1",
            0.01,
            0.3,
            False,
            ("tau",),
            "load-dependent gear friction (harmonic drives): mu |tau_rigid| sign(qd) on top of "
            "Coulomb + viscous",
        ),
    )
}
"""Every kind by name."""

HELD_OUT_KINDS = frozenset(
    {
        "hitch_nonlinearity",
        "dropped_increments",
        "cogging",
        # a third of the explanation study's new kinds
        "hitch_ripple",
        "skid_varying",
        "wheel_eccentricity",
        "load_friction",
    }
)
"""Kinds that developers must not look at until the final run (one per robot of the first set,
then four of the thirteen added for the explanation study)."""

BASELINE_NAMES: dict[str, tuple[str, ...]] = {
    "tractor_trailer": (),
    "diff_drive": ("wheel_radius_asymmetry(wheels)", "effective_track(track)"),
    "arm": tuple(
        f"{term}({j})"
        for term in ("coulomb_friction", "coulomb_friction_smooth", "viscous_friction")
        for j in ("joint1", "joint2")
    ),
}
"""logcal catalogue keys that are correct on every log of a robot's generator, clean or not:
the diff drive's wheels always differ in radius (up to 3 %) and its nominal track (metadata) is
off the true one by up to 5 % (logcal's ``effective_track(track)`` is b / b_nominal - 1); the
arm's joints always have Coulomb and viscous friction (a smoothed Coulomb term is the same
physics)."""


def is_correct_name(key: str, correct: tuple[str, ...] | frozenset[str] | set[str]) -> bool:
    """Whether catalogue key ``key`` is one of ``correct``: equal, or ``correct`` holds
    ``id(*)`` (any target of that effect id, e.g. ``encoder_stuck(*)`` for a span's label)."""
    if key in correct:
        return True
    return f"{key.split('(', 1)[0]}(*)" in correct


NEW_KINDS = (
    "tyre_saturation",
    "hitch_hysteresis",
    "hitch_ripple",
    "hitch_lowpass",
    "tyre_growth",
    "wheel_backlash",
    "yaw_slip",
    "skid_varying",
    "wheel_eccentricity",
    "joint_spring",
    "gearbox_backlash",
    "friction_drift",
    "load_friction",
)
"""The kinds added for the explanation study (issue 30)."""


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
