"""The tractor-trailer model run on recorded inputs, with a baseline and optional effects.

Outputs: yaw rate omega = v kappa_actual and the joint angle psi (steady-state relation of the
patent, or the transient off-axle kinematics d psi/ds = [kappa (L2 + L1 cos psi) - sin psi] /
lambda, lambda = L2 unless an effect sets it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from calib.discovery.data import DiscoveryData, block_mean
from calib.discovery.effects import Effect, ParamSpec
from calib.models.hitch_rk4 import rk4_hitch

__all__ = [
    "BASE_PARAMS",
    "ModelSpec",
    "Vector",
    "as_recorded",
    "integrate_hitch",
    "integrate_hitch_half",
    "predict",
    "steady_psi",
]

FloatArray = NDArray[np.float64]
Vector = Sequence[float] | NDArray[np.float64]

# L1 may be zero or negative: a hitch ahead of the tractor's axle is real (L1 = -0.02 m on one
# robot); the models below hold for any sign of L1.
BASE_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec("L1", "m", 1.0, -5.0, 20.0, math.nan),
    ParamSpec("L2", "m", 2.0, 0.05, 30.0, math.nan),
)


@dataclass(frozen=True)
class ModelSpec:
    """A baseline ("steady" or "transient" hitch) plus a tuple of effects."""

    baseline: Literal["steady", "transient"]
    effects: tuple[Effect, ...] = ()

    @property
    def param_names(self) -> list[str]:
        """Flat names: "L1", "L2", then "<effect key>.<param>"."""
        return [p.name for p in BASE_PARAMS] + [
            f"{e.key}.{p.name}" for e in self.effects for p in e.params
        ]

    @property
    def param_specs(self) -> list[ParamSpec]:
        return list(BASE_PARAMS) + [p for e in self.effects for p in e.params]

    def with_effect(self, effect: Effect) -> ModelSpec:
        return ModelSpec(self.baseline, (*self.effects, effect))

    def split(self, theta: Vector) -> tuple[float, float, list[dict[str, float]]]:
        """(L1, L2, per-effect parameter dicts) from a flat vector."""
        L1, L2 = float(theta[0]), float(theta[1])
        out, i = [], 2
        for e in self.effects:
            d = {}
            for p in e.params:
                d[p.name] = float(theta[i])
                i += 1
            out.append(d)
        return L1, L2, out


def steady_psi(kappa: FloatArray, L1: float, L2: float) -> FloatArray:
    """Steady-state joint angle (rad); the asin argument is clipped so the result stays finite."""
    r = np.sqrt(1.0 + (kappa * L1) ** 2)
    return np.arctan(kappa * L1) + np.arcsin(np.clip(kappa * L2 / r, -1.0, 1.0))


def integrate_hitch(
    t_s: FloatArray,
    kappa: FloatArray,
    v: FloatArray,
    L1: float,
    L2: float,
    lam: float,
    psi0: float | None = None,
    anchors: Mapping[int, float] | None = None,
) -> FloatArray:
    """RK4 of d psi/dt = v [kappa (L2 + L1 cos psi) - sin psi] / lam from ``psi0`` (rad;
    default the steady state of the first curvature). Inputs are linear between samples.
    Units: s, 1/m, m/s, m; returns psi (rad). ``anchors``: sample index -> psi to reset the
    state to there (see ``integrate_hitch_half``).
    """
    return integrate_hitch_half(
        _with_midpoints(t_s),
        _with_midpoints(kappa),
        _with_midpoints(v),
        L1,
        L2,
        lam,
        psi0,
        anchors,
    )


def _with_midpoints(x: FloatArray) -> FloatArray:
    """``x`` on the half-step grid: samples at even indices, their means at odd ones."""
    out = np.empty(2 * x.size - 1)
    out[0::2] = x
    out[1::2] = 0.5 * (x[:-1] + x[1:])
    return out


MAX_STEP_LENGTHS = 0.25  # largest RK4 step, in relaxation lengths of travel


def integrate_hitch_half(
    th_s: FloatArray,
    kappa_h: FloatArray,
    v_h: FloatArray,
    L1: float,
    L2: float,
    lam: float,
    psi0: float | None = None,
    anchors: Mapping[int, float] | None = None,
) -> FloatArray:
    """RK4 as ``integrate_hitch`` on a half-step grid (samples at even, midpoints at odd
    indices); returns psi (rad) at the samples.

    A step that covers more than ``MAX_STEP_LENGTHS`` relaxation lengths of travel (high
    speed, a coarse grid or a gap in the recording) is split into sub-steps, the inputs
    linear between the grid points. ``anchors`` (sample index -> psi, rad) resets the state
    at those samples: where the model cannot run open loop (reversing, where the joint angle
    is unstable), it restarts from the recorded angle.
    """
    p = float(steady_psi(kappa_h[:1], L1, L2)[0]) if psi0 is None else psi0
    inv = 1.0 / lam if lam > 0 else 1e9
    reset = dict(anchors) if anchors else {}
    if 0 in reset:
        p = reset[0]
    h = th_s[2::2] - th_s[:-2:2]
    k0, km, k1 = kappa_h[:-2:2], kappa_h[1::2], kappa_h[2::2]
    v0, vm, v1 = v_h[:-2:2], v_h[1::2], v_h[2::2]
    travel = h * np.maximum(np.maximum(np.abs(v0), np.abs(vm)), np.abs(v1)) * inv
    ns = np.where(travel > MAX_STEP_LENGTHS, np.ceil(travel / MAX_STEP_LENGTHS), 1).astype(int)
    ends = np.cumsum(ns)  # RK4 steps done at each sample after the first
    if bool(np.all(ns == 1)):  # no sub-steps: the grid's own stage values
        kx = np.stack([k0, km, k1], axis=1)
        vx = np.stack([v0, vm, v1], axis=1)
        hs = h
    else:
        step = np.repeat(np.arange(ns.size), ns)  # the sample step each RK4 step belongs to
        nss = ns[step]
        j = np.arange(step.size) - (ends - ns)[step]

        def stage(u: FloatArray, x: tuple[FloatArray, ...], exact: FloatArray) -> FloatArray:
            """Input at fraction u of the sample step; sub-steps take it linear on each half."""
            a, b, c = x[0][step], x[1][step], x[2][step]
            sub = np.where(u <= 0.5, a + (b - a) * 2.0 * u, b + (c - b) * (2.0 * u - 1.0))
            return np.where(nss > 1, sub, exact[step])

        u0, uh, u1 = j / nss, (j + 0.5) / nss, (j + 1) / nss
        kk, vv = (k0, km, k1), (v0, vm, v1)
        kx = np.stack([stage(u0, kk, k0), stage(uh, kk, km), stage(u1, kk, k1)], axis=1)
        vx = np.stack([stage(u0, vv, v0), stage(uh, vv, vm), stage(u1, vv, v1)], axis=1)
        hs = h[step] / nss
    marks = ends.tolist()
    resets = {marks[i - 1]: float(x) for i, x in reset.items() if 1 <= i <= len(marks)}
    # d psi/dt = v k (L2 + L1 cos psi) / lam - v sin(psi) / lam
    out = rk4_hitch(hs, vx * kx, vx, L2 * inv, L1 * inv, inv, p, keep=marks, resets=resets)
    return out[:, 0, 0]


def _true_psi(y: float, stage2: Sequence[tuple[Effect, dict[str, float]]]) -> float:
    """The true joint angle (rad) behind a recorded one: the output effects undone, last
    applied first."""
    for e, p in sorted(stage2, key=lambda x: x[0].order, reverse=True):
        y = e.true_from_recorded("psi", y, p)
    return y


def predict(
    spec: ModelSpec,
    theta: Vector,
    data: DiscoveryData,
    *,
    full_rate: bool = False,
    fine: bool = False,
) -> dict[str, FloatArray]:
    """Modelled recordings of each output on the fitting grid (or with ``full_rate`` the
    aligned grid). ``fine`` computes on the aligned grid and block-averages to the fitting
    grid: slower (the hitch ODE runs at the full rate), free of the coarse grid's
    discretisation error; used for the final fit and its intervals."""
    if fine and not full_rate:
        full = predict(spec, theta, data, full_rate=True)
        return {c: block_mean(y, data.m) for c, y in full.items()}
    L1, L2, eff_params = spec.split(theta)
    pairs = list(zip(spec.effects, eff_params, strict=True))
    delay = sum(e.input_delay(p) for e, p in pairs)
    kh = data.delayed_command(delay) if delay else data.kappa_h
    vh = data.v_h
    # clock offsets of a sensor group move its inputs back onto the true clock first
    for e, p in (x for x in pairs if x[0].stage == 2):
        kh, vh = e.modify_inputs(data.th_s, kh, vh, p)
    for e, p in sorted((x for x in pairs if x[0].stage == 0), key=lambda x: x[0].order):
        kh, vh = e.modify_inputs(data.th_s, kh, vh, p)
    kappa, v = kh[0::2], vh[0::2]
    m = 1 if full_rate else data.m
    stage2 = [x for x in pairs if x[0].stage == 2]
    t = data.t_s if full_rate else data.tc_s
    out: dict[str, FloatArray] = {}
    if "omega" in data.outputs:
        # the yaw rate is modelled at the full rate (it follows command jumps), its sensor
        # effects applied there, then averaged onto the output grid
        om = v * kappa
        for e, p in sorted(stage2, key=lambda x: x[0].order):
            om = e.modify_output("omega", data.t_s, om, p)
        out["omega"] = block_mean(as_recorded(data, "omega", om), m)
    if "psi" in data.outputs:
        lam = L2 if spec.baseline == "transient" else None
        for e, p in pairs:
            lam_e = e.relaxation_length(p)
            lam = lam_e if lam_e is not None else lam
        # restarts take the recorded angle with the joint-angle sensor's effects taken out
        psi0 = _true_psi(data.psi0, stage2)
        if lam is None:
            out["psi"] = block_mean(steady_psi(kappa, L1, L2), m)
        elif full_rate:
            anchors = {i: _true_psi(y, stage2) for i, y in data.anchors.items()}
            out["psi"] = integrate_hitch_half(data.th_s, kh, vh, L1, L2, lam, psi0, anchors)
        else:
            k_d, v_d = block_mean(kappa, m), block_mean(v, m)
            anchors = {i: _true_psi(y, stage2) for i, y in data.anchors_d.items()}
            out["psi"] = integrate_hitch(t, k_d, v_d, L1, L2, lam, psi0, anchors)
    if "psi" in out:
        for e, p in sorted(stage2, key=lambda x: x[0].order):
            out["psi"] = e.modify_output("psi", t, out["psi"], p)
        if full_rate:  # on the fitting grid the joint angle is modelled at block means already
            out["psi"] = as_recorded(data, "psi", out["psi"])
    return out


def as_recorded(data: DiscoveryData, name: str, y: FloatArray) -> FloatArray:
    """Output ``name`` modelled on the aligned grid (``y``) as the log records it: sampled at
    its own topic's times and linearly interpolated back onto the grid, as the aligned frame
    was built (``data.sampled``; unchanged when the output is not known to be sampled so)."""
    ts = data.sampled.get(name)
    if ts is None:
        return y
    t = data.t_s[: y.size]
    return np.interp(t, ts, np.interp(ts, t, y))
