"""Scenario description (everything that defines one generated log) and random draws of it."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from .inputs import Command, Speed

__all__ = [
    "EFFECT_NAMES",
    "SMALL_ROBOT",
    "TOPICS",
    "Effects",
    "Robot",
    "Scenario",
    "TopicDef",
    "TopicSpec",
    "random_scenario",
    "small_robot_scenario",
]

Robot = Literal["tractor_trailer", "small_tractor_trailer"]

SMALL_ROBOT = {"wheelbase": 0.42, "L1": -0.02, "L2": 0.537}
"""The small ROS 2 tractor-trailer: steered-drive-wheel tractor, hitch 2 cm ahead of the axle."""


@dataclass(frozen=True)
class TopicDef:
    """A topic of a robot class: its name, message fields and the true signal of each field."""

    topic: str
    fields: tuple[str, ...]
    signals: tuple[str, ...]


TOPICS: dict[str, dict[str, TopicDef]] = {
    "tractor_trailer": {
        "cmd": TopicDef("/cmd/curvature", ("curvature",), ("kappa_cmd",)),
        "cmd_vel": TopicDef("/cmd/vel", ("v", "omega"), ("v_cmd", "omega_cmd")),
        "odom": TopicDef("/odom", ("v", "omega"), ("v", "omega")),
        "pose": TopicDef("/pose", ("x", "y", "yaw"), ("x", "y", "yaw")),
        "hitch": TopicDef("/hitch/angle", ("angle",), ("psi",)),
    },
    "small_tractor_trailer": {
        "cmd_vel": TopicDef("/cmd_vel", ("v", "delta"), ("v_cmd", "delta_cmd")),
        "encoder": TopicDef("/encoder/angle", ("angle",), ("psi",)),
        "odom": TopicDef("/odom", ("x", "y", "yaw"), ("x2", "y2", "yaw2")),
        "truck_pose": TopicDef("/truck_trailer/truck_pose", ("x", "y", "yaw"), ("x", "y", "yaw")),
        "kelo": TopicDef("/kelo_angle", ("angle",), ("delta",)),
        "tf": TopicDef("/tf", ("x", "y", "yaw"), ("x", "y", "yaw")),
    },
}
"""Topic groups per robot class. Signals: see ``Trajectory.signals``."""

EFFECT_NAMES = (
    "actuator_delay",
    "actuator_lag",
    "understeer",
    "sensor_offset(psi)",
    "sensor_scale(omega)",
    "clock_offset(hitch)",
    "clock_offset(odom)",
    "trailer_slip",
)
"""Effects ``random_scenario(effects=...)`` can switch on (keys as in the truth dict)."""


@dataclass(frozen=True)
class Effects:
    """True effects (all off by default). Conventions (same meaning as calib's catalogue):

    actuator_delay_s: d, kappa(t) = kappa_cmd(t - d).
    actuator_lag_s: tau, tau dkappa/dt = kappa_cmd(t - d) - kappa (a state of the ODE; it
        starts at rest at the command).
    understeer_K: K (s^2/m^2), kappa = kappa_lagged / (1 + K v^2) (v the actual speed).
    sensor_offset: by signal name (``psi``, ``omega``, ``v``, ...), recorded = true + offset.
    sensor_scale: by signal name, recorded = scale * true (applied before the offset).
    clock_offset_s: by topic group, stamp = true sample instant + offset (positive: late).
    trailer_slip: c (s/m), adds -c v^2 kappa to dpsi/dt (lateral slip of the trailer tyres;
        outside calib's catalogue; the trailer axle then does slip sideways).
    """

    actuator_delay_s: float = 0.0
    actuator_lag_s: float = 0.0
    understeer_K: float = 0.0
    sensor_offset: Mapping[str, float] = field(default_factory=dict)
    sensor_scale: Mapping[str, float] = field(default_factory=dict)
    clock_offset_s: Mapping[str, float] = field(default_factory=dict)
    trailer_slip: float = 0.0

    def truth(self) -> dict[str, dict[str, float]]:
        """The active effects, keyed like calib's catalogue (``id`` or ``id(target)``)."""
        out: dict[str, dict[str, float]] = {}
        if self.actuator_delay_s:
            out["actuator_delay"] = {"delay": self.actuator_delay_s}
        if self.actuator_lag_s:
            out["actuator_lag"] = {"time_constant": self.actuator_lag_s}
        if self.understeer_K:
            out["understeer"] = {"K": self.understeer_K}
        for k, v in self.sensor_offset.items():
            if v:
                out[f"sensor_offset({k})"] = {"offset": v}
        for k, v in self.sensor_scale.items():
            if v != 1.0:
                out[f"sensor_scale({k})"] = {"scale": v}
        for k, v in self.clock_offset_s.items():
            if v:
                out[f"clock_offset({k})"] = {"offset": v}
        if self.trailer_slip:
            out["trailer_slip"] = {"c": self.trailer_slip}
        return out


@dataclass(frozen=True)
class TopicSpec:
    """Sampling of one topic.

    rate_hz: nominal rate; the first sample is at a random phase in [0, 1/rate).
    sample_jitter_s: std of the true sample instants around the nominal grid (stamped
        correctly), clipped to +/- 0.2 / rate.
    stamp_noise_s: std of the error of the stamp against the true instant, clipped to
        +/- 0.2 / rate (so stamps stay increasing).
    drop_prob: probability of losing each sample independently.
    bursts_per_min, burst_s: rate of burst dropouts and the (min, max) length of each (s).
    noise: Gaussian noise std per message field.
    quantum: quantisation step per message field (recorded = round(value / q) * q, after noise).
    """

    rate_hz: float
    sample_jitter_s: float = 0.0
    stamp_noise_s: float = 0.0
    drop_prob: float = 0.0
    bursts_per_min: float = 0.0
    burst_s: tuple[float, float] = (0.1, 1.0)
    noise: Mapping[str, float] = field(default_factory=dict)
    quantum: Mapping[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Scenario:
    """Everything that defines one run; ``generate(scenario, seed)`` adds the random draws.

    robot: ``tractor_trailer`` (curvature commands, LOG_FORMAT.md topics) or
        ``small_tractor_trailer`` (steering-angle commands, the small ROS 2 robot's topics).
    L1, L2: link lengths (m); L1 < 0: hitch ahead of the axle.
    wheelbase: if set, ``command`` is a steering angle delta (rad) and kappa_cmd =
        tan(delta) / wheelbase; else ``command`` is the curvature (1/m).
    speed: commanded speed of C1; the actual speed is ``drive_gain`` times it.
    topics: sampled topic groups (absent group: topic absent), keys from ``TOPICS[robot]``.
    n_stalls, max_stall_s: recorder stalls: every topic loses all samples whose true instant
        falls in [start, start + length), length uniform in [0.2, max_stall_s] s.
    psi0, yaw0: initial hitch angle and heading (rad); C1 starts at the origin.
    start_ns: absolute time (ns) of t = 0.
    """

    robot: Robot = "tractor_trailer"
    L1: float = 1.25
    L2: float = 2.48
    duration_s: float = 63.0
    command: Command = field(default_factory=Command)
    speed: Speed = field(default_factory=Speed)
    effects: Effects = field(default_factory=Effects)
    topics: Mapping[str, TopicSpec] = field(
        default_factory=lambda: {
            g: TopicSpec(10.0) for g in ("cmd", "cmd_vel", "odom", "pose", "hitch")
        }
    )
    wheelbase: float | None = None
    drive_gain: float = 1.0
    n_stalls: int = 0
    max_stall_s: float = 3.0
    psi0: float = 0.0
    yaw0: float = 0.0
    start_ns: int = 1_760_000_000_000_000_000


def _sines(rng: np.random.Generator, n: int, fmin: float, fmax: float) -> dict[str, Any]:
    f = np.exp(rng.uniform(math.log(fmin), math.log(fmax), n))
    w = rng.uniform(0.3, 1.0, n) * rng.choice([-1.0, 1.0], n)
    return {
        "freqs_hz": tuple(float(x) for x in f),
        "phases": tuple(float(x) for x in rng.uniform(0, 2 * np.pi, n)),
        "weights": tuple(float(x) for x in w / np.abs(w).sum()),
    }


def _random_command(rng: np.random.Generator, M: float, T: float, kind: str) -> Command:
    if kind in ("H", "C", "L", "constant"):
        if kind == "L":
            M = M / max(1.0, 0.1 * T / math.pi - 1.0)
        return Command(kind, M=M)  # type: ignore[arg-type]
    if kind == "random":
        return Command("random", M=M, **_sines(rng, int(rng.integers(2, 6)), 0.005, 0.15))
    if kind == "chirp":
        return Command("chirp", M=M, f0_hz=0.005, f1_hz=float(rng.uniform(0.05, 0.3)), chirp_s=T)
    # steering-rate-limited steps
    n = int(rng.integers(2, 8))
    hold = T / (n + 1)
    rate = float(rng.choice([math.inf, 2 * M / rng.uniform(0.1, 0.5 * hold)]))
    times = tuple(float(hold * (i + 1) + rng.uniform(-0.2, 0.2) * hold) for i in range(n))
    levels = tuple(float(x) for x in rng.uniform(-M, M, n + 1))
    return Command("steps", M=M, step_times=times, step_levels=levels, rate=rate)


def _random_speed(rng: np.random.Generator, T: float, kind: str, reverse: bool, L2: float) -> Speed:
    v = float(rng.uniform(0.5, 6.0))
    rev = None
    if reverse:
        frac = float(rng.uniform(0.05, 0.2))
        ln = min(3.0, 0.4 * L2 / (frac * v) + 0.5)
        rev = (float(rng.uniform(0.3, 0.6) * T), ln, frac)
    if kind == "random":
        base: dict[str, Any] = {"kind": "random", "lo": 0.2, "hi": float(rng.uniform(1.0, 8.0))}
        base.update(_sines(rng, int(rng.integers(2, 5)), 0.005, 0.08))
        kt, kf = Speed.envelope(T, ramp_s=1.0, reverse=rev)
        return Speed(**base, knots_t=kt, knots_f=kf)
    stops: tuple[tuple[float, float], ...] = ()
    ramp = 0.0
    if kind == "ramp":
        ramp = float(rng.uniform(1.0, max(1.0, 0.3 * T)))  # a short log: a 1 s ramp
    elif kind == "stops":
        ramp = 2.0
        n = int(rng.integers(1, 4))
        starts = np.sort(rng.uniform(0.15 * T, 0.85 * T, n))
        stops = tuple((float(s), float(rng.uniform(1.0, 5.0))) for s in starts)
    kt, kf = Speed.envelope(T, ramp_s=ramp, ramp_down=kind == "ramp", stops=stops, reverse=rev)
    return Speed(base=v, knots_t=kt, knots_f=kf)


def random_scenario(
    rng: np.random.Generator, *, effects: Sequence[str] = (), **overrides: Any
) -> Scenario:
    """A random tractor-trailer scenario for sweeps (the curvature-command robot of LOG_FORMAT).

    Draws: L1 + L2 in 0.5-5 m and L1/(L1+L2) in -0.05-0.6; duration 30-90 s; command shape
    (H, C, L, constant, random, chirp, steps) with amplitude bounded so the steady-state hitch
    angle stays below 0.6 rad; speed profile (constant, ramp, stops, random smooth between 0.2
    and up to 8 m/s; a short reverse with probability 0.15); rates 5-200 Hz (common or per
    topic); noise, jitter, dropouts, bursts, stalls and hitch-encoder quantisation; ``cmd`` and
    ``hitch`` always present, ``cmd_vel``, ``odom``, ``pose`` each with probability 0.75.
    ``effects``: names from ``EFFECT_NAMES`` to switch on with random magnitudes (default none).
    ``overrides``: Scenario fields to set; ``L1``, ``L2``, ``duration_s`` are honoured before
    the dependent draws (command amplitude, speed profile).

    The run is integrated once (a few ms) and redrawn (up to 50 times) while the true |psi|
    reaches 0.65 rad, so |psi| < 0.65 rad holds unless the overrides force it.
    """
    from .physics import integrate

    scn = _draw_scenario(rng, effects, overrides)
    for _ in range(50):
        t = np.linspace(0.0, scn.duration_s, 2001)
        if np.abs(integrate(scn).signals(t)["psi"]).max() < 0.65:
            break
        scn = _draw_scenario(rng, effects, overrides)
    return scn


def _draw_scenario(
    rng: np.random.Generator, effects: Sequence[str], overrides: Mapping[str, Any]
) -> Scenario:
    total = float(rng.uniform(0.5, 5.0))
    ratio = float(rng.uniform(-0.05, 0.6))
    L1 = float(overrides.get("L1", ratio * total))
    L2 = float(overrides.get("L2", total - L1))
    T = float(overrides.get("duration_s", round(float(rng.uniform(30.0, 90.0)), 1)))
    M = float(rng.uniform(0.3, 1.0)) * math.sin(0.6) / (L2 + abs(L1))
    kind = str(rng.choice(["H", "C", "L", "constant", "random", "chirp", "steps"]))
    command = _random_command(rng, M, T, kind)
    skind = str(rng.choice(["constant", "ramp", "stops", "random"]))
    speed = _random_speed(rng, T, skind, bool(rng.random() < 0.15), L2)

    common = rng.random() < 0.5
    r0 = float(np.exp(rng.uniform(math.log(5), math.log(200))))
    noise_scale = float(rng.choice([0.0, 0.3, 1.0, 3.0]))
    std = {"v": 0.02, "omega": 0.005, "x": 0.02, "y": 0.02, "yaw": 0.005, "angle": 0.005}
    topics: dict[str, TopicSpec] = {}
    for g, tdef in TOPICS["tractor_trailer"].items():
        if g in ("cmd_vel", "odom", "pose") and rng.random() < 0.25:
            continue
        rate = r0 if common else float(np.exp(rng.uniform(math.log(5), math.log(200))))
        is_cmd = g.startswith("cmd")
        quantum: dict[str, float] = {}
        if g == "hitch" and rng.random() < 0.5:
            quantum["angle"] = 2 * math.pi / float(rng.choice([1024, 4096, 16384]))
        topics[g] = TopicSpec(
            rate_hz=rate,
            sample_jitter_s=float(rng.choice([0.0, 0.05])) / rate,
            stamp_noise_s=float(rng.choice([0.0, 0.05])) / rate,
            drop_prob=float(rng.choice([0.0, 0.01, 0.05])),
            bursts_per_min=float(rng.choice([0.0, 0.5, 2.0])),
            noise={} if is_cmd else {f: noise_scale * std[f] for f in tdef.fields},
            quantum=quantum,
        )
    eff = _random_effects(rng, effects)
    scn = Scenario(
        robot="tractor_trailer",
        L1=L1,
        L2=L2,
        duration_s=T,
        command=command,
        speed=speed,
        effects=eff,
        topics=topics,
        n_stalls=int(rng.integers(0, 3)),
        max_stall_s=float(rng.uniform(0.5, 4.0)),
    )
    return replace(scn, **overrides)


def _random_effects(rng: np.random.Generator, names: Sequence[str]) -> Effects:
    unknown = set(names) - set(EFFECT_NAMES)
    if unknown:
        raise ValueError(f"unknown effects {sorted(unknown)}; choose from {EFFECT_NAMES}")
    kw: dict[str, Any] = {}
    sign = float(rng.choice([-1.0, 1.0]))
    if "actuator_delay" in names:
        kw["actuator_delay_s"] = float(rng.uniform(0.1, 0.8))
    if "actuator_lag" in names:
        kw["actuator_lag_s"] = float(rng.uniform(0.1, 1.5))
    if "understeer" in names:
        kw["understeer_K"] = float(rng.uniform(0.02, 0.3))
    if "sensor_offset(psi)" in names:
        kw["sensor_offset"] = {"psi": sign * float(rng.uniform(0.02, 0.1))}
    if "sensor_scale(omega)" in names:
        kw["sensor_scale"] = {"omega": 1.0 + sign * float(rng.uniform(0.03, 0.15))}
    clocks = {}
    for g in ("hitch", "odom"):
        if f"clock_offset({g})" in names:
            clocks[g] = float(rng.choice([-1.0, 1.0])) * float(rng.uniform(0.1, 0.5))
    if clocks:
        kw["clock_offset_s"] = clocks
    if "trailer_slip" in names:
        kw["trailer_slip"] = float(rng.uniform(0.01, 0.05))
    return Effects(**kw)


def small_robot_scenario(
    rng: np.random.Generator, *, barely_moves: bool = False, **overrides: Any
) -> Scenario:
    """A run of the small ROS 2 tractor-trailer (``SMALL_ROBOT``): 10-23 s at 0.1-0.3 m/s with
    steering-angle commands (random smooth or rate-limited steps, |delta| <= 0.35 rad), one or
    two recorder stalls of up to 2.3 s; topics /cmd_vel ~7 Hz, /encoder/angle 54 Hz, /odom
    (trailer mocap) and /truck_trailer/truck_pose and /tf 29 Hz, /kelo_angle 20 Hz.

    ``barely_moves``: the robot is commanded as usual but moves 2 cm in all (drive_gain set
    accordingly).
    """
    T = float(overrides.get("duration_s", round(float(rng.uniform(10.0, 23.0)), 2)))
    v = float(rng.uniform(0.1, 0.3))
    amp = float(rng.uniform(0.15, 0.35))
    if rng.random() < 0.5:
        command = Command("random", M=amp, **_sines(rng, int(rng.integers(2, 4)), 0.03, 0.2))
    else:
        n = int(rng.integers(1, 4))
        times = tuple(float(x) for x in np.sort(rng.uniform(0.15 * T, 0.85 * T, n)))
        levels = tuple(float(x) for x in rng.uniform(-amp, amp, n + 1))
        command = Command("steps", M=amp, step_times=times, step_levels=levels, rate=1.0)
    kt, kf = Speed.envelope(T, ramp_s=0.5)
    speed = Speed(base=v, knots_t=kt, knots_f=kf)
    gain = 1.0
    if barely_moves:
        gain = 0.02 / float(
            np.trapezoid(np.abs(speed.values(np.linspace(0, T, 2001))), np.linspace(0, T, 2001))
        )
    mocap = {"x": 0.001, "y": 0.001, "yaw": 0.003}
    topics = {
        "cmd_vel": TopicSpec(7.0, sample_jitter_s=0.01),
        "encoder": TopicSpec(
            54.0, stamp_noise_s=0.001, quantum={"angle": 2 * math.pi / 4096}, noise={"angle": 0.001}
        ),
        "odom": TopicSpec(29.0, stamp_noise_s=0.002, noise=mocap),
        "truck_pose": TopicSpec(29.0, stamp_noise_s=0.002, noise=mocap),
        "kelo": TopicSpec(20.0, noise={"angle": 0.005}),
        "tf": TopicSpec(29.0, stamp_noise_s=0.002, noise=mocap),
    }
    scn = Scenario(
        robot="small_tractor_trailer",
        L1=SMALL_ROBOT["L1"],
        L2=SMALL_ROBOT["L2"],
        wheelbase=SMALL_ROBOT["wheelbase"],
        duration_s=T,
        command=command,
        speed=speed,
        topics=topics,
        drive_gain=gain,
        n_stalls=int(rng.integers(1, 3)),
        max_stall_s=2.3,
    )
    return replace(scn, **overrides)
