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

__all__ = [
    "BASE_PARAMS",
    "ModelSpec",
    "Vector",
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
    tl, kl, vl = th_s.tolist(), kappa_h.tolist(), v_h.tolist()
    sin, cos = math.sin, math.cos
    p = float(steady_psi(np.array([kl[0]]), L1, L2)[0]) if psi0 is None else psi0
    n = (len(tl) + 1) // 2
    out = [0.0] * n
    inv = 1.0 / lam if lam > 0 else 1e9
    reset = dict(anchors) if anchors else {}
    if 0 in reset:
        p = reset[0]
    out[0] = p

    def f(q: float, k: float, v: float) -> float:
        return v * (k * (L2 + L1 * cos(q)) - sin(q)) * inv

    for i in range(n - 1):
        j = 2 * i
        h = tl[j + 2] - tl[j]
        k0, km, k1 = kl[j], kl[j + 1], kl[j + 2]
        v0, vm, v1 = vl[j], vl[j + 1], vl[j + 2]
        travel = h * max(abs(v0), abs(vm), abs(v1)) * inv
        if travel <= MAX_STEP_LENGTHS:
            f1 = f(p, k0, v0)
            f2 = f(p + 0.5 * h * f1, km, vm)
            f3 = f(p + 0.5 * h * f2, km, vm)
            f4 = f(p + h * f3, k1, v1)
            p = p + h / 6.0 * (f1 + 2.0 * f2 + 2.0 * f3 + f4)
        else:  # sub-steps; inputs linear on each half of the step
            ns = math.ceil(travel / MAX_STEP_LENGTHS)
            hs = h / ns

            def at(u: float, a: float, b: float, c: float) -> float:
                return a + (b - a) * 2.0 * u if u <= 0.5 else b + (c - b) * (2.0 * u - 1.0)

            for s_ in range(ns):
                u0, uh, u1 = s_ / ns, (s_ + 0.5) / ns, (s_ + 1) / ns
                ka, kb, kc = at(u0, k0, km, k1), at(uh, k0, km, k1), at(u1, k0, km, k1)
                va, vb, vc = at(u0, v0, vm, v1), at(uh, v0, vm, v1), at(u1, v0, vm, v1)
                f1 = f(p, ka, va)
                f2 = f(p + 0.5 * hs * f1, kb, vb)
                f3 = f(p + 0.5 * hs * f2, kb, vb)
                f4 = f(p + hs * f3, kc, vc)
                p = p + hs / 6.0 * (f1 + 2.0 * f2 + 2.0 * f3 + f4)
        if reset and (i + 1) in reset:
            p = reset[i + 1]
        out[i + 1] = p
    return np.asarray(out)


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
    kh = data.command.at(data.th_s - delay) if delay else data.kappa_h
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
        out["omega"] = block_mean(om, m)
    if "psi" in data.outputs:
        lam = L2 if spec.baseline == "transient" else None
        for e, p in pairs:
            lam_e = e.relaxation_length(p)
            lam = lam_e if lam_e is not None else lam
        if lam is None:
            out["psi"] = block_mean(steady_psi(kappa, L1, L2), m)
        elif full_rate:
            out["psi"] = integrate_hitch_half(
                data.th_s, kh, vh, L1, L2, lam, data.psi0, data.anchors
            )
        else:
            k_d, v_d = block_mean(kappa, m), block_mean(v, m)
            out["psi"] = integrate_hitch(t, k_d, v_d, L1, L2, lam, data.psi0, data.anchors_d)
    if "psi" in out:
        for e, p in sorted(stage2, key=lambda x: x[0].order):
            out["psi"] = e.modify_output("psi", t, out["psi"], p)
    return out
