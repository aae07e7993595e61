"""An Ackermann car, a robot defined entirely in this room: its wheelbase and steering offset
from its steering angle, speed and yaw rate through the shared bicycle kinematics
(:mod:`calib.kinematics.bicycle`: omega = v tan(steer - offset) / wheelbase), and what its
catalogue of effects adds, found by the shared discovery engine (:mod:`calib.discovery`: its
effects in an ``EffectRegistry``, chosen by ``select_effects``, judged on held-out blocks of
:func:`calib.stats.alternate_blocks`).

Its catalogue has no built-in entry; an effect (the gyro's bias, :data:`GYRO_BIAS`) joins with
one registration line, ``CAR_EFFECTS.register(GYRO_BIAS)``, and the robot with one more,
``logtools.robots.register(PLUGIN)``; no shared file changes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
from rich.console import RenderableType
from rich.text import Text
from scipy.optimize import least_squares

from calib.adequacy import ResidualChannel, assess
from calib.discovery import EffectKind, EffectParam, EffectRegistry, EffectSpec, ModelFit
from calib.discovery.selection import SelectionRules, select_effects
from calib.kinematics.bicycle import bicycle_yaw_rate
from calib.results import AnalysisResult, CalibrationResult, Estimate, StageStatus
from calib.stats import Z95, alternate_blocks, bartlett_bandwidth, hac_covariance, hf_noise_std
from logtools.analyze import AnalysisConfig
from logtools.load import LoadedLog
from logtools.robots import RobotPlugin, SignalSpec

FloatArray = np.ndarray
MIN_SPEED = 0.5
"""m/s: slower samples say little about the wheelbase."""
BLOCK = 250
"""Samples per held-out block (5 s at 50 Hz)."""
NOMINAL = ("wheelbase", "steering_offset")


@dataclass(frozen=True)
class CarData:
    """The samples the car is fitted on: steering angle (rad), speed (m/s), yaw rate (rad/s)."""

    steer: FloatArray
    v: FloatArray
    omega: FloatArray


@runtime_checkable
class CarEffectModel(Protocol):
    """How an effect changes the car's model: its addition to the measured yaw rate."""

    def yaw_rate(self, params: Sequence[float], data: CarData) -> FloatArray: ...


class _ConstantBias:
    def yaw_rate(self, params: Sequence[float], data: CarData) -> FloatArray:
        return np.full(data.v.shape, params[0])


GYRO_BIAS: EffectSpec[CarEffectModel] = EffectSpec(
    id="gyro_bias",
    target="omega",
    kind=EffectKind.SENSOR,
    params=(EffectParam("bias", "rad/s", 0.0, -0.5, 0.5, 0.0),),
    physics="the gyro reads the yaw rate plus a constant offset",
    confounded_with=("param:steering_offset",),
    sim_switch="gyro_bias",
    truth_key="gyro_bias",
    model=_ConstantBias(),
)


def _hook_problem(entry: EffectSpec[Any]) -> str | None:
    if isinstance(entry.model, CarEffectModel):
        return None
    return "its model hook has no yaw_rate(params, data)"


CAR_EFFECTS: EffectRegistry[EffectSpec[Any]] = EffectRegistry(
    "car", key=lambda e: e.key, check=_hook_problem
)
"""The car's catalogue: nothing built in, the registered effects."""


