"""A planar 2-link arm in a vertical plane (independent of logcal): own Lagrangian dynamics, a
Fourier excitation trajectory, ``/joint_states`` sensors and a URDF of the same arm.

Link i (i = 1, 2): mass m_i, centre of mass c_i = (cx_i, cy_i) in its joint frame (x along the
link), rotational inertia I_i about the centre of mass (about the joint axis); l1 the distance
joint 1 -> joint 2; gravity g along -y of the plane (angles counter-clockwise from horizontal).
With Io_i = I_i + m_i |c_i|^2 and h(q2) = l1 (m2 cx2 cos q2 - m2 cy2 sin q2):

    M = [[Io1 + Io2 + m2 l1^2 + 2 h, Io2 + h], [Io2 + h, Io2]]
    C qd = [h' (2 qd1 qd2 + qd2^2), -h' qd1^2],   h' = -l1 (m2 cx2 sin q2 + m2 cy2 cos q2)
    G = g [(m1 cx1 + m2 l1) cos q1 - m1 cy1 sin q1 + m2 cx2 cos q12 - m2 cy2 sin q12,
           m2 cx2 cos q12 - m2 cy2 sin q12]
    tau = M qdd + C qd + G + Fc sign(qd) + Fv qd        (+ the kind's torque)

Kinds: torque terms (Stribeck, cogging, a joint spring, friction falling as the gearboxes warm,
load-dependent friction, a payload picked up), an actuation delay, and sensor-side angles
(elastic joints, gearbox play), see ``kinds.KINDS``.

The trajectory is prescribed (Fourier series per joint), so torques come from the inverse
dynamics; ``forward_dynamics`` (for tests) integrates the same model forward.

URDF (``urdf_text``): joint 1 at the origin with rpy (pi/2, 0, 0) and axis z (so the arm moves
in the world x-z plane with gravity -z), joint 2 at (l1, 0, 0) of link 1; each link's inertial
at (cx, cy, 0) with ixx = 0.1 I, iyy = I, izz = I. ``full_parameters`` gives logcal's full
parameter vector convention (pinocchio dynamic parameters about the joint frame origin:
m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz per link, keyed ``name[jointN]``; ``Ia``, ``Fc``,
``Fv`` per joint) from the true values - written out here from the definitions, not computed by
pinocchio.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .robotlog import FloatArray, RobotLog, Stream, grid, quantise

__all__ = [
    "PERTURBABLE",
    "ArmParams",
    "arm_log",
    "forward_dynamics",
    "full_parameters",
    "inverse_dynamics",
    "urdf_text",
]

JOINTS = ("joint1", "joint2")
BACKLASH_RATE = 0.02
"""Joint rate (rad/s) over which the gear play of ``gearbox_backlash`` is taken up."""


@dataclass(frozen=True)
class ArmParams:
    """True parameters of the 2-link arm (SI units; friction per joint)."""

    l1: float = 0.5
    l2: float = 0.4
    m1: float = 3.0
    m2: float = 1.5
    cx1: float = 0.25
    cy1: float = 0.0
    cx2: float = 0.2
    cy2: float = 0.0
    I1: float = 0.06
    I2: float = 0.02
    Fc: tuple[float, float] = (0.3, 0.2)
    Fv: tuple[float, float] = (0.2, 0.1)
    g: float = 9.81

    def with_tip_mass(self, mp: float) -> ArmParams:
        """The arm with a point mass ``mp`` at the tip (l2, 0) of link 2."""
        m2 = self.m2 + mp
        cx2 = (self.m2 * self.cx2 + mp * self.l2) / m2
        cy2 = self.m2 * self.cy2 / m2
        # inertia about the new COM: parallel axis for both bodies
        d_old = (self.cx2 - cx2) ** 2 + (self.cy2 - cy2) ** 2
        d_tip = (self.l2 - cx2) ** 2 + cy2**2
        I2 = self.I2 + self.m2 * d_old + mp * d_tip
        return replace(self, m2=m2, cx2=cx2, cy2=cy2, I2=I2)


def _terms(p: ArmParams, q: FloatArray) -> tuple[FloatArray, ...]:
    q1, q2 = q[:, 0], q[:, 1]
    mx2, my2 = p.m2 * p.cx2, p.m2 * p.cy2
    Io1 = p.I1 + p.m1 * (p.cx1**2 + p.cy1**2)
    Io2 = p.I2 + p.m2 * (p.cx2**2 + p.cy2**2)
    h = p.l1 * (mx2 * np.cos(q2) - my2 * np.sin(q2))
    hp = -p.l1 * (mx2 * np.sin(q2) + my2 * np.cos(q2))
    M11 = Io1 + Io2 + p.m2 * p.l1**2 + 2 * h
    M12 = Io2 + h
    M22 = np.full_like(q1, Io2)
    q12 = q1 + q2
    g2 = p.g * (mx2 * np.cos(q12) - my2 * np.sin(q12))
    g1 = p.g * ((p.m1 * p.cx1 + p.m2 * p.l1) * np.cos(q1) - p.m1 * p.cy1 * np.sin(q1)) + g2
    return M11, M12, M22, hp, g1, g2


def _friction(p: ArmParams, qd: FloatArray) -> FloatArray:
    return np.asarray(p.Fc) * np.sign(qd) + np.asarray(p.Fv) * qd


def rigid_torque(p: ArmParams, q: FloatArray, qd: FloatArray, qdd: FloatArray) -> FloatArray:
    """M qdd + C qd + G (n, 2), without friction."""
    M11, M12, M22, hp, g1, g2 = _terms(p, q)
    t1 = M11 * qdd[:, 0] + M12 * qdd[:, 1] + hp * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2) + g1
    t2 = M12 * qdd[:, 0] + M22 * qdd[:, 1] - hp * qd[:, 0] ** 2 + g2
    return np.column_stack([t1, t2])


def inverse_dynamics(p: ArmParams, q: FloatArray, qd: FloatArray, qdd: FloatArray) -> FloatArray:
    """Joint torques (n, 2) of the rigid arm with Coulomb + viscous friction."""
    return rigid_torque(p, q, qd, qdd) + _friction(p, qd)


def forward_dynamics(p: ArmParams, q: FloatArray, qd: FloatArray, tau: FloatArray) -> FloatArray:
    """Joint accelerations (n, 2) for torques ``tau`` (the inverse of ``inverse_dynamics``)."""
    M11, M12, M22, *_ = _terms(p, q)
    rest = tau - rigid_torque(p, q, qd, np.zeros_like(q)) - _friction(p, qd)
    det = M11 * M22 - M12 * M12
    a1 = (M22 * rest[:, 0] - M12 * rest[:, 1]) / det
    a2 = (-M12 * rest[:, 0] + M11 * rest[:, 1]) / det
    return np.column_stack([a1, a2])


def full_parameters(p: ArmParams) -> dict[str, float]:
    """The true full parameters in logcal's naming (see module docstring)."""
    out: dict[str, float] = {}
    for j, (m, cx, cy, Ic) in enumerate(
        ((p.m1, p.cx1, p.cy1, p.I1), (p.m2, p.cx2, p.cy2, p.I2)), 1
    ):
        n = f"joint{j}"
        out |= {
            f"m[{n}]": m,
            f"mx[{n}]": m * cx,
            f"my[{n}]": m * cy,
            f"mz[{n}]": 0.0,
            f"Ixx[{n}]": 0.1 * Ic + m * cy * cy,
            f"Ixy[{n}]": -m * cx * cy,
            f"Iyy[{n}]": Ic + m * cx * cx,
            f"Ixz[{n}]": 0.0,
            f"Iyz[{n}]": 0.0,
            f"Izz[{n}]": Ic + m * (cx * cx + cy * cy),
        }
    for j, n in enumerate(JOINTS):
        out |= {f"Ia[{n}]": 0.0, f"Fc[{n}]": p.Fc[j], f"Fv[{n}]": p.Fv[j]}
    return out


