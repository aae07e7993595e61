"""The tractor-trailer model run on recorded inputs, with a baseline and optional effects.

Outputs: yaw rate omega = v kappa_actual and the joint angle psi (steady-state relation of the
patent, or the transient off-axle kinematics d psi/ds = [kappa (L2 + L1 cos psi) - sin psi] /
lambda, lambda = L2 unless an effect sets it).

A fit evaluates ``predict`` hundreds of times, moving one parameter at a time for its
finite-difference Jacobian (issue 14): each step of a prediction (the inputs as the vehicle
feels them, the joint angle before any sensor effect, the whole prediction) is remembered on
the ``DiscoveryData`` for exactly the parameters it depends on (``DiscoveryData.recall``),
and an effect remembers its costly step on read-only inputs (``effects.base.remembered``).
The results are read-only arrays, bit for bit those of a fresh computation.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from calib.tractor_trailer.discovery.data import DiscoveryData, block_mean
from calib.tractor_trailer.discovery.effects import Effect, ParamSpec
from calib.tractor_trailer.models.hitch_rk4 import rk4_hitch, rk4_hitch_half

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


@dataclass(frozen=True)
class _SubstepPlan:
    """Where the RK4 steps take their inputs when sample steps are split into ``ns``
    sub-steps: per step and stage (start, middle, end) the half-grid points ``lo``, ``hi`` it
    lies between and the weight ``w`` of ``hi`` (0 at a grid point; all None without
    sub-steps); ``h`` the step lengths; ``marks`` the step counts that end at the samples
    (None: every step does)."""

    lo: NDArray[np.intp] | None
    hi: NDArray[np.intp] | None
    w: FloatArray | None
    h: FloatArray
    marks: list[int] | None

    @classmethod
    def build(cls, h: FloatArray, ns: NDArray[np.int64]) -> _SubstepPlan:
        if bool(np.all(ns == 1)):  # the grid's own stage values
            return cls(None, None, None, h, None)
        ends = np.cumsum(ns)  # RK4 steps done at each sample after the first
        step = np.repeat(np.arange(ns.size), ns)  # the sample step each RK4 step belongs to
        nss = ns[step]
        j = np.arange(step.size) - (ends - ns)[step]
        u = np.stack([j / nss, (j + 0.5) / nss, (j + 1) / nss], axis=1)
        # a sub-step takes the input linear on each half of its sample step; a whole step
        # takes the grid's own stage values
        second = u > 0.5
        w = np.where(second, 2.0 * u - 1.0, 2.0 * u)
        lo = 2 * step[:, None] + second
        whole = (nss == 1)[:, None]
        exact = 2 * step[:, None] + np.arange(3)[None, :]
        return cls(
            np.where(whole, exact, lo),
            np.where(whole, exact, lo + 1),
            np.where(whole, 0.0, w),
            h[step] / nss,
            ends.tolist(),
        )

    def stages(self, x_h: FloatArray) -> FloatArray:
        """The input ``x_h`` (on the half-step grid) at every step's three stages."""
        if self.lo is None or self.hi is None or self.w is None:  # no sub-steps: a view
            return sliding_window_view(x_h, 3)[::2]
        a = x_h[self.lo]
        return a + (x_h[self.hi] - a) * self.w


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
    is unstable), it restarts from the recorded angle. A step that ends at a reset is not
    split: its result is replaced (a gap between the windows of a long log would otherwise
    cost as many sub-steps as the rest of it).
    """
    p = float(steady_psi(kappa_h[:1], L1, L2)[0]) if psi0 is None else psi0
    inv = 1.0 / lam if lam > 0 else 1e9
    reset = dict(anchors) if anchors else {}
    if 0 in reset:
        p = reset[0]
    # d psi/dt = v k (L2 + L1 cos psi) / lam - v sin(psi) / lam
    out = rk4_hitch_half(
        th_s, kappa_h, v_h, L2 * inv, L1 * inv, inv, inv, MAX_STEP_LENGTHS, p, reset
    )
    if out is not None:  # compiled: the steps below without building their stage arrays
        return out
    # the same steps in numpy, for rk4_hitch (when the compiled loops were not built)
    h = th_s[2::2] - th_s[:-2:2]
    v0, vm, v1 = v_h[:-2:2], v_h[1::2], v_h[2::2]
    travel = h * np.maximum(np.maximum(np.abs(v0), np.abs(vm)), np.abs(v1)) * inv
    ns = np.where(travel > MAX_STEP_LENGTHS, np.ceil(travel / MAX_STEP_LENGTHS), 1).astype(int)
    reset_steps = [i - 1 for i in reset if 1 <= i <= ns.size]
    if reset_steps:
        ns[reset_steps] = 1
    plan = _SubstepPlan.build(h, ns)
    vx = plan.stages(v_h)
    kx = plan.stages(kappa_h)
    marks = plan.marks
    if marks is None:
        resets = {i: float(x) for i, x in reset.items() if 1 <= i <= ns.size}
    else:
        resets = {marks[i - 1]: float(x) for i, x in reset.items() if 1 <= i <= len(marks)}
    psi = rk4_hitch(plan.h, vx * kx, vx, L2 * inv, L1 * inv, inv, p, keep=marks, resets=resets)
    return psi[:, 0, 0]


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
    discretisation error; used for the final fit and its intervals.

    The result (read-only arrays) and its intermediate steps are remembered on ``data``
    (``DiscoveryData.recall``) for the parameters they depend on."""
    key = (spec, np.asarray(theta, dtype=float).tobytes(), full_rate, fine)
    return data.recall("predict", key, lambda: _predict(spec, theta, data, full_rate, fine))


