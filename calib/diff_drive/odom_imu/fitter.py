"""The fitter discovery calls on the odometry + IMU windows: the gyro's yaw change predicted as
the odometry's divided by the gain the effects make, plus what an effect adds to it directly (a
described term), plus a gyro bias x duration, in units of the residual's noise floor; its
held-out sum of squares over two folds of alternating time blocks; Newey-West (Bartlett)
standard errors over windows. Two effects that fit one part of the gain (``covers``) are not
fitted together: the set is one effect twice."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from calib.diff_drive.odom_imu.effects import GainEffectModel
from calib.diff_drive.odom_imu.windows import FOLD_S, Windows
from calib.discovery import CandidateFailedError, EffectSpec, ModelFit
from calib.results import Estimate
from calib.stats import bartlett_long_run, cube_root_lag, sandwich

__all__ = ["GainFitter", "GainPayload"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class GainPayload:
    """What a fit keeps for the re-report: the fitted values by name (``"bias"``,
    ``"key:param"``), their Newey-West covariance (in ``names`` order), the residual (noise
    units) on the fitted windows and its Jacobian."""

    names: tuple[str, ...]
    values: Mapping[str, float]
    cov: Array = field(repr=False)
    residual: Array = field(repr=False)
    jac: Array = field(repr=False)

    def std(self, name: str) -> float:
        i = self.names.index(name)
        return float(math.sqrt(max(float(self.cov[i, i]), 0.0)))


def _nested(effects: Sequence[EffectSpec[GainEffectModel]]) -> str | None:
    seen: dict[str, str] = {}
    for e in effects:
        for part in getattr(e.model, "covers", ()):
            if part in seen:
                return f"{e.key} and {seen[part]} both fit the gain's part {part!r} (nested)"
            seen[part] = e.key
    return None


class GainFitter:
    """Nominal: the odometry's yaw rate is the true one (G = 1) up to a gyro bias; effects:
    a constant gain, its growth with |turn rate|, with speed, jointly (ICR), described terms."""

    def __init__(
        self,
        w: Windows,
        use: NDArray[np.intp],
        sigma: float,
        catalogue: Sequence[EffectSpec[GainEffectModel]] = (),
    ) -> None:
        self.w, self.use, self.sigma = w, use, sigma
        blocks = ((w.t[use] - w.t[0]) // FOLD_S).astype(int) % 2
        self.folds = (use[blocks == 0], use[blocks == 1])
        self.order = {e.key: i for i, e in enumerate(catalogue)}
        """The catalogue's order, in which the parts of the gain are summed (whatever order
        the selection added the effects in)."""

    def slope(
        self,
        values: Mapping[str, float],
        rows: NDArray[np.intp],
        effects: Sequence[EffectSpec[GainEffectModel]],
    ) -> float | Array:
        """Gyro yaw change per odometry yaw change on windows ``rows``: (1 - slip) / G."""
        const: float | Array = 0.0
        grow: float | Array = 1.0
        slip: float | Array = 0.0
        for e in sorted(effects, key=lambda e: self.order.get(e.key, len(self.order))):
            if e.model is None:
                raise ValueError(f"effect {e.key}: no model hook (a GainEffectModel)")
            own = {p.name: values[f"{e.key}:{p.name}"] for p in e.params}
            c, d = e.model.gain(own, self.w, rows)
            const, grow = const + c, grow + d
            slip = slip + e.model.slip(own, self.w, rows)
        out: float | Array = (1 - slip) / np.maximum((1 + const) * grow, 1e-3)
        return out

    def predicted(
        self,
        values: Mapping[str, float],
        rows: NDArray[np.intp],
        effects: Sequence[EffectSpec[GainEffectModel]],
    ) -> Array:
        """The gyro's yaw change (rad) the model predicts on windows ``rows``."""
        w = self.w
        const: float | Array = 0.0
        grow: float | Array = 1.0
        slip: float | Array = 0.0
        for e in sorted(effects, key=lambda e: self.order.get(e.key, len(self.order))):
            if e.model is None:
                raise ValueError(f"effect {e.key}: no model hook (a GainEffectModel)")
            own = {p.name: values[f"{e.key}:{p.name}"] for p in e.params}
            c, d = e.model.gain(own, w, rows)
            const, grow = const + c, grow + d
            slip = slip + e.model.slip(own, w, rows)
        g = (1 + const) * grow
        pred = w.odo[rows] * (1 - slip) / np.maximum(g, 1e-3) + values["bias"] * w.dt[rows]
        for e in effects:
            if e.model is not None:
                own = {p.name: values[f"{e.key}:{p.name}"] for p in e.params}
                pred = pred + e.model.added_yaw(own, w, rows)
        return np.asarray(pred, dtype=float)

    def _res(
        self,
        th: Array,
        names: Sequence[str],
        rows: NDArray[np.intp],
        effects: Sequence[EffectSpec[GainEffectModel]],
    ) -> Array:
        v = dict(zip(names, th, strict=True))
        pred = self.predicted(v, rows, effects)
        return np.asarray((self.w.gyro[rows] - pred) / self.sigma, dtype=float)

    def values_on(
        self, effects: Sequence[EffectSpec], rows: NDArray[np.intp]
    ) -> dict[str, float] | None:
        """The fitted values (by name) of ``effects`` on windows ``rows`` (a resample, say);
        None when the fit fails."""
        names = self.names(effects)
        try:
            sol = self._solve(names, effects, rows)
        except ValueError:
            return None
        return dict(zip(names, map(float, sol.x), strict=True))

    def _solve(
        self, names: list[str], effects: Sequence[EffectSpec], rows: NDArray[np.intp]
    ) -> Any:
        spec = {f"{e.key}:{p.name}": p for e in effects for p in e.params}
        lo = np.array([spec[n].lower if n in spec else -np.inf for n in names])
        hi = np.array([spec[n].upper if n in spec else np.inf for n in names])
        x0 = np.array([spec[n].init if n in spec else 0.0 for n in names])
        x0 = np.clip(x0, lo, hi)
        return least_squares(lambda th: self._res(th, names, rows, effects), x0, bounds=(lo, hi))

    @staticmethod
    def names(effects: Sequence[EffectSpec]) -> list[str]:
        return ["bias"] + [f"{e.key}:{p.name}" for e in effects for p in e.params]

    def heldout_residual(self, fit: ModelFit) -> Array:
        """Per window (rad), the gyro's yaw change minus what the model fitted on the other
        fold's turning windows predicts (NaN where a fold cannot be fitted)."""
        effects = fit.effects
        names = self.names(effects)
        w = self.w
        out = np.full(w.t.size, math.nan)
        blocks = ((w.t - w.t[0]) // FOLD_S).astype(int) % 2
        for f, train in ((1, self.folds[0]), (0, self.folds[1])):
            if train.size < 8:
                continue
            try:
                sol = self._solve(names, effects, train)
            except ValueError:
                continue
            test = np.flatnonzero(blocks == f).astype(np.intp)
            v = dict(zip(names, map(float, sol.x), strict=True))
            out[test] = w.gyro[test] - self.predicted(v, test, effects)
        return out

    def __call__(self, effects: tuple[EffectSpec, ...]) -> ModelFit | None:
        why = _nested(effects)
        if why is not None:
            raise CandidateFailedError(why)
        names = self.names(effects)
        try:
            sol = self._solve(names, effects, self.use)
        except ValueError:
            return None
        J, r = np.asarray(sol.jac, float), np.asarray(sol.fun, float)
        S = bartlett_long_run(J * r[:, None], cube_root_lag(r.size))
        cov = sandwich(J.T @ J, S)
        std = np.sqrt(np.maximum(np.diag(cov), 0.0))
        held = 0.0
        for train, test in (self.folds, self.folds[::-1]):
            try:
                s2 = self._solve(names, effects, train)
            except ValueError:
                held = math.nan
                break
            rr = self._res(np.asarray(s2.x), names, test, effects)
            held += float(rr @ rr)
        eff: dict[str, dict[str, Estimate]] = {}
        for e in effects:
            for p in e.params:
                i = names.index(f"{e.key}:{p.name}")
                x, s = float(sol.x[i]), float(std[i])
                eff.setdefault(e.key, {})[p.name] = Estimate(
                    p.name,
                    x,
                    s,
                    (x - 1.96 * s, x + 1.96 * s),
                    s > 0,
                    p.unit,
                    "Newey-West over windows",
                )
        pars = {
            "gyro_bias": Estimate(
                "gyro_bias",
                float(sol.x[0]),
                float(std[0]),
                (float(sol.x[0] - 1.96 * std[0]), float(sol.x[0] + 1.96 * std[0])),
                True,
                "rad/s",
            )
        }
        values = dict(zip(names, map(float, sol.x), strict=True))
        return ModelFit(
            effects,
            pars,
            eff,
            float(r @ r),
            held,
            r.size,
            len(names),
            payload=GainPayload(tuple(names), values, np.asarray(cov, dtype=float), r, J),
        )