def urdf_text(p: ArmParams) -> str:
    """A URDF of the arm (see module docstring)."""

    def link(name: str, m: float, cx: float, cy: float, Ic: float) -> str:
        return (
            f'  <link name="{name}">\n    <inertial>\n'
            f'      <origin xyz="{cx!r} {cy!r} 0" rpy="0 0 0"/>\n'
            f'      <mass value="{m!r}"/>\n'
            f'      <inertia ixx="{0.1 * Ic!r}" ixy="0" ixz="0" iyy="{Ic!r}" iyz="0" '
            f'izz="{Ic!r}"/>\n    </inertial>\n  </link>\n'
        )

    lim = '<limit lower="-6.28" upper="6.28" effort="200" velocity="20"/>'
    return (
        '<?xml version="1.0"?>\n<robot name="indgen_planar2">\n'
        '  <link name="base_link"/>\n'
        + link("link1", p.m1, p.cx1, p.cy1, p.I1)
        + link("link2", p.m2, p.cx2, p.cy2, p.I2)
        + '  <joint name="joint1" type="revolute">\n    <parent link="base_link"/>\n'
        f'    <child link="link1"/>\n    <origin xyz="0 0 0" rpy="{math.pi / 2!r} 0 0"/>\n'
        f'    <axis xyz="0 0 1"/>\n    {lim}\n  </joint>\n'
        '  <joint name="joint2" type="revolute">\n    <parent link="link1"/>\n'
        f'    <child link="link2"/>\n    <origin xyz="{p.l1!r} 0 0" rpy="0 0 0"/>\n'
        f'    <axis xyz="0 0 1"/>\n    {lim}\n  </joint>\n</robot>\n'
    )