def _predict(
    spec: ModelSpec, theta: Vector, data: DiscoveryData, full_rate: bool, fine: bool
) -> dict[str, FloatArray]:
    if fine and not full_rate:
        full = predict(spec, theta, data, full_rate=True)
        return {c: _frozen(block_mean(y, data.m)) for c, y in full.items()}
    L1, L2, eff_params = spec.split(theta)
    pairs = list(zip(spec.effects, eff_params, strict=True))
    inputs = _inputs(data, pairs)
    m = 1 if full_rate else data.m
    stage2 = [x for x in pairs if x[0].stage == 2]
    t = data.t_s if full_rate else data.tc_s
    out: dict[str, FloatArray] = {}
    if "omega" in data.outputs:
        # the yaw rate is modelled at the full rate (it follows command jumps), its sensor
        # effects applied there, then averaged onto the output grid
        om = inputs.omega
        for e, p in sorted(stage2, key=lambda x: x[0].order):
            om = e.modify_output("omega", data.t_s, om, p)
        if om is inputs.omega:  # no sensor effect on it: the same for every such model
            out["omega"] = inputs.omega_recorded(m)
        else:
            out["omega"] = block_mean(as_recorded(data, "omega", om), m)
    if "psi" in data.outputs:
        lam = L2 if spec.baseline == "transient" else None
        for e, p in pairs:
            lam_e = e.relaxation_length(p)
            lam = lam_e if lam_e is not None else lam
        # restarts take the recorded angle with the joint-angle sensor's effects taken out
        psi0 = _true_psi(data.psi0, stage2)
        anchors = {
            i: _true_psi(y, stage2)
            for i, y in (data.anchors if full_rate else data.anchors_d).items()
        }
        psi_key = (inputs.key, full_rate, L1, L2, lam, psi0, tuple(anchors.items()))
        psi = data.recall(
            "psi",
            psi_key,
            lambda: _frozen(_true_joint_angle(inputs, full_rate, L1, L2, lam, psi0, anchors)),
        )
        for e, p in sorted(stage2, key=lambda x: x[0].order):
            psi = e.modify_output("psi", t, psi, p)
        if full_rate:  # on the fitting grid the joint angle is modelled at block means already
            psi = as_recorded(data, "psi", psi)
        out["psi"] = psi
    return {c: _frozen(y) for c, y in out.items()}


def _frozen(y: FloatArray) -> FloatArray:
    """``y`` made read-only: remembered results are shared between callers."""
    y.flags.writeable = False
    return y


