"""The differential drive's catalogue of effects and its fitter for the shared selection engine
(:func:`calib.adequacy.select_effects`).

The nominal model: both wheels of one radius r (fitted: a constant slip fraction is exactly a
smaller radius, so the mean radius is always the effective rolling radius), the nominal track
(fitted when the log carries none) and the ground-truth marker's offset from the axle. Per
segment (``segment_s``, each starting from the true pose) the residuals are the yaw change and
the displacement (x, y) minus the wheels' arcs, in units of their noise floors. Effects:

* ``wheel_radius_asymmetry(wheels)``: r_R / r_L - 1 (null 0);
* ``effective_track(track)``: b / b_nominal - 1 (null 0): a skid-steer's effective track;
* ``wheel_slip(wheels)``: each wheel's ground travel its rolling travel x (1 - k |wheel ground
  speed|), k in s/m (null 0): slip that grows with speed;
* ``encoder_stuck(<wheel> t0-t1 s)``: one wheel's reading stood still over a span while the
  other wheel and the ground truth moved (a stuck or dropped encoder); its parameter is the
  wheel turn the reading missed (rad, null 0). The span's turn is a nuisance parameter, fitted
  on whichever fold holds it.

Each effect carries how it changes the model (its ``model``, a :class:`DriveEffectModel`):
parameter-level effects move the radii or the track, wheel-level effects turn the logged wheel
increments into the ground travel the model rolls, in the chain's order (a sensor's reading
corrected first, then the dynamics). The fitter applies the hooks and never branches on an
effect's id; an effect whose parameters are local (a span's nuisance turn) says which segments
it touches, and is refitted on the held-out fold. A new effect is one :class:`EffectSpec` with
its hook, added by :func:`register_effect` (or passed to :func:`discover_effects` as ``extra``).

Standard errors: Newey-West (Bartlett) over consecutive segments, which share slip and
ground-truth errors. Held out: two folds of alternating blocks of ``CV_BLOCK`` segments.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from calib.diff_drive.adequacy import StuckSpan
from calib.diff_drive.data import DriveRun
from calib.diff_drive.described import (
    described_hook,
    drive_grid,
    drive_library,
    entries,
    residual_space,
)
from calib.diff_drive.kinematics import DiffDriveParams
from calib.diff_drive.segments import SegmentIndex, cut_segments, segment_length
from calib.discovery import (
    Description,
    EffectKind,
    EffectParam,
    EffectRegistry,
    EffectSpec,
    ModelFit,
    Selection,
    describe,
    select_effects,
)
from calib.results import Estimate, json_safe
from calib.stats import (
    bartlett_long_run,
    cube_root_lag,
    long_run_variance_ratio,
    mad_std,
    sandwich,
)

__all__ = [
    "ASYMMETRY",
    "CHAIN_ORDER",
    "CLOCK_DRIFT",
    "CLOCK_OFFSET",
    "EFFECTIVE_TRACK",
    "WHEEL_SLIP",
    "DiffDriveSelection",
    "DriveEffect",
    "DriveEffectModel",
    "catalogue",
    "discover_effects",
    "register_effect",
    "registered_effects",
    "stuck_spec",
    "unregister_effect",
]

Array = NDArray[np.float64]
Z95 = 1.959963984540054
CV_BLOCK = 5
EXPLAINS_SSE = 1.5**2
"""Held-out sum of squares per residual (noise units) up to which the model explains the log
(the adequacy check's ratio of 1.5, squared)."""


class DriveEffectModel(Protocol):
    """How one effect changes the differential drive's model: the hook of its
    :class:`~calib.adequacy.EffectSpec`. ``values`` holds the effect's own parameters by
    name (:class:`~calib.adequacy.EffectParam` names)."""

    def params(self, p: DiffDriveParams, values: Mapping[str, float]) -> DiffDriveParams:
        """The radii and track with the effect, from those without it."""
        ...

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        """Run ``run``'s wheel increments (rad; right, left) as the model rolls them, from the
        logged ones (or from what earlier effects made of them); ``p``: the radii and track
        with every parameter-level effect. Never modifies ``dr`` or ``dl`` in place."""
        ...

    def local_segments(self, segments: Sequence[SegmentIndex]) -> set[int] | None:
        """The segments a local effect (its parameters a nuisance of a few samples) acts on;
        None for a global effect."""
        ...


class DriveEffect:
    """A :class:`DriveEffectModel` that changes nothing: subclass it and override the hooks
    an effect needs."""

    def params(self, p: DiffDriveParams, values: Mapping[str, float]) -> DiffDriveParams:
        return p

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        return dr, dl

    def local_segments(self, segments: Sequence[SegmentIndex]) -> set[int] | None:
        return None


class _Asymmetry(DriveEffect):
    """r_R / r_L = 1 + a about the same mean radius."""

    def params(self, p: DiffDriveParams, values: Mapping[str, float]) -> DiffDriveParams:
        a = values["ratio_minus_1"]
        r_L = 2 * (0.5 * (p.r_R + p.r_L)) / (2 + a)
        return DiffDriveParams(r_L * (1 + a), r_L, p.b)


class _EffectiveTrack(DriveEffect):
    """b = b_nominal (1 + t)."""

    def params(self, p: DiffDriveParams, values: Mapping[str, float]) -> DiffDriveParams:
        return DiffDriveParams(p.r_R, p.r_L, p.b * (1 + values["track_ratio_minus_1"]))


class _WheelSlip(DriveEffect):
    """Each wheel's travel scaled by (1 - k |wheel ground speed|)."""

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        k = values["k"]
        if not k:
            return dr, dl
        dt = np.maximum(np.diff(data.t), 1e-9)
        return dr * (1 - k * p.r_R * np.abs(dr) / dt), dl * (1 - k * p.r_L * np.abs(dl) / dt)


@dataclass(frozen=True)
class _Stuck(DriveEffect):
    """Over the span, the wheel turned ``missed_turn`` in all, evenly, where the reading
    stood still."""

    span: StuckSpan

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        sp = self.span
        if sp.run != run:
            return dr, dl
        n = max(1, sp.i1 - sp.i0)
        if sp.wheel == "wheel_right":
            dr = dr.copy()
            dr[sp.i0 : sp.i1] = values["missed_turn"] / n
        else:
            dl = dl.copy()
            dl[sp.i0 : sp.i1] = values["missed_turn"] / n
        return dr, dl

    def local_segments(self, segments: Sequence[SegmentIndex]) -> set[int] | None:
        sp = self.span
        return {
            i
            for i, s in enumerate(segments)
            if s.run == sp.run and s.start < sp.i1 and s.stop > sp.i0
        }


def shifted_increments(t: Array, d: Array, shift_s: Array | float) -> Array:
    """Increments ``d`` between samples at ``t`` as they are at the ground truth's instants
    when the encoders' stamps are late by ``shift_s`` (s, a constant or one per sample): the
    cumulative reading interpolated at t + shift, differenced."""
    cum = np.concatenate([[0.0], np.cumsum(d)])
    return np.diff(np.interp(t + shift_s, t, cum))


@dataclass(frozen=True)
class _ClockOffset(DriveEffect):
    """The encoders are stamped ``offset`` s late against the ground truth (in run ``run``
    only, or every run)."""

    run: int | None = None

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        c = values["offset"]
        if not c or (self.run is not None and run != self.run):
            return dr, dl
        return shifted_increments(data.t, dr, c), shifted_increments(data.t, dl, c)


@dataclass(frozen=True)
class _ClockDrift(DriveEffect):
    """The encoders' clock runs at (1 + drift) of the ground truth's: stamped late by
    drift x (t - t0) (in run ``run`` only, or every run)."""

    run: int | None = None

    def increments(
        self,
        run: int,
        data: DriveRun,
        dr: Array,
        dl: Array,
        values: Mapping[str, float],
        p: DiffDriveParams,
    ) -> tuple[Array, Array]:
        d = values["drift"]
        if not d or (self.run is not None and run != self.run):
            return dr, dl
        s = d * (data.t - data.t[0])
        return shifted_increments(data.t, dr, s), shifted_increments(data.t, dl, s)


CLOCK_OFFSET: EffectSpec[DriveEffectModel] = EffectSpec(
    "clock_offset",
    "wheels",
    EffectKind.CLOCK,
    (EffectParam("offset", "s", 0.0, -2.0, 2.0, 0.0),),
    "the wheel encoders' time stamps are off from the ground truth's by a constant (offset > 0: "
    "the wheels are stamped late): turns show in the pose before the wheels report them",
    confounded_with=("clock_drift(wheels)",),
    sim_switch="clock_offset_s",
    model=_ClockOffset(),
)
CLOCK_DRIFT: EffectSpec[DriveEffectModel] = EffectSpec(
    "clock_drift",
    "wheels",
    EffectKind.CLOCK,
    (EffectParam("drift", "s/s", 0.0, -0.02, 0.02, 0.0),),
    "the wheel encoders' clock runs at another rate than the ground truth's: the offset between "
    "them grows by drift seconds per second",
    confounded_with=("clock_offset(wheels)",),
    sim_switch="clock_drift",
    model=_ClockDrift(),
)
ASYMMETRY: EffectSpec[DriveEffectModel] = EffectSpec(
    "wheel_radius_asymmetry",
    "wheels",
    EffectKind.DYNAMICS,
    (EffectParam("ratio_minus_1", "1", 0.0, -0.3, 0.3, 0.0),),
    "the right and left wheels roll on different radii: the robot curves when both turn alike",
    sim_switch="asymmetry",
    truth_key="wheel_radius_right",
    model=_Asymmetry(),
)
EFFECTIVE_TRACK: EffectSpec[DriveEffectModel] = EffectSpec(
    "effective_track",
    "track",
    EffectKind.DYNAMICS,
    (EffectParam("track_ratio_minus_1", "1", 0.0, -0.5, 3.0, 0.0),),
    "the robot turns as if its track were other than nominal (a skid steer's wheels slide "
    "sideways: effective track wider than the geometric one)",
    confounded_with=("wheel_slip(wheels)",),
    sim_switch="skid",
    truth_key="track_width",
    model=_EffectiveTrack(),
)
WHEEL_SLIP: EffectSpec[DriveEffectModel] = EffectSpec(
    "wheel_slip",
    "wheels",
    EffectKind.DYNAMICS,
    (EffectParam("k", "s/m", 0.0, -2.0, 2.0, 0.0),),
    "longitudinal slip growing with speed: each wheel covers (1 - k |speed|) of its rolling travel",
    confounded_with=("effective_track(track)",),
    sim_switch="slip_per_speed",
    model=_WheelSlip(),
)

REGISTRY: EffectRegistry[EffectSpec[DriveEffectModel]] = EffectRegistry(
    "diff drive",
    key=lambda e: e.key,
    builtin=lambda: (
        e.key for e in (ASYMMETRY, EFFECTIVE_TRACK, WHEEL_SLIP, CLOCK_OFFSET, CLOCK_DRIFT)
    ),
    check=lambda e: None if e.model is not None else "no model hook (a DriveEffectModel)",
)
"""Effects added to the diff drive's catalogue from outside (``calib.discovery``'s one registry
behaviour)."""

CHAIN_ORDER = {
    EffectKind.SENSOR: 0,
    EffectKind.CLOCK: 0,
    EffectKind.ACTUATOR: 1,
    EffectKind.DYNAMICS: 2,
}
"""The order in which wheel-level hooks apply: what the reading got wrong is undone first, then
what the wheels did on the ground."""


def register_effect(spec: EffectSpec[DriveEffectModel]) -> EffectSpec[DriveEffectModel]:
    """Add ``spec`` (with its hook) to every catalogue built from now on; returns it."""
    return REGISTRY.register(spec)


def unregister_effect(spec: EffectSpec[DriveEffectModel] | str) -> None:
    """Take a registered effect (or its key) out again (no error when it is not registered)."""
    REGISTRY.unregister(spec)


def registered_effects() -> tuple[EffectSpec[DriveEffectModel], ...]:
    """The effects added by :func:`register_effect`, in order."""
    return REGISTRY.entries()


def stuck_spec(span: StuckSpan) -> EffectSpec[DriveEffectModel]:
    """The catalogue entry of one stuck-encoder span."""
    return EffectSpec(
        "encoder_stuck",
        span.label,
        EffectKind.SENSOR,
        (EffectParam("missed_turn", "rad", 0.0, -1e3, 1e3, 0.0),),
        f"the {span.wheel.replace('_', ' ')} encoder's reading stood still from "
        f"{span.t0_s:.1f} to {span.t1_s:.1f} s while the other wheel and the ground truth "
        "moved (a stuck or dropped encoder): those samples are left out of the calibration",
        model=_Stuck(span),
    )


def run_clocks(run: int, name: str) -> tuple[EffectSpec[DriveEffectModel], ...]:
    """The clock offset and drift of one run of several (each run's encoders and ground truth
    may be synchronised apart)."""
    return tuple(
        replace(spec, target=f"wheels of {name.rsplit('/', 1)[-1]}", model=hook(run))
        for spec, hook in ((CLOCK_OFFSET, _ClockOffset), (CLOCK_DRIFT, _ClockDrift))
    )


def catalogue(
    has_nominal_track: bool,
    spans: Sequence[StuckSpan] = (),
    extra: Sequence[EffectSpec[DriveEffectModel]] = (),
    runs: Sequence[str] = (),
) -> list[EffectSpec[DriveEffectModel]]:
    """The effects tested on one log: the built-in ones (a clock per run when ``runs`` names
    more than one), the registered ones (:func:`register_effect`), then ``extra``."""
    out = [ASYMMETRY]
    if has_nominal_track:
        out.append(EFFECTIVE_TRACK)
    out.append(WHEEL_SLIP)
    if len(runs) > 1:
        out += [c for k, name in enumerate(runs) for c in run_clocks(k, name)]
    else:
        out += [CLOCK_OFFSET, CLOCK_DRIFT]
    out += [stuck_spec(s) for s in spans]
    out += [*REGISTRY.entries(), *extra]
    return out


def _hook(e: EffectSpec[DriveEffectModel]) -> DriveEffectModel:
    if e.model is None:
        raise ValueError(f"effect {e.key}: no model hook (a DriveEffectModel)")
    return e.model


@dataclass
class _Problem:
    runs: Sequence[DriveRun]
    segments: list[SegmentIndex]
    b_nominal: float | None
    r0: float
    offset: bool
    sigma_h: float
    sigma_p: float

    def names(self, effects: Sequence[EffectSpec]) -> list[str]:
        out = ["r"] + ([] if self.b_nominal is not None else ["b"])
        out += ["lx", "ly"] if self.offset else []
        for e in effects:
            out += [f"{e.key}:{p.name}" for p in e.params]
        return out

    def unpack(self, theta: Array, names: Sequence[str]) -> dict[str, float]:
        return dict(zip(names, map(float, theta), strict=True))

    @staticmethod
    def own(e: EffectSpec, v: Mapping[str, float]) -> dict[str, float]:
        """An effect's own parameters, by their names, from the full vector's values."""
        return {p.name: v[f"{e.key}:{p.name}"] for p in e.params}

    def params_of(self, v: Mapping[str, float], effects: Sequence[EffectSpec]) -> DiffDriveParams:
        """The radii and track: one radius ``r``, the nominal (or fitted) track, then each
        effect's parameter-level hook."""
        b = v["b"] if "b" in v else float(self.b_nominal or 1.0)
        p = DiffDriveParams(v["r"], v["r"], b)
        for e in effects:
            p = _hook(e).params(p, self.own(e, v))
        return p

    def residuals(
        self,
        theta: Array,
        names: Sequence[str],
        rows: NDArray[np.intp],
        effects: Sequence[EffectSpec],
    ) -> Array:
        v = self.unpack(theta, names)
        p = self.params_of(v, effects)
        chain = sorted(effects, key=lambda e: CHAIN_ORDER.get(e.kind, 2))
        off = complex(v.get("lx", 0.0), v.get("ly", 0.0))
        out = np.empty((len(self.segments), 3))
        by_run: dict[int, list[int]] = {}
        for i in rows:
            by_run.setdefault(self.segments[i].run, []).append(int(i))
        for r, idx in by_run.items():
            run = self.runs[r]
            dr, dl = np.diff(run.wheel_right), np.diff(run.wheel_left)
            for e in chain:
                dr, dl = _hook(e).increments(r, run, dr, dl, self.own(e, v), p)
            dth = (p.r_R * dr - p.r_L * dl) / p.b
            h = np.concatenate([[0.0], np.cumsum(dth)])
            step = (
                0.5
                * (p.r_R * dr + p.r_L * dl)
                * np.sinc(dth / (2 * np.pi))
                * np.exp(1j * (h[:-1] + 0.5 * dth))
            )
            cum = np.concatenate([[0.0], np.cumsum(step)])
            for i in idx:
                s = self.segments[i]
                a, b = s.start, s.stop
                dyaw = run.yaw[b] - run.yaw[a]
                disp = complex(run.x[b] - run.x[a], run.y[b] - run.y[a])
                pred = np.exp(1j * (run.yaw[a] - h[a])) * (cum[b] - cum[a]) + off * (
                    np.exp(1j * run.yaw[b]) - np.exp(1j * run.yaw[a])
                )
                e = disp - pred
                out[i] = [
                    (dyaw - (h[b] - h[a])) / self.sigma_h,
                    e.real / self.sigma_p,
                    e.imag / self.sigma_p,
                ]
        return out[rows].ravel()


def _bounds(names: Sequence[str], effects: Sequence[EffectSpec]) -> tuple[Array, Array, Array]:
    lo, hi, x0 = [], [], []
    spec = {f"{e.key}:{p.name}": p for e in effects for p in e.params}
    for n in names:
        if n in spec:
            p = spec[n]
            lo.append(p.lower)
            hi.append(p.upper)
            x0.append(p.init)
        else:
            lo.append(-np.inf)
            hi.append(np.inf)
            x0.append(0.0)
    return np.array(lo), np.array(hi), np.array(x0)


def _hac_cov(jac: Array, res: Array, n_seg: int) -> Array:
    """Newey-West covariance of the least-squares parameters, scores summed per segment."""
    p = jac.shape[1]
    scores = (jac * res[:, None]).reshape(n_seg, 3, p).sum(axis=1)
    return sandwich(jac.T @ jac, bartlett_long_run(scores, cube_root_lag(n_seg)))


class _Fitter:
    """The fitter :func:`select_effects` calls: nominal model + ``effects`` -> ModelFit."""

    def __init__(self, prob: _Problem, heldout: bool = True) -> None:
        self.prob = prob
        self.heldout = heldout
        n = len(prob.segments)
        block = (np.arange(n) // CV_BLOCK) % 2
        self.folds = (
            np.flatnonzero(block == 0).astype(np.intp),
            np.flatnonzero(block == 1).astype(np.intp),
        )

    def _x0(self, names: Sequence[str], effects: Sequence[EffectSpec]) -> tuple[Array, ...]:
        lo, hi, x0 = _bounds(names, effects)
        for i, n in enumerate(names):
            if n == "r":
                x0[i] = self.prob.r0
            elif n == "b":
                x0[i] = self.prob.b_nominal or 0.3
        return lo, hi, x0

    def _solve(
        self,
        names: list[str],
        effects: Sequence[EffectSpec],
        rows: NDArray[np.intp],
        x0: Array,
        free: NDArray[np.bool_] | None = None,
    ) -> Any:
        lo, hi, _ = self._x0(names, effects)
        fr = np.ones(len(names), bool) if free is None else free

        def f(z: Array) -> Array:
            th = x0.copy()
            th[fr] = z
            return self.prob.residuals(th, names, rows, effects)

        return least_squares(
            f,
            np.clip(x0[fr], lo[fr] + 1e-12, hi[fr] - 1e-12),
            bounds=(lo[fr], hi[fr]),
            x_scale="jac",
            method="trf",
        )

    def __call__(self, effects: tuple[EffectSpec, ...]) -> ModelFit | None:
        prob = self.prob
        names = prob.names(effects)
        n = len(prob.segments)
        all_rows = np.arange(n, dtype=np.intp)
        _, _, x0 = self._x0(names, effects)
        try:
            sol = self._solve(names, effects, all_rows, x0)
        except (ValueError, np.linalg.LinAlgError):
            return None
        theta = np.asarray(sol.x, dtype=float)
        res = np.asarray(sol.fun, dtype=float)
        cov = _hac_cov(np.asarray(sol.jac, dtype=float), res, n)
        std = np.sqrt(np.maximum(np.diag(cov), 0.0))
        held = self._heldout(names, effects, theta) if self.heldout else math.nan
        v = prob.unpack(theta, names)
        params = prob.params_of(v, effects)
        pars = self._robot_estimates(names, effects, theta, cov, params)
        eff: dict[str, dict[str, Estimate]] = {}
        for e in effects:
            for p in e.params:
                i = names.index(f"{e.key}:{p.name}")
                eff.setdefault(e.key, {})[p.name] = Estimate(
                    p.name,
                    float(theta[i]),
                    float(std[i]),
                    (float(theta[i] - Z95 * std[i]), float(theta[i] + Z95 * std[i])),
                    bool(std[i] > 0),
                    p.unit,
                    "Newey-West over segments",
                )
        return ModelFit(
            effects,
            pars,
            eff,
            float(res @ res),
            held,
            res.size,
            len(names),
            payload={"params": params, "values": v},
        )

    def _robot_estimates(
        self,
        names: Sequence[str],
        effects: Sequence[EffectSpec],
        theta: Array,
        cov: Array,
        p: DiffDriveParams,
    ) -> dict[str, Estimate]:
        """r_R, r_L, b with delta-method standard errors (numerical gradient)."""

        def f(th: Array) -> Array:
            q = self.prob.params_of(self.prob.unpack(th, names), effects)
            return np.array([q.r_R, q.r_L, q.b])

        base = f(theta)
        G = np.zeros((3, theta.size))
        for i in range(theta.size):
            h = 1e-6 * max(1.0, abs(theta[i]))
            tp = theta.copy()
            tp[i] += h
            G[:, i] = (f(tp) - base) / h
        sd = np.sqrt(np.maximum(np.diag(G @ cov @ G.T), 0.0))
        out = {}
        for name, val, s in zip(
            ("wheel_radius_right", "wheel_radius_left", "track_width"), base, sd, strict=True
        ):
            out[name] = Estimate(
                name, float(val), float(s), (float(val - Z95 * s), float(val + Z95 * s)), True, "m"
            )
        return out

    def _heldout(self, names: list[str], effects: Sequence[EffectSpec], theta: Array) -> float:
        """Held-out sum of squares over the two folds; a local effect's parameters (a nuisance
        of the few segments it touches) are refitted on the held-out fold with the global ones
        fixed."""
        touched: dict[str, set[int] | None] = {
            f"{e.key}:{p.name}": _hook(e).local_segments(self.prob.segments)
            for e in effects
            for p in e.params
        }
        local = np.array([touched.get(n) is not None for n in names])
        total = 0.0
        for train, test in (self.folds, self.folds[::-1]):
            if train.size < 6 or test.size == 0:
                return math.nan
            in_train = set(train.tolist())
            free = ~local | np.array([bool((touched.get(n) or set()) & in_train) for n in names])
            try:
                sol = self._solve(names, effects, train, theta.copy(), free=free)
                th = theta.copy()
                th[free] = sol.x
                if local.any():
                    sol2 = self._solve(names, effects, test, th, free=local)
                    th[local] = sol2.x
                r = self.prob.residuals(th, names, test, effects)
            except (ValueError, np.linalg.LinAlgError):
                return math.nan
            total += float(r @ r)
        return total


@dataclass(frozen=True)
class DiffDriveSelection:
    """What discovery found on one log (``selection``: the shared engine's record) in the
    shape the report and the JSON read: ``named`` effect ids, one line per effect tried."""

    selection: Selection | None
    catalogue: tuple[EffectSpec, ...]
    notes: list[str] = field(default_factory=list)
    also_named: tuple[str, ...] = ()
    """Effect ids named by a dedicated test outside the forward selection (the joint slip fit
    of :mod:`calib.diff_drive.slip`)."""
    description: Description | None = None
    """The residual model of what the selected effects leave (accepted or not)."""

    @property
    def named(self) -> list[str]:
        found = [] if self.selection is None else [e.id for e in self.selection.accepted]
        return list(dict.fromkeys([*found, *self.also_named]))

    @property
    def accepted(self) -> tuple[EffectSpec, ...]:
        return () if self.selection is None else self.selection.accepted

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "engine": "calib.adequacy.select_effects",
                "named": self.named,
                "catalogue": [
                    {"key": e.key, "kind": str(e.kind), "physics": e.physics}
                    for e in self.catalogue
                ],
                "selection": None if self.selection is None else self.selection.to_dict(),
                "notes": list(self.notes),
            }
        )

    def report(self) -> list[str]:
        sel = self.selection
        if sel is None:
            return ["Discovery: nothing tested. " + " ".join(self.notes)]
        head = (
            "Discovery: " + ", ".join(e.key for e in sel.accepted)
            if sel.accepted
            else "Discovery: no catalogued effect improves the held-out fit"
        )
        lines = [head]
        for e in sel.accepted:
            pars = sel.final.effect_parameters.get(e.key, {})
            vals = ", ".join(f"{n} = {p.value:.4g} ± {p.std:.2g} {p.unit}" for n, p in pars.items())
            lines.append(f"  {e.key}: {vals}; {e.physics}")
        b, a = sel.base.heldout_sse, sel.final.heldout_sse
        if sel.accepted and math.isfinite(b) and math.isfinite(a):
            lines.append(f"  held-out sum of squares (noise units) {b:.4g} -> {a:.4g}")
        not_named = [t.key for t in sel.tried if not t.accepted]
        if not_named:
            lines.append("  tried, not named: " + ", ".join(dict.fromkeys(not_named)))
        lines += [f"  {c.note}" for c in sel.confounds]
        lines += [f"  {n}" for n in self.notes]
        return lines