@dataclass(frozen=True)
class Fourier:
    """q_j(t) = q0_j + sum_k a_jk sin(k w t) + b_jk cos(k w t) (w = 2 pi f0)."""

    f0: float
    q0: FloatArray
    a: FloatArray
    b: FloatArray

    def eval(self, t: FloatArray, order: int = 0) -> FloatArray:
        """The ``order``-th derivative at ``t``, (n, 2)."""
        w = 2 * np.pi * self.f0
        k = np.arange(1, self.a.shape[1] + 1)
        ph = np.outer(t, k * w)  # (n, K)
        s, c = np.sin(ph), np.cos(ph)
        kw = (k * w) ** order
        # derivatives of sin / cos cycle with period 4
        d = [(s, c), (c, -s), (-s, -c), (-c, s)][order % 4]
        out = d[0] @ (self.a * kw).T + d[1] @ (self.b * kw).T
        return out + (self.q0 if order == 0 else 0.0)


def _trajectory(rng: np.random.Generator) -> Fourier:
    K = 5
    f0 = float(rng.uniform(0.08, 0.2))
    a = rng.normal(0, 1, (2, K)) / np.arange(1, K + 1)
    b = rng.normal(0, 1, (2, K)) / np.arange(1, K + 1)
    amp = rng.uniform(0.6, 1.2, 2)
    vmax = rng.uniform(1.5, 3.0, 2)
    tr = Fourier(f0, np.zeros(2), a, b)
    t = np.linspace(0, 1 / f0, 2000)
    scale = np.minimum(amp / np.abs(tr.eval(t)).max(0), vmax / np.abs(tr.eval(t, 1)).max(0))
    q0 = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-1.0, 1.0)])
    return Fourier(f0, q0, a * scale[:, None], b * scale[:, None])