class _Inputs:
    """Commanded curvature (1/m) and speed (m/s) as the vehicle feels them, on the half-step
    grid (``kh``, ``vh``), for one set of input-effect parameters (``key``), and what is
    derived from them, each computed when first asked for."""

    def __init__(self, data: DiscoveryData, key: Hashable, kh: FloatArray, vh: FloatArray):
        self.data, self.key = data, key
        self.kh, self.vh = _frozen(kh), _frozen(vh)
        self.kappa, self.v = self.kh[0::2], self.vh[0::2]
        self._recorded: dict[int, FloatArray] = {}

    @cached_property
    def omega(self) -> FloatArray:
        """True yaw rate on the aligned grid (rad/s)."""
        return _frozen(self.v * self.kappa)

    def omega_recorded(self, m: int) -> FloatArray:
        """The yaw rate as recorded without sensor effects, averaged over blocks of ``m``."""
        out = self._recorded.get(m)
        if out is None:
            out = _frozen(block_mean(as_recorded(self.data, "omega", self.omega), m))
            self._recorded[m] = out
        return out

    @cached_property
    def half_d(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Time (s), curvature and speed of the fitting grid on its half-step grid."""
        m = self.data.m
        k_d, v_d = block_mean(self.kappa, m), block_mean(self.v, m)
        return _half_tc(self.data), _with_midpoints(k_d), _with_midpoints(v_d)


def _half_tc(data: DiscoveryData) -> FloatArray:
    return data.recall("half_tc", None, lambda: _frozen(_with_midpoints(data.tc_s)), 1)


def _inputs(data: DiscoveryData, pairs: Sequence[tuple[Effect, dict[str, float]]]) -> _Inputs:
    """The inputs of a model whose effects and their parameters are ``pairs``; remembered
    for the parameters of the effects that change them (a finite-difference Jacobian column
    of a link length or an output effect reuses the inputs of the point it varies)."""
    delay = sum(e.input_delay(p) for e, p in pairs)
    movers = [(e, tuple(p.items())) for e, p in pairs if e.stage == 0 or e.changes_inputs]
    key = (delay, tuple(movers))

    def make() -> _Inputs:
        kh = data.delayed_command(delay) if delay else data.kappa_h
        vh = data.v_h
        # clock offsets of a sensor group move its inputs back onto the true clock first
        for e, p in (x for x in pairs if x[0].stage == 2):
            kh, vh = e.modify_inputs(data.th_s, kh, vh, p)
        for e, p in sorted((x for x in pairs if x[0].stage == 0), key=lambda x: x[0].order):
            kh, vh = e.modify_inputs(data.th_s, kh, vh, p)
        return _Inputs(data, key, kh, vh)

    return data.recall("inputs", key, make)


def _true_joint_angle(
    inputs: _Inputs,
    full_rate: bool,
    L1: float,
    L2: float,
    lam: float | None,
    psi0: float,
    anchors: Mapping[int, float],
) -> FloatArray:
    """The modelled true joint angle (rad) before any sensor effect, on the aligned grid
    (``full_rate``) or the fitting grid; ``anchors`` index that grid."""
    data = inputs.data
    if lam is None:
        m = 1 if full_rate else data.m
        return block_mean(steady_psi(inputs.kappa, L1, L2), m)
    if full_rate:
        return integrate_hitch_half(data.th_s, inputs.kh, inputs.vh, L1, L2, lam, psi0, anchors)
    th, kh, vh = inputs.half_d
    return integrate_hitch_half(th, kh, vh, L1, L2, lam, psi0, anchors)


def as_recorded(data: DiscoveryData, name: str, y: FloatArray) -> FloatArray:
    """Output ``name`` modelled on the aligned grid (``y``) as the log records it: sampled at
    its own topic's times and linearly interpolated back onto the grid, as the aligned frame
    was built (``data.sampled``; unchanged when the output is not known to be sampled so)."""
    ts = data.sampled.get(name)
    if ts is None:
        return y
    t = data.t_s[: y.size]
    return np.interp(t, ts, np.interp(ts, t, y))