def _lrv_ratio(x: Array) -> float:
    """Long-run variance (Bartlett) over variance of a segment residual series (>= 1): how
    much consecutive segments' shared errors (slip, ground-truth drift) inflate what a sum of
    squares counts as independent noise."""
    x = x[np.isfinite(x)] - np.median(x[np.isfinite(x)]) if np.isfinite(x).any() else x
    if x.size < 8:
        return 1.0
    clip = 4 * max(mad_std(x), 1e-15)
    x = np.clip(x, -clip, clip)  # a stuck span must not pass for correlation
    return max(1.0, long_run_variance_ratio(x))


def _raw_residuals(prob: _Problem, p: DiffDriveParams, marker: complex) -> Array:
    """Per-segment residuals (unscaled) of the free radii and track ``p``."""
    effects = (ASYMMETRY,) + ((EFFECTIVE_TRACK,) if prob.b_nominal is not None else ())
    names = prob.names(effects)
    asym, track = (f"{e.key}:{e.params[0].name}" for e in (ASYMMETRY, EFFECTIVE_TRACK))
    a = p.r_R / p.r_L - 1
    v = {"r": p.r_L * (2 + a) / 2, "b": p.b, "lx": marker.real, "ly": marker.imag, asym: a}
    if prob.b_nominal is not None:
        v[track] = p.b / prob.b_nominal - 1
    theta = np.array([v[n] for n in names])
    return prob.residuals(theta, names, np.arange(len(prob.segments), dtype=np.intp), effects)