def _params(rng: np.random.Generator) -> ArmParams:
    l1, l2 = float(rng.uniform(0.3, 0.6)), float(rng.uniform(0.25, 0.5))
    m1, m2 = float(rng.uniform(1.0, 5.0)), float(rng.uniform(0.5, 3.0))
    return ArmParams(
        l1=l1,
        l2=l2,
        m1=m1,
        m2=m2,
        cx1=l1 * float(rng.uniform(0.3, 0.6)),
        cy1=float(rng.uniform(-0.02, 0.02)),
        cx2=l2 * float(rng.uniform(0.3, 0.6)),
        cy2=float(rng.uniform(-0.02, 0.02)),
        I1=m1 * l1**2 / 12 * float(rng.uniform(0.8, 1.2)),
        I2=m2 * l2**2 / 12 * float(rng.uniform(0.8, 1.2)),
        Fc=(float(rng.uniform(0.1, 1.0)), float(rng.uniform(0.1, 0.6))),
        Fv=(float(rng.uniform(0.05, 0.5)), float(rng.uniform(0.03, 0.3))),
    )


PERTURBABLE = (
    "m1",
    "m2",
    "cx1",
    "cy1",
    "cx2",
    "cy2",
    "I1",
    "I2",
    "Fc1",
    "Fc2",
    "Fv1",
    "Fv2",
    "Ia1",
    "Ia2",
)
"""Parameters ``arm_log(perturb=...)`` shifts (additively): mass, centre of mass, inertia of
each link, Coulomb and viscous friction of each joint, and a rotor (armature) inertia ``Ia`` per
joint (0 unperturbed: the arm has none, logcal's model has one; it adds Ia qdd to the torque)."""


def _perturbed(p: ArmParams, dp: dict[str, float]) -> tuple[ArmParams, FloatArray]:
    if set(dp) - set(PERTURBABLE):
        raise ValueError(f"cannot perturb {sorted(set(dp) - set(PERTURBABLE))}")
    scalar = {k: getattr(p, k) + v for k, v in dp.items() if k[:2] not in ("Fc", "Fv", "Ia")}
    Fc = (p.Fc[0] + dp.get("Fc1", 0.0), p.Fc[1] + dp.get("Fc2", 0.0))
    Fv = (p.Fv[0] + dp.get("Fv1", 0.0), p.Fv[1] + dp.get("Fv2", 0.0))
    Ia = np.array([dp.get("Ia1", 0.0), dp.get("Ia2", 0.0)])
    return replace(p, **scalar, Fc=Fc, Fv=Fv), Ia


