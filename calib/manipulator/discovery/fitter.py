"""The arm's fitter: the baseline model (the terms the log declares, the rigid body fitted or
nominal) plus a set of effects fitted on the first 60 % of the log (momentum windows, WLS with
Newey-West intervals; a delay or lag by a bounded 1-D search with the linear parameters solved
inside, its interval from the Gauss-Newton column at the optimum; an elastic joint by
Gauss-Newton with exact regressors at each step), predicting the logged torque on the last 40 %
at the logged stamps. Residuals are divided by each joint's noise floor so that joints in
different units add; callable as the shared engine's :class:`~calib.discovery.Fitter`."""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, replace
from typing import Any, TypeAlias

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import cumulative_trapezoid
from scipy.optimize import minimize_scalar

from calib.adequacy import EXPLAINS_RATIO, noise_floor
from calib.discovery import EffectParam, EffectSpec, ModelFit
from calib.errors import CalibError
from calib.manipulator.design import Design, Term, coulomb, make_design, term_name
from calib.manipulator.discovery.hooks import (
    Array,
    ColumnEffect,
    InputEffect,
    StateEffect,
    hook,
)
from calib.manipulator.estimators import batch_wls
from calib.manipulator.identify import IdentifyConfig
from calib.manipulator.model import ArmModel
from calib.manipulator.rows import Regressors, compute_regressors
from calib.manipulator.signals import JointSignals
from calib.results import Estimate

__all__ = [
    "COMPLIANCE_ITERATIONS",
    "SHARP_COULOMB_SCALE",
    "ArmFit",
    "ArmFitter",
    "joint_floors",
    "noise_timescale",
]

SHARP_COULOMB_SCALE = 1e-3
"""Velocity scale (rad/s) of the sharpened Coulomb term :meth:`ArmFitter.processing_shifts`
refits with (a tenth of the model's: a sign at every resolvable velocity)."""
COMPLIANCE_ITERATIONS = 6
"""Gauss-Newton steps of a compliance fit at most (each recomputes the regressors)."""


def noise_timescale(cutoff_hz: float) -> float:
    """The longest correlation time counted as torque-sensor noise: a tenth of the zero-phase
    filter's period, ``1 / (10 f_c)``. The model's prediction carries nothing above the cut-off
    ``f_c``, so what the residual holds at that spacing is what the log's torque holds beyond
    the model; a smooth model error at up to ``f_c / 2`` leaks under 10 % of its amplitude into
    the local-line estimate at that spacing (2 ms-step DFKI runs at 10 Hz: spacings 2-10 ms)."""
    return 0.1 / cutoff_hz


_State: TypeAlias = tuple[tuple[EffectSpec, float], ...]
"""State effects with the values their inputs are moved by."""


@dataclass(frozen=True)
class ArmFit:
    """One fit of the fitter: the parameters (``names``, ``theta``, ``std``, ``identifiable``),
    the effects' estimates, and the logged-torque residual at the logged stamps ``t_s``
    (``residual`` (S, n); ``train`` marks the samples the fit saw)."""

    names: tuple[str, ...]
    units: tuple[str, ...]
    theta: Array
    std: Array
    identifiable: Array
    effect_parameters: dict[str, dict[str, Estimate]]
    t_s: Array
    residual: Array
    train: NDArray[np.bool_]
    condition_number: float

    def estimates(self) -> dict[str, Estimate]:
        """The robot's parameters as estimates (effects' own parameters excluded)."""
        out = {}
        for k, name in enumerate(self.names):
            ok = bool(self.identifiable[k]) and math.isfinite(float(self.std[k]))
            v, s = float(self.theta[k]), float(self.std[k]) if ok else math.nan
            ci = (v - 1.96 * s, v + 1.96 * s) if ok else (math.nan, math.nan)
            out[name] = Estimate(
                name,
                v,
                s,
                ci,
                ok,
                self.units[k],
                "" if ok else "regressor column nearly a combination of the others on this log",
            )
        return out

    def heldout_rms(self) -> Array:
        """Per-joint RMS of the residual on the samples the fit did not see (NaN: none)."""
        test = ~self.train
        if not test.any():
            return np.full(self.residual.shape[1], math.nan)
        return np.sqrt(np.mean(self.residual[test] ** 2, axis=0))