def noise_scales(
    prob: _Problem, calibrated: DiffDriveParams, marker: complex
) -> tuple[float, float]:
    """Heading and position noise scales per segment: the robust (MAD) spread of what the
    calibrated model leaves, inflated by the residuals' long-run variance ratio."""
    raw = _raw_residuals(prob, calibrated, marker).reshape(-1, 3)
    sigma_h = max(mad_std(raw[:, 0]) * math.sqrt(_lrv_ratio(raw[:, 0])), 1e-9)
    sigma_p = max(
        mad_std(raw[:, 1:].ravel()) * math.sqrt(max(_lrv_ratio(raw[:, 1]), _lrv_ratio(raw[:, 2]))),
        1e-9,
    )
    return sigma_h, sigma_p


def discover_effects(
    runs: Sequence[DriveRun],
    nominal: DiffDriveParams | None,
    *,
    calibrated: DiffDriveParams,
    marker: complex | None = None,
    spans: Sequence[StuckSpan] = (),
    segment_s: float | None = None,
    extra: Sequence[EffectSpec[DriveEffectModel]] = (),
) -> DiffDriveSelection:
    """Select effects from :func:`catalogue` on ``runs``. ``calibrated`` (r_R, r_L, b free,
    with the ground-truth ``marker`` offset) sets the noise scale per segment: the robust
    (MAD) spread of what it leaves in heading and in position, so that a model as good as the
    calibrated one leaves about one unit per residual. ``segment_s``: None picks a length
    that gives a short log enough segments for the two-fold check (:func:`segment_length`).
    ``extra``: effects tried besides the catalogue's (each with its hook)."""
    if segment_s is None:
        segment_s = segment_length(runs, 6 * CV_BLOCK)
    segments = cut_segments(runs, segment_s)
    cat = catalogue(nominal is not None, spans, extra, [r.name for r in runs])
    if len(segments) < 4 * CV_BLOCK:
        return DiffDriveSelection(
            None,
            tuple(cat),
            [
                f"only {len(segments)} moving segments of {segment_s:g} s: discovery needs "
                f"{4 * CV_BLOCK}"
            ],
        )
    turned = sum(abs(runs[s.run].yaw[s.stop] - runs[s.run].yaw[s.start]) for s in segments)
    prob = _Problem(
        runs,
        segments,
        None if nominal is None else nominal.b,
        0.5 * (calibrated.r_R + calibrated.r_L),
        turned >= math.pi / 2,
        1.0,
        1.0,
    )
    prob.sigma_h, prob.sigma_p = noise_scales(prob, calibrated, marker or 0j)
    fitter = _Fitter(prob)
    # a clock per run may be off on its own: room for an offset and a drift in each
    per_run = 2 * len(runs) if len(runs) > 1 else 0
    sel = select_effects(fitter, cat, max_effects=2 + len(spans) + per_run)
    description = _describe(fitter, sel, calibrated) if sel is not None else None
    notes = (
        []
        if nominal is not None
        else [
            "no nominal track in the log: the effective track is not tested (the track is fitted)"
        ]
    )
    return DiffDriveSelection(sel, tuple(cat), notes, description=description)


def _describe(fitter: _Fitter, sel: Selection, calibrated: DiffDriveParams) -> Description | None:
    """The residual model of what the selected model leaves (``calib.discovery.residual_model``)."""
    prob = fitter.prob
    grid = drive_grid(prob.runs)
    effects = sel.final.effects
    names = prob.names(effects)
    values = sel.final.payload["values"]
    theta = np.array([values[n] for n in names])
    rows = np.arange(len(prob.segments), dtype=np.intp)
    res = prob.residuals(theta, names, rows, effects)
    ents = entries(grid, prob.segments, prob.sigma_h, prob.sigma_p)
    space = residual_space(res, fitter.folds, len(prob.segments), ents)
    library = drive_library(grid, sel.final.payload["params"])
    n = sel.final.n_heldout if sel.final.n_heldout is not None else sel.final.n
    # the residuals are in units of the noise scale: a model at it leaves about one per residual
    explained = math.isfinite(sel.final.heldout_sse) and sel.final.heldout_sse <= EXPLAINS_SSE * n
    return describe(
        fitter,
        sel.final,
        space,
        library,
        block=3 * CV_BLOCK,
        hook=described_hook(grid),
        explained=explained,
    )