def arm_log(
    seed: int,
    kind: str | None = None,
    magnitude: float = 0.0,
    duration_s: float | None = None,
    *,
    perturb: dict[str, float] | None = None,
) -> RobotLog:
    """An arm log (``/joint_states``, JSON arrays) with ``kind`` at ``magnitude`` (None / 0:
    clean); ``files["arm.urdf"]`` is the URDF of the (payload-free) arm. Draws from ``seed``.
    ``perturb``: additive shifts of ``PERTURBABLE`` parameters (the truth reports the shifted
    values), for ``refit.refit_effect``."""
    rng = np.random.default_rng([seed, 0])
    T = duration_s if duration_s is not None else round(float(rng.uniform(20.0, 45.0)), 1)
    p = _params(rng)
    armature = np.zeros(2)
    if perturb:
        p, armature = _perturbed(p, dict(perturb))
    traj = _trajectory(rng)
    rate = float(rng.uniform(200.0, 500.0))
    ticks = int(rng.choice([2**14, 2**16, 2**18]))
    qd_sd = float(rng.uniform(0.002, 0.01))
    tau_sd = float(rng.uniform(0.02, 0.1))
    krng = np.random.default_rng([seed, 99])
    t_pick = float(krng.uniform(0.3, 0.7) * T)
    vs = float(krng.uniform(0.05, 0.2))
    cog_n = krng.integers(6, 25, 2)
    cog_ph = krng.uniform(0, 2 * np.pi, 2)
    m = magnitude if kind is not None else 0.0
    nrng = np.random.default_rng([seed, 98])  # the added kinds' own draws (older ones unchanged)
    kind_joint = int(nrng.integers(0, 2))
    spring_rest = float(nrng.uniform(-0.5, 0.5))
    on_joint = np.eye(2)[kind_joint]

    g = np.random.default_rng([seed, 1])
    t = grid(g, rate, T, jitter=0.01)

    def torque(tt: FloatArray) -> FloatArray:
        q, qd, qdd = traj.eval(tt), traj.eval(tt, 1), traj.eval(tt, 2)
        tau = inverse_dynamics(p, q, qd, qdd) + armature * qdd
        if kind == "payload_pickup" and m > 0:
            late = tt >= t_pick
            tau[late] = (
                inverse_dynamics(p.with_tip_mass(m), q[late], qd[late], qdd[late])
                + armature * qdd[late]
            )
        if kind == "stribeck":
            tau = tau + m * np.exp(-((qd / vs) ** 2)) * np.sign(qd)
        if kind == "cogging":
            tau = tau + m * np.sin(cog_n * q + cog_ph)
        if kind == "joint_spring":
            tau = tau + m * (q - spring_rest) * on_joint
        if kind == "friction_drift":
            drop = m * (1.0 - np.exp(-tt / (T / 3.0)))[:, None]
            tau = tau - drop * _friction(p, qd)
        if kind == "load_friction":
            tau = tau + m * np.abs(rigid_torque(p, q, qd, qdd)) * np.sign(qd)
        return tau

    q, qd = traj.eval(t), traj.eval(t, 1)
    effort = torque(t + (m if kind == "torque_delay" else 0.0))
    if kind == "joint_compliance" and m > 0:
        hstep = 1e-4

        def rig(tt: FloatArray) -> FloatArray:
            return rigid_torque(p, traj.eval(tt), traj.eval(tt, 1), traj.eval(tt, 2))

        q = q + m * rig(t)
        qd = qd + m * (rig(t + hstep) - rig(t - hstep)) / (2 * hstep)
    if kind == "gearbox_backlash":
        q = q + 0.5 * m * np.tanh(qd / BACKLASH_RATE) * on_joint
    n = t.size
    qq = 2 * np.pi / ticks
    pos = quantise(q, qq)
    vel = qd + g.normal(0, qd_sd, (n, 2))
    eff = effort + g.normal(0, tau_sd, (n, 2))
    stamps = 1_760_000_000_000_000_000 + np.round(t * 1e9).astype(np.int64)
    stream = Stream(
        "/joint_states",
        stamps,
        t,
        {"position": pos, "velocity": vel, "effort": eff},
        {"position": qq / math.sqrt(12), "velocity": qd_sd, "effort": tau_sd},
        constants={"name": list(JOINTS)},
        expected={"position": q, "velocity": qd, "effort": effort},
    )
    truth: dict[str, Any] = {
        "robot": "arm",
        "seed": seed,
        "duration_s": T,
        "kind": kind,
        "magnitude": m,
        "rate_hz": rate,
        "arm": dict(p.__dict__),
        "params": full_parameters(p),
    }
    if np.any(armature):
        truth["armature"] = [float(a) for a in armature]
    if kind == "payload_pickup":
        truth["t_pick_s"] = t_pick
    if kind == "stribeck":
        truth["stribeck_velocity"] = vs
    if kind == "cogging":
        truth["cogging_periods"] = [int(x) for x in cog_n]
    if kind in ("joint_spring", "gearbox_backlash"):
        truth["kind_joint"] = JOINTS[kind_joint]
    if kind == "joint_spring":
        truth["spring_rest_rad"] = spring_rest
    csv = {
        ("/joint_states", f, j): f"{c}{j + 1}"
        for f, c in (("position", "q"), ("velocity", "qd"), ("effort", "tau"))
        for j in range(2)
    }
    meta = {"logcal": {"robot": "manipulator", "joints": ",".join(JOINTS)}}
    return RobotLog(
        "arm", {"/joint_states": stream}, truth, meta, csv, files={"arm.urdf": urdf_text(p)}
    )