@dataclass
class _Assembled:
    reg: Regressors
    names: list[str]
    units: list[str]
    keep0: NDArray[np.intp]
    slices: dict[str, list[int]]


class ArmFitter:
    """Fits the arm's baseline model plus effects (see the module docstring); callable as the
    shared engine's fitter.

    Args:
        model: the arm. sig: its prepared signals (with the logged stamps and torque).
        baseline: the terms the model declares. nominal: full rigid-body parameters to hold
            fixed (None: the rigid body is fitted). config: window, split.
        floors: per-joint noise floor (N·m); None: estimated from the baseline's residual.
    """

    def __init__(
        self,
        model: ArmModel,
        sig: JointSignals,
        baseline: tuple[Term, ...],
        nominal: Array | None = None,
        config: IdentifyConfig | None = None,
        floors: Array | None = None,
    ) -> None:
        self.model, self.sig, self.baseline = model, sig, baseline
        self.nominal = None if nominal is None else np.asarray(nominal, float)
        self.cfg = config or IdentifyConfig()
        lo_hi = model.limits() if hasattr(model, "limits") else None
        self.design: Design = make_design(
            model, baseline, rigid=self.nominal is None, fixed_rigid=self.nominal, q_range=lo_hi
        )
        self.reg = compute_regressors(self.design, sig)
        self.n = len(model.joint_names)
        self.N = len(sig)
        self.cut = round(self.cfg.train_fraction * self.N)
        if self.cut < 20 or self.N - self.cut < 20:
            raise CalibError(f"{self.N} samples are too few to split 60/40")
        g = sig.t_s
        if sig.raw_t_s is not None and sig.raw_tau is not None:
            inside = (sig.raw_t_s >= g[0]) & (sig.raw_t_s <= g[-1])
            self.t_st, self.tau_st = sig.raw_t_s[inside], sig.raw_tau[inside]
        else:
            self.t_st, self.tau_st = g, sig.tau
        self.train_st = self.t_st < g[self.cut]
        self._cache: dict[Any, Any] = {}
        self._rigid_names: tuple[str, ...] | None = None
        self.weights: Array | None = None
        self.floors = np.ones(self.n) if floors is None else np.asarray(floors, float)
        first = self.fit_arm((), 0, self.cut)
        if first is None:
            raise CalibError("the baseline model could not be fitted")
        if floors is None:
            self.floors = joint_floors(first, self.cfg.cutoff_hz)

    # ------------------------------------------------------------------ assembly
    def cached(self, key: Hashable, make: Callable[[], Any]) -> Any:
        """``make()`` computed once per fitter under ``key`` (for hooks: what they derive from
        the whole log's signals)."""
        ck = ("hook", key)
        if ck not in self._cache:
            self._cache[ck] = make()
        return self._cache[ck]

    def _assemble(self, effects: Sequence[EffectSpec], r0: Regressors) -> _Assembled | None:
        names = list(self.design.names)
        units = list(self.design.units)
        keep = list(range(len(names)))
        extra_p: list[Array] = []
        extra_r: list[Array] = []
        extra_c: list[Array] = []
        extra_names: list[str] = []
        extra_units: list[str] = []
        at: dict[str, int] = {}
        taken: set[Hashable] = set()
        for e in effects:
            h = hook(e)
            if not isinstance(h, ColumnEffect):
                continue
            col = h.column(self)
            if col is None:
                return None
            if col.exclusive is not None:
                if col.exclusive in taken:
                    return None  # a model holds at most one of a pair
                taken.add(col.exclusive)
            if col.drop is not None and col.drop in names:
                drop = names.index(col.drop)
                if drop in keep:
                    keep.remove(drop)
            at[e.key] = len(extra_names)
            extra_p.append(col.momentum)
            extra_r.append(col.rest)
            extra_c.append(col.classic)
            extra_names += [p.name for p in e.params]
            extra_units += [p.unit for p in e.params]
        k = np.asarray(keep, dtype=np.intp)
        sel_names = [names[i] for i in keep] + extra_names
        sel_units = [units[i] for i in keep] + extra_units
        slices = {
            e.key: [len(keep) + at[e.key] + i for i in range(len(e.params))]
            for e in effects
            if e.key in at
        }
        reg = Regressors(
            self.sig,
            np.concatenate([r0.Xc[:, :, k], *extra_c], axis=2),
            r0.kc,
            np.concatenate([r0.Xp[:, :, k], *extra_p], axis=2),
            np.concatenate([r0.Xr[:, :, k], *extra_r], axis=2),
            r0.kp,
            r0.kr,
        )
        return _Assembled(reg, sel_names, sel_units, k, slices)

    def _windows_tau(self, tau_f: Array, start: int, stop: int) -> Array:
        s = self.sig
        step = max(1, round(self.cfg.window_s * s.rate_hz))
        ct = cumulative_trapezoid(tau_f[start:stop], s.t_s[start:stop], axis=0, initial=0.0)
        b = np.arange(0, stop - start, step)
        out: Array = ct[b[1:]] - ct[b[:-1]]
        return out

    # ------------------------------------------------------------------ state effects
    def _shifted(
        self, state: _State, extra: tuple[EffectSpec, float] | None = None
    ) -> JointSignals:
        """The signals moved by each state effect of ``state`` at its value, then by
        ``extra`` (an effect, a value) on top."""
        s = self.sig
        dq = np.zeros_like(s.q)
        dqd = np.zeros_like(s.q)
        dqdd = np.zeros_like(s.q)
        for e, c in (*state, *((extra,) if extra is not None else ())):
            h = hook(e)
            if c == 0.0 or not isinstance(h, StateEffect):
                continue
            h.shift(self, c, dq, dqd, dqdd)
        return replace(s, q=s.q + dq, qd=s.qd + dqd, qdd=s.qdd + dqdd)

    @staticmethod
    def _state_key(state: _State) -> tuple[tuple[str, float], ...]:
        return tuple((e.key, c) for e, c in state)

    def _state_reg(self, state: _State) -> Regressors:
        if not state:
            return self.reg
        key = ("state", self._state_key(state))
        if key not in self._cache:
            self._trim()
            self._cache[key] = compute_regressors(self.design, self._shifted(state))
        out: Regressors = self._cache[key]
        return out

    def _trim(self) -> None:
        """Keep the state effects' caches small (each holds regressors along the whole log)."""
        keys = [
            k for k in self._cache if isinstance(k, tuple) and k[0] in ("state", "compsig", "comp")
        ]
        for k in keys[: max(0, len(keys) - 24)]:
            del self._cache[k]

    def _state_column(
        self, e: EffectSpec, start: int, stop: int, state: _State
    ) -> tuple[Array, Array, Array, Array]:
        """d/dh of (window X, window known) and (classic X, classic known) as ``e``'s
        parameter moves by -h about the state ``state``, for the baseline columns."""
        sk = self._state_key(state)
        key = ("comp", e.key, start, stop, sk)
        if key in self._cache:
            out: tuple[Array, Array, Array, Array] = self._cache[key]
            return out
        skey = ("compsig", e.key, sk)
        if skey not in self._cache:
            h_ = hook(e)
            assert isinstance(h_, StateEffect)
            h = h_.step(self)
            regs = [
                compute_regressors(self.design, self._shifted(state, (e, -(sgn * h))))
                for sgn in (1.0, -1.0)
            ]
            self._trim()
            self._cache[skey] = (regs, h)
        (rp, rm), h = self._cache[skey]
        xp, up, _ = rp.momentum_windows(start, stop, self.cfg.window_s)
        xm, um, _ = rm.momentum_windows(start, stop, self.cfg.window_s)
        dxw, dkw = (xp - xm) / (2 * h), -(up - um) / (2 * h)
        dxc, dkc = (rp.Xc - rm.Xc) / (2 * h), (rp.kc - rm.kc) / (2 * h)
        self._cache[key] = (dxw, dkw, dxc, dkc)
        return dxw, dkw, dxc, dkc

    # ------------------------------------------------------------------ the fit
    def _lstsq(self, X: Array, u: Array) -> tuple[Array, float]:
        T, n, P = X.shape
        w = np.ones(n) if self.weights is None else self.weights
        A = (X * w[None, :, None]).reshape(T * n, P)
        b = (u * w[None, :]).reshape(T * n)
        norms = np.linalg.norm(A, axis=0)
        norms[norms == 0] = 1.0
        th, *_ = np.linalg.lstsq(A / norms, b, rcond=None)
        res = b - (A / norms) @ th
        return th / norms, float(res @ res)

    def fit_arm(
        self, effects: Sequence[EffectSpec], start: int = 0, stop: int | None = None
    ) -> ArmFit | None:
        """Fit the baseline plus ``effects`` on grid samples [start, stop) (default: the whole
        log); None when the set is not a model (two alternatives) or the fit fails."""
        stop = self.N if stop is None else stop
        try:
            return self._fit(tuple(effects), start, stop)
        except (CalibError, np.linalg.LinAlgError, ValueError):
            return None

    def _fit(self, effects: tuple[EffectSpec, ...], start: int, stop: int) -> ArmFit | None:
        """State effects (an elastic joint) are linearised about the current estimate and
        refitted there until they settle (Gauss-Newton with exact regressors at each step);
        column effects are linear, an input effect is profiled."""
        states = [e for e in effects if isinstance(hook(e), StateEffect)]
        state: _State = tuple((e, 0.0) for e in states)
        fit = None
        for _ in range(COMPLIANCE_ITERATIONS if states else 1):
            fit = self._fit_at(effects, start, stop, state)
            if fit is None or not states:
                return fit
            new = tuple(
                (e, float(fit.effect_parameters[e.key][e.params[0].name].value)) for e in states
            )
            if not all(math.isfinite(c) for _, c in new):
                return None
            moved = max(abs(c - c0) for (_, c), (_, c0) in zip(new, state, strict=True))
            state = tuple((e, round(c, 12)) for e, c in new)
            size = max(abs(c) for _, c in new)
            if moved <= 1e-3 * size + 1e-12:
                break
        return fit

    def _fit_at(
        self, effects: tuple[EffectSpec, ...], start: int, stop: int, state: _State
    ) -> ArmFit | None:
        st = tuple(x for x in state if x[1] != 0.0)
        asm = self._assemble(effects, self._state_reg(st))
        if asm is None:
            return None
        c_at = {e.key: c for e, c in state}
        transforms = [e for e in effects if isinstance(hook(e), InputEffect)]
        if len(transforms) > 1:
            return None
        spec_in = transforms[0] if transforms else None
        inp = hook(spec_in) if spec_in is not None else None
        assert inp is None or isinstance(inp, InputEffect)
        comps = [e for e, _ in state]
        X0, u0, _ = asm.reg.momentum_windows(start, stop, self.cfg.window_s)
        w0 = self._windows_tau(self.sig.tau_f, start, stop)
        P0 = len(self.design.names)

        def u_of(p: float) -> Array:
            if inp is None or p == 0.0:
                return u0
            out: Array = u0 + self._windows_tau(inp.acting(self, p), start, stop) - w0
            return out

        def theta0_full(th: Array) -> Array:
            full = np.zeros(P0)
            full[asm.keep0] = th[: len(asm.keep0)]
            return full

        def comp_cols(th: Array) -> Array:
            cols = []
            for e in comps:
                dxw, dkw, _, _ = self._state_column(e, start, stop, st)
                cols.append(-(dxw @ theta0_full(th) + dkw))
            return np.stack(cols, axis=2)

        def solve(p: float) -> tuple[Array, float, Array | None]:
            u = u_of(p)
            th, sse = self._lstsq(X0, u)
            C = None
            for _ in range(2 if comps else 0):
                C = comp_cols(th)
                th_c, sse = self._lstsq(np.concatenate([X0, C], axis=2), u)
                th = th_c[: X0.shape[2]]
            return th, sse, C

        p_star = 0.0
        if spec_in is not None:
            lo, hi = spec_in.params[0].lower, spec_in.params[0].upper
            res = minimize_scalar(
                lambda p: solve(float(p))[1],
                bounds=(lo, hi),
                method="bounded",
                options={"xatol": 2e-4},
            )
            p_star = float(res.x)
        _, _, C = solve(p_star)
        u = u_of(p_star)
        blocks = [X0] if C is None else [X0, C]
        if spec_in is not None:
            h = 1e-3
            lo, hi = spec_in.params[0].lower, spec_in.params[0].upper
            a, b = max(lo, p_star - h), min(hi, p_star + h)
            if b <= a:
                return None
            blocks.append((-(u_of(b) - u_of(a)) / (b - a))[:, :, None])
        Xa = np.concatenate(blocks, axis=2)
        if Xa.shape[2] == 0:  # a nominal model with nothing left to fit
            theta = std = np.zeros(0)
            ident = np.zeros(0, dtype=bool)
            cond = math.nan
            sigma = np.sqrt(np.mean(u**2, axis=0))
        else:
            w = batch_wls(Xa, u)
            theta, std, ident, cond, sigma = (
                w.theta,
                w.std,
                w.identifiable,
                w.condition_number,
                w.sigma,
            )
        if self.weights is None and not effects:
            self.weights = 1.0 / np.where(sigma > 0, sigma, 1.0)
        P = X0.shape[2]
        # prediction of the logged torque on the grid (classic form), then at the stamps
        tr = np.nan_to_num(theta[:P])
        pred = asm.reg.Xc @ tr + asm.reg.kc
        effect_pars: dict[str, dict[str, Estimate]] = {}
        for i, e in enumerate(comps):
            _, _, dxc, dkc = self._state_column(e, start, stop, st)
            c = float(np.nan_to_num(theta[P + i]))
            pred = pred - c * (dxc @ theta0_full(tr) + dkc)
            effect_pars[e.key] = {
                e.params[0].name: _est(
                    e.params[0], c_at[e.key] + theta[P + i], std[P + i], ident[P + i]
                )
            }
        if spec_in is not None and inp is not None:
            k = P + len(comps)
            par = spec_in.params[0]
            delta = float(np.nan_to_num(theta[k]))
            p_final = p_star + delta if abs(delta) < 0.5 * (par.upper - par.lower) else p_star
            effect_pars[spec_in.key] = {par.name: _est(par, p_final, std[k], ident[k])}
            if p_star != 0.0:
                pred = inp.logged(self, p_star, pred)
        at = np.stack(
            [np.interp(self.t_st, self.sig.t_s, pred[:, j]) for j in range(self.n)], axis=1
        )
        resid = self.tau_st - at
        t0, t1 = self.sig.t_s[start], self.sig.t_s[stop - 1]
        train = (self.t_st >= t0) & (self.t_st <= t1)
        for key, idx in asm.slices.items():
            spec = next(e for e in effects if e.key == key)
            effect_pars[key] = {
                p.name: _est(p, theta[i], std[i], ident[i])
                for p, i in zip(spec.params, idx, strict=True)
            }
        return ArmFit(
            tuple(asm.names),
            tuple(asm.units),
            theta[:P],
            std[:P],
            ident[:P],
            effect_pars,
            self.t_st,
            resid,
            train,
            cond,
        )

    # ------------------------------------------------------------------ input noise
    def input_noise(self, fit: ArmFit | None = None) -> Array:
        """Per joint, the RMS torque (N·m) the model's prediction inherits from its inputs, at
        ``fit``'s parameters (default: the baseline on the whole log): the encoder's noise
        carried through the derivatives (one seeded draw, :mod:`calib.manipulator.signals`),
        and where the joint reverses, the Coulomb term's unresolved shape below its velocity
        scale (:meth:`coulomb_shape_misfit`). It is what a correct model leaves above the
        torque sensor's own noise."""
        default = fit is None
        if fit is None:
            if "input_noise" in self._cache:
                cached: Array = self._cache["input_noise"]
                return cached
            fit = self.fit_arm(())
            if fit is None:
                return np.zeros(self.n)
        s = self.sig
        by_name = dict(zip(fit.names, np.nan_to_num(fit.theta).tolist(), strict=True))
        theta = np.array([by_name.get(n, 0.0) for n in self.design.names])
        sq = self.coulomb_shape_misfit() ** 2
        if s.noise is not None and theta.size:
            dq, dqd, dqdd = s.noise
            Xc, kc = self.design.classic(s.q + dq, s.qd + dqd, s.qdd + dqdd)
            d = (Xc - self.reg.Xc) @ theta + (kc - self.reg.kc)
            sq = sq + np.mean(d**2, axis=0)
        out: Array = np.sqrt(sq)
        if default:
            self._cache["input_noise"] = out
        return out

    def _sharp(self) -> Regressors | None:
        """The regressors with each Coulomb column sharpened to ``tanh(qd / 0.001)`` (None: the
        model holds no Coulomb term)."""
        names = self.design.names
        sharp = [
            (j, names.index(term_name(Term.COULOMB, jn)))
            for j, jn in enumerate(self.model.joint_names)
            if term_name(Term.COULOMB, jn) in names
        ]
        if not sharp:
            return None
        if "sharp" not in self._cache:
            s, r = self.sig, self.reg
            Xc, Xr = r.Xc.copy(), r.Xr.copy()
            for j, k in sharp:
                col = coulomb(s.qd[:, j], SHARP_COULOMB_SCALE)
                Xc[:, j, k] = col
                Xr[:, j, k] = col
            self._cache["sharp"] = Regressors(s, Xc, r.kc, r.Xp, Xr, r.kp, r.kr)
        out: Regressors = self._cache["sharp"]
        return out

    def coulomb_shape_misfit(self) -> Array:
        """Per joint, the RMS difference (N·m) between the whole-log predictions of the model
        fitted with its Coulomb term and with that term sharpened to a sign: what either
        friction shape leaves in the residual if the other one is true, once the fit has
        absorbed what it can (0 without a Coulomb term or when a fit fails). The shape below
        0.01 rad/s is a modelling choice no log resolves at reversals."""
        if "shape" in self._cache:
            cached: Array = self._cache["shape"]
            return cached
        out = np.zeros(self.n)
        sharp = self._sharp()
        if sharp is not None:
            try:
                w = self.cfg.window_s
                X, u, _ = self.reg.momentum_windows(0, self.N, w)
                Xs, us, _ = sharp.momentum_windows(0, self.N, w)
                th = np.nan_to_num(batch_wls(X, u).theta)
                ths = np.nan_to_num(batch_wls(Xs, us).theta)
                d = sharp.Xc @ ths - self.reg.Xc @ th
                out = np.sqrt(np.mean(d**2, axis=0))
            except (CalibError, np.linalg.LinAlgError, ValueError):
                pass
        self._cache["shape"] = out
        return out

    def processing_shifts(self) -> dict[str, float]:
        """Per base parameter, how far the whole-log baseline estimate moves under what the
        log cannot settle about its own processing: the Coulomb term sharpened to a sign (its
        shape below 0.01 rad/s is a choice, not a measurement) and the encoder's noise drawn
        once more into the inputs (noise in the regressor biases least squares; adding the
        same noise again moves the estimate by about that bias). Each shift is a systematic
        uncertainty the model-conditional interval leaves out; 0 where a refit fails."""
        if "shifts" in self._cache:
            cached: dict[str, float] = self._cache["shifts"]
            return cached
        names = self.design.names
        out = dict.fromkeys(names, 0.0)
        if not names:
            return out
        s, w = self.sig, self.cfg.window_s
        try:
            X, u, _ = self.reg.momentum_windows(0, self.N, w)
            ref = batch_wls(X, u).theta
            variants: list[Regressors] = []
            sharp = self._sharp()
            if sharp is not None:
                variants.append(sharp)
            if s.noise is not None:
                dq, dqd, dqdd = s.noise
                variants.append(
                    compute_regressors(
                        self.design, replace(s, q=s.q + dq, qd=s.qd + dqd, qdd=s.qdd + dqdd)
                    )
                )
            sq = np.zeros(len(names))
            for reg in variants:
                Xv, uv, _ = reg.momentum_windows(0, self.N, w)
                th = batch_wls(Xv, uv).theta
                d = np.where(np.isfinite(th) & np.isfinite(ref), th - ref, 0.0)
                sq += d**2
            out = dict(zip(names, np.sqrt(sq).tolist(), strict=True))
        except (CalibError, np.linalg.LinAlgError, ValueError):
            pass
        self._cache["shifts"] = out
        return out

    # ------------------------------------------------------------------ the engine's fitter
    def _implied_rigid(self, fit: ArmFit, effects: Sequence[EffectSpec]) -> dict[str, Estimate]:
        """Against a nominal rigid body: the base parameters it implies (nominal plus what
        the fitted effects change of the body, a payload), so that explanations implying
        different bodies can be compared."""
        assert self.nominal is not None
        rd = make_design(self.model, (), rigid=True)
        base = rd.to_base(self.nominal)
        moves: list[tuple[Array, float, float]] = []
        for e in effects:
            h = hook(e)
            d = h.body_change(self) if isinstance(h, ColumnEffect) else None
            est = fit.effect_parameters.get(e.key, {}).get(e.params[0].name)
            if d is not None and est is not None:
                moves.append((rd.to_base(d), est.value, est.std))
        out = {}
        for k, (name, unit) in enumerate(zip(rd.names, rd.units, strict=True)):
            v = float(base[k])
            for inc, m, _ in moves:
                v = float(v + m * inc[k])
            s = math.hypot(*(float(abs(inc[k]) * sm) for inc, _, sm in moves))
            out[name] = Estimate(name, v, s, (v - 1.96 * s, v + 1.96 * s), True, unit)
        return out

    def addable(self, effects: Sequence[EffectSpec]) -> list[EffectSpec]:
        """Those of ``effects`` this fitter's model can take and does not already hold (a
        payload is regrouped into a fitted body; a term the baseline has is there)."""
        return [e for e in effects if hook(e).applies(self) and not hook(e).absorbed(self)]

    def extensions(self, effects: Sequence[EffectSpec]) -> list[EffectSpec]:
        """Those of ``effects`` that extend this fitter's model: addable (:meth:`addable`),
        not fitted in place of a baseline term (an alternative is a different model) and not
        a change of the rigid body (a payload)."""
        out = []
        for e in self.addable(effects):
            h = hook(e)
            if h.replaces(self.baseline) is not None:
                continue
            if isinstance(h, ColumnEffect) and h.body_change(self) is not None:
                continue
            out.append(e)
        return out

    def applicable(self, effects: Sequence[EffectSpec]) -> list[EffectSpec]:
        """Those of ``effects`` this fitter's model can take (see :meth:`addable`)."""
        return [e for e in effects if hook(e).applies(self)]

    def model_fit(self, fit: ArmFit, effects: tuple[EffectSpec, ...]) -> ModelFit:
        """The shared engine's view of ``fit``: residuals over the noise floors, the held-out
        sum scaled to the in-sample count (so that the engine's "one unit per sample" holds)."""
        z = fit.residual / self.floors[None, :]
        tr = fit.train
        n = int(tr.sum()) * self.n
        sse = float(np.sum(z[tr] ** 2))
        held = math.nan
        if (~tr).any():
            held = float(np.sum(z[~tr] ** 2)) * tr.sum() / (~tr).sum()
        params = (
            fit.estimates()
            if self.nominal is None
            else (fit.estimates() | self._implied_rigid(fit, effects))
        )
        k = len(fit.theta) + sum(len(v) for v in fit.effect_parameters.values())
        return ModelFit(effects, params, fit.effect_parameters, sse, held, n, k, payload=fit)

    def __call__(self, effects: tuple[EffectSpec, ...]) -> ModelFit | None:
        fit = self.fit_arm(effects, 0, self.cut)
        return None if fit is None else self.model_fit(fit, effects)

    def explained(self, mf: ModelFit) -> bool:
        """Every joint's held-out residual within ``EXPLAINS_RATIO`` of its noise floor (the
        torque sensor's, with what the model's inputs carry, :meth:`input_noise`)."""
        fit: ArmFit = mf.payload
        ratio = fit.heldout_rms() / np.hypot(self.floors, self.input_noise())
        return bool(np.all(np.isfinite(ratio) & (ratio <= EXPLAINS_RATIO)))


def _est(p: EffectParam, v: float, s: float, ok: bool) -> Estimate:
    v, s = float(v), float(s)
    good = bool(ok) and math.isfinite(s)
    s = s if good else math.nan
    return Estimate(
        p.name, v, s, (v - 1.96 * s, v + 1.96 * s) if good else (math.nan, math.nan), good, p.unit
    )


def joint_floors(fit: ArmFit, cutoff_hz: float) -> Array:
    """Per-joint noise floor of the logged torque around ``fit`` (N·m): the residual's own
    high-frequency content up to :func:`noise_timescale`, never below the torque's quantisation."""
    out = []
    for j in range(fit.residual.shape[1]):
        nf = noise_floor(fit.t_s, fit.residual[:, j], timescale_s=noise_timescale(cutoff_hz))
        out.append(nf.std if nf.std > 0 else 1e-12)
    return np.asarray(out, dtype=float)
