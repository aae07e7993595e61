"""Simulated arm logs with known truth and realistic sensors.

Two ways to move an arm:

* :func:`simulate_planar`: the paper's way, a persistently exciting torque (low- and
  high-frequency sinusoids) drives the planar 2-link arm's forward dynamics (RK4, 4 sub-steps per
  sample) with Coulomb + viscous friction and a held payload;
* :func:`simulate_trajectory`: the way identification experiments on real arms are run, a
  position-controlled Fourier-series exciting trajectory (5 harmonics of 0.1 Hz, kept inside the
  joint limits) whose torque comes from inverse dynamics of any :class:`ArmModel` plus friction,
  payload and torque offset.

Sensors (:class:`Sensors`): encoder quantisation of positions, velocity by backward differencing of
the quantised positions (plus optional extra noise), torque with Gaussian current noise, time
stamps with jitter and optionally repeated (stale) samples.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from calib.manipulator.design import COULOMB_SMOOTHING, coulomb
from calib.manipulator.model import ArmModel
from calib.manipulator.planar import PAPER_ARM, Planar2Link, Planar2Params

__all__ = [
    "ArmRun",
    "Friction",
    "Sensors",
    "fourier_trajectory",
    "paper_torque",
    "simulate_planar",
    "simulate_trajectory",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Friction:
    """Per-joint Coulomb (N*m) and viscous (N*m*s/rad) coefficients and torque offsets (N*m)."""

    coulomb: tuple[float, ...] = (0.1, 0.1)
    viscous: tuple[float, ...] = (0.1, 0.1)
    offset: tuple[float, ...] = ()

    def torque(self, qd: Array) -> Array:
        out = np.asarray(self.coulomb) * coulomb(qd) + np.asarray(self.viscous) * qd
        if self.offset:
            out = out + np.asarray(self.offset)
        return out


@dataclass(frozen=True)
class Sensors:
    """Sensor model; zeros give ideal sensors.

    Attributes:
        position_step: encoder quantisation step (rad), 0: none.
        velocity_noise: std of extra Gaussian noise on the differenced velocity (rad/s).
        torque_noise: std of the torque noise (N*m), per joint or one for all.
        jitter_s: half-width of uniform time-stamp jitter (s), below half the sample period.
        repeat_fraction: fraction of samples that repeat the previous sample's values.
    """

    position_step: float = 2 * np.pi / 2**16
    velocity_noise: float = 0.0
    torque_noise: float | tuple[float, ...] = 0.05
    jitter_s: float = 0.0
    repeat_fraction: float = 0.0


IDEAL = Sensors(position_step=0.0, torque_noise=0.0)


@dataclass(frozen=True)
class ArmRun:
    """A simulated log: what the sensors gave (``t_s``, ``q``, ``qd``, ``tau``) and the truth
    (``q_true``, ``qd_true``, ``qdd_true``, ``tau_true`` on the true time grid ``t_true``).
    ``truth`` maps parameter names to values; ``meta`` says how it was made."""

    t_s: Array
    q: Array
    qd: Array
    tau: Array
    t_true: Array
    q_true: Array
    qd_true: Array
    qdd_true: Array
    tau_true: Array
    joint_names: tuple[str, ...]
    truth: dict[str, float] = field(default_factory=dict)
    meta: dict[str, str] = field(default_factory=dict)


def paper_torque(t: Array) -> Array:
    """A persistently exciting torque for the paper's arm (N*m): low- and high-frequency
    sinusoids per joint (the paper's Eq. 24 did not survive; this mix is ours)."""
    w = 2 * np.pi
    t1 = 3.0 * np.sin(w * 0.3 * t) + 1.5 * np.sin(w * 2.1 * t) + 0.8 * np.sin(w * 5.3 * t)
    t2 = 1.2 * np.sin(w * 0.45 * t + 1.0) + 0.6 * np.sin(w * 3.1 * t) + 0.4 * np.sin(w * 7.7 * t)
    return np.stack([t1, t2], axis=1)


def _apply_sensors(
    t: Array, q: Array, tau: Array, sensors: Sensors, rng: np.random.Generator
) -> tuple[Array, Array, Array, Array]:
    step = sensors.position_step
    qm = np.round(q / step) * step if step > 0 else q.copy()
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    qdm = np.vstack([np.zeros((1, q.shape[1])), np.diff(qm, axis=0)]) / dt[:, None]
    qdm[0] = qdm[1]
    if sensors.velocity_noise > 0:
        qdm = qdm + rng.normal(0, sensors.velocity_noise, qdm.shape)
    sd = np.broadcast_to(np.asarray(sensors.torque_noise, float), (q.shape[1],))
    taum = tau + rng.normal(size=tau.shape) * sd
    stamps = t.copy()
    if sensors.jitter_s > 0:
        stamps = t + rng.uniform(-sensors.jitter_s, sensors.jitter_s, len(t))
        stamps = np.maximum.accumulate(stamps)
        stamps[1:] = np.maximum(stamps[1:], stamps[:-1] + 1e-6)
    if sensors.repeat_fraction > 0:
        rep = np.flatnonzero(rng.random(len(t)) < sensors.repeat_fraction)
        rep = rep[rep > 0]
        for k in rep:
            qm[k], qdm[k], taum[k] = qm[k - 1], qdm[k - 1], taum[k - 1]
    return stamps, qm, qdm, taum


def simulate_planar(
    params: Planar2Params = PAPER_ARM,
    friction: Friction | None = None,
    *,
    duration_s: float = 5.0,
    dt: float = 0.002,
    torque: Callable[[Array], Array] = paper_torque,
    q0: tuple[float, float] = (-np.pi / 2, 0.0),
    sensors: Sensors = IDEAL,
    seed: int = 0,
    delay_s: float = 0.0,
    lag_s: float = 0.0,
    compliance: tuple[float, ...] = (),
    payload_change: tuple[float, float] | None = None,
) -> ArmRun:
    """The planar arm driven by ``torque(t)`` from rest at ``q0`` (default hanging down).

    Switches for discovery (each 0 / empty / None: off):

    * ``delay_s``: the logged torque ``torque(t)`` acts at ``t + delay_s`` (actuation delay);
    * ``lag_s``: the logged torque acts through a first-order lag of time constant ``lag_s``;
    * ``compliance``: per joint ``c = 1/k`` (rad/(N·m)) of an elastic joint whose encoder reads
      the motor side: with no rotor inertia the spring carries the acting torque, so the logged
      position is the link's plus ``c tau`` (truth keys ``c[joint]``);
    * ``payload_change``: ``(t_s, kg)``: the payload becomes ``kg`` at ``t_s`` (picked up or put
      down mid-log; truth keys ``payload_after``, ``payload_change_t``).
    """
    fr = friction or Friction()
    arm = Planar2Link(params)
    th = params.theta()
    th_after = th
    t_change = math.inf
    if payload_change is not None:
        t_change = float(payload_change[0])
        th_after = replace(params, payload=float(payload_change[1])).theta()
    if fr.offset and len(fr.offset) != 2:
        raise ValueError("offset needs one value per joint")
    t = np.arange(0.0, duration_s + 0.5 * dt, dt)
    sub = 4
    h = dt / sub

    a_before = tuple(float(v) for v in th)
    a_after = tuple(float(v) for v in th_after)
    g = params.g
    fc = [float(v) for v in fr.coulomb]
    fv = [float(v) for v in fr.viscous]
    off = [float(v) for v in fr.offset] if fr.offset else [0.0, 0.0]
    vs = COULOMB_SMOOTHING
    half = h / 2
    t_fine = np.arange(0.0, duration_s + 2 * dt, half)
    acting = torque(t_fine - delay_s) if delay_s else torque(t_fine)
    if lag_s > 0:
        a_lag = math.exp(-half / lag_s)
        for k in range(1, len(acting)):
            acting[k] = a_lag * acting[k - 1] + (1 - a_lag) * acting[k]
    fine = acting.tolist()

    def accel(tt: float, x: tuple[float, ...]) -> tuple[float, float, float, float]:
        # scalar closed form of M^-1 (tau - C qd - tau_g - tau_f): this loop is the hot path
        q1, q2, d1, d2 = x
        a1, a2, a3, a4, a5 = a_after if tt >= t_change else a_before
        c2, s2 = math.cos(q2), math.sin(q2)
        c1, c12 = math.cos(q1), math.cos(q1 + q2)
        tau1, tau2 = fine[round(tt / half)]
        b1 = -a3 * s2 * (2 * d1 * d2 + d2 * d2) + g * (a4 * c1 + a5 * c12)
        b2 = a3 * s2 * d1 * d1 + g * a5 * c12
        r1 = tau1 - b1 - fc[0] * math.tanh(d1 / vs) - fv[0] * d1 - off[0]
        r2 = tau2 - b2 - fc[1] * math.tanh(d2 / vs) - fv[1] * d2 - off[1]
        m11, m12, m22 = a1 + a2 + 2 * a3 * c2, a2 + a3 * c2, a2
        det = m11 * m22 - m12 * m12
        return (d1, d2, (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det)

    x: tuple[float, ...] = (float(q0[0]), float(q0[1]), 0.0, 0.0)
    X = np.empty((len(t), 4))
    for k in range(len(t)):
        X[k] = x
        tk = k * dt
        for s in range(sub):
            ts = tk + s * h
            k1 = accel(ts, x)
            k2 = accel(ts + half, tuple(a + half * b for a, b in zip(x, k1, strict=True)))
            k3 = accel(ts + half, tuple(a + half * b for a, b in zip(x, k2, strict=True)))
            k4 = accel(ts + h, tuple(a + h * b for a, b in zip(x, k3, strict=True)))
            x = tuple(
                a + h / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
                for a, b1, b2, b3, b4 in zip(x, k1, k2, k3, k4, strict=True)
            )
    q, qd = X[:, :2], X[:, 2:]
    tau = torque(t)
    qdd = np.array([accel(k * dt, tuple(X[k]))[2:] for k in range(len(t))])
    q_motor = q
    if compliance:
        act = np.asarray(acting)[np.round(t / half).astype(int)]  # acting torque at t
        q_motor = q + np.asarray(compliance, float)[None, :] * act
    rng = np.random.default_rng(seed)
    stamps, qm, qdm, taum = _apply_sensors(t, q_motor, tau, sensors, rng)
    truth = {f"a{i + 1}": float(v) for i, v in enumerate(th)}
    truth |= _friction_truth(fr, arm.joint_names)
    truth |= {"payload": params.payload, "l1": params.l1, "l2": params.l2, "g": params.g}
    if delay_s:
        truth["delay_s"] = float(delay_s)
    if lag_s:
        truth["lag_s"] = float(lag_s)
    for j, c in enumerate(compliance):
        truth[f"c[{arm.joint_names[j]}]"] = float(c)
    if payload_change is not None:
        truth["payload_after"] = float(payload_change[1])
        truth["payload_change_t"] = float(payload_change[0])
    return ArmRun(
        stamps,
        qm,
        qdm,
        taum,
        t,
        q,
        qd,
        qdd,
        tau,
        arm.joint_names,
        truth,
        {"model": "planar2", "excitation": "torque"},
    )


def _friction_truth(fr: Friction, names: tuple[str, ...]) -> dict[str, float]:
    out: dict[str, float] = {}
    for j, n in enumerate(names):
        out[f"Fc[{n}]"] = float(fr.coulomb[j])
        out[f"Fv[{n}]"] = float(fr.viscous[j])
        if fr.offset:
            out[f"tau0[{n}]"] = float(fr.offset[j])
    return out


def fourier_trajectory(
    n: int,
    t: Array,
    *,
    seed: int = 0,
    base_hz: float = 0.1,
    harmonics: int = 5,
    center: Array | None = None,
    amplitude: Array | None = None,
    max_speed: float = 1.0,
) -> tuple[Array, Array, Array]:
    """(q, qd, qdd) of a random Fourier-series trajectory around ``center`` (default 0) whose
    excursion stays within ``amplitude`` (default 1 rad) and speed within ``max_speed``."""
    rng = np.random.default_rng(seed)
    wf = 2 * np.pi * base_hz
    k = np.arange(1, harmonics + 1)
    a = rng.normal(size=(n, harmonics)) / k
    b = rng.normal(size=(n, harmonics)) / k
    ph = np.outer(t, k) * wf  # (T, H)
    q = (np.sin(ph) @ (a / (wf * k)).T) - (np.cos(ph) @ (b / (wf * k)).T)
    qd = np.cos(ph) @ a.T + np.sin(ph) @ b.T
    qdd = (-np.sin(ph) * wf * k) @ a.T + (np.cos(ph) * wf * k) @ b.T
    q = q - q.mean(axis=0)
    amp = np.ones(n) if amplitude is None else np.asarray(amplitude, float)
    scale = np.minimum(amp / np.abs(q).max(axis=0), max_speed / np.abs(qd).max(axis=0))
    c = np.zeros(n) if center is None else np.asarray(center, float)
    return c + q * scale, qd * scale, qdd * scale


def simulate_trajectory(
    model: ArmModel,
    friction: Friction,
    *,
    duration_s: float = 20.0,
    rate_hz: float = 1000.0,
    payload: float = 0.0,
    theta: Array | None = None,
    sensors: Sensors | None = None,
    seed: int = 0,
    center: Array | None = None,
    amplitude: Array | None = None,
    max_speed: float = 1.0,
) -> ArmRun:
    """An exciting trajectory of ``model`` with torque from inverse dynamics (see module)."""
    sens = sensors or Sensors()
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    n = len(model.joint_names)
    q, qd, qdd = fourier_trajectory(
        n, t, seed=seed, center=center, amplitude=amplitude, max_speed=max_speed
    )
    if theta is None and model.nominal is None:
        raise ValueError("the model has no nominal parameters: pass theta")
    th = np.array(model.nominal if theta is None else theta, dtype=float)
    if payload:
        th = th + payload * model.payload_increment()
    tau = model.regressor(q, qd, qdd) @ th + friction.torque(qd)
    rng = np.random.default_rng(seed + 1_000_003)
    stamps, qm, qdm, taum = _apply_sensors(t, q, tau, sens, rng)
    truth = _friction_truth(friction, model.joint_names) | {"payload": payload}
    return ArmRun(
        stamps,
        qm,
        qdm,
        taum,
        t,
        q,
        qd,
        qdd,
        tau,
        model.joint_names,
        truth,
        {"excitation": "fourier trajectory"},
    )