def simulate(
    wheelbase: float, offset: float, gyro_bias: float, *, seconds: float = 60.0, seed: int = 0
) -> str:
    """A CSV drive log (``t, steer, v, omega`` at 50 Hz) of a car with these properties."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.02)
    v = 3.0 + 2.0 * np.sin(0.21 * t)
    steer = 0.3 * np.sin(0.5 * t) + 0.1 * np.sin(1.3 * t + 0.4)
    omega = bicycle_yaw_rate(v, steer, wheelbase, offset) + gyro_bias
    omega = omega + rng.normal(0.0, 0.005, t.size)
    rows = "\n".join(
        f"{a:.2f},{s:.7f},{b:.7f},{w:.7f}" for a, s, b, w in zip(t, steer, v, omega, strict=True)
    )
    return "t,steer,v,omega\n" + rows + "\n"


class CarFitter:
    """The car's :class:`~calib.discovery.Fitter`: wheelbase, steering offset and the effects'
    parameters by least squares on one fold, judged on the other."""

    def __init__(self, data: CarData) -> None:
        self.data = data
        self.train, self.test = alternate_blocks(data.v.size, BLOCK)
        self.floor = hf_noise_std(data.omega) ** 2

    def predict(self, theta: FloatArray, effects: Sequence[EffectSpec[Any]]) -> FloatArray:
        d = self.data
        out = bicycle_yaw_rate(d.v, d.steer, theta[0], theta[1])
        at = 2
        for spec in effects:
            width = len(spec.params)
            out = out + spec.model.yaw_rate(theta[at : at + width], d)
            at += width
        return out

    def __call__(self, effects: tuple[EffectSpec[Any], ...], /) -> ModelFit | None:
        d, rows = self.data, self.train
        pars = [p for e in effects for p in e.params]
        lower = [0.1, -0.5, *(p.lower for p in pars)]
        upper = [20.0, 0.5, *(p.upper for p in pars)]

        def resid(theta: FloatArray) -> FloatArray:
            return (d.omega - self.predict(theta, effects))[rows]

        sol = least_squares(resid, [2.0, 0.0, *(p.init for p in pars)], bounds=(lower, upper))
        if not sol.success:
            return None
        cov = hac_covariance(sol.jac, sol.fun, bartlett_bandwidth(sol.fun))
        std = np.sqrt(np.maximum(np.diag(cov), 0.0))
        held = (d.omega - self.predict(sol.x, effects))[self.test]
        estimates = [
            _estimate(n, float(x), float(s))
            for n, x, s in zip((*NOMINAL, *(p.name for p in pars)), sol.x, std, strict=True)
        ]
        by_effect, at = {}, 2
        for spec in effects:
            by_effect[spec.key] = {e.name: e for e in estimates[at : at + len(spec.params)]}
            at += len(spec.params)
        return ModelFit(
            effects=effects,
            parameters={e.name: e for e in estimates[:2]},
            effect_parameters=by_effect,
            sse=float(sol.fun @ sol.fun) / self.floor,
            heldout_sse=float(held @ held) / self.floor,
            n=int(rows.size),
            k=int(sol.x.size),
            n_heldout=int(self.test.size),
            payload=sol.x,
        )


def _estimate(name: str, value: float, std: float) -> Estimate:
    half = Z95 * std
    unit = "m" if name == "wheelbase" else "rad" if name == "steering_offset" else "rad/s"
    ok = math.isfinite(std) and std > 0
    return Estimate(name, value, std, (value - half, value + half), ok, unit)


def analyze(loaded: LoadedLog, config: AnalysisConfig, progress: object) -> AnalysisResult:
    frame = loaded.frame
    cols = [frame[c].to_numpy().astype(float) for c in ("steer", "v", "omega")]
    keep = np.all(np.isfinite(np.vstack(cols)), axis=0) & (np.abs(cols[1]) > MIN_SPEED)
    data = CarData(*(c[keep] for c in cols))
    fitter = CarFitter(data)
    selection = select_effects(fitter, CAR_EFFECTS.entries(), rules=SelectionRules(max_effects=1))
    if selection is None:
        raise ValueError("the car's nominal fit failed")
    final = selection.final
    t = (frame["t_ns"].to_numpy()[keep] - int(frame["t_ns"][0])) * 1e-9
    residual = data.omega - fitter.predict(final.payload, final.effects)
    adequacy = assess(
        [ResidualChannel("omega", "rad/s", t, residual, measured=data.omega)],
        model="kinematic bicycle" + "".join(f" + {k}" for k in final.keys),
    )
    verdict = f"wheelbase and steering offset from {data.v.size} samples; model {final.label}"
    return AnalysisResult(
        robot="ackermann",
        segments=[],
        methods=[],
        estimate=CalibrationResult("least squares", dict(final.parameters), verdict),
        adequacy=adequacy,
        source={"path": str(loaded.path)},
        stages=[StageStatus("calibration", "ok"), StageStatus("discovery", "ok")],
        discovery=selection,
    )


def report(result: AnalysisResult) -> list[RenderableType]:
    return [Text(f"car: model {result.discovery.final.label}")]


def _identify(found: frozenset[str]) -> str | None:
    return "signals steer, v, omega" if {"steer", "v", "omega"} <= found else None


PLUGIN = RobotPlugin(
    name="ackermann",
    title="Ackermann car",
    signals=(
        SignalSpec("steer", "rad", "front-wheel steering angle", required=True),
        SignalSpec("v", "m/s", "rear-axle speed", required=True),
        SignalSpec("omega", "rad/s", "yaw rate (gyro)", required=True),
    ),
    identify=_identify,
    analyze=analyze,
    report=report,
)
