"""The fitter discovery calls on the odometry + IMU windows: the gyro's yaw change predicted as
the odometry's divided by the gain the effects make, plus a gyro bias x duration, in units of
the residual's noise floor; its held-out sum of squares over two folds of alternating time
blocks; Newey-West (Bartlett) standard errors over windows."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from calib.diff_drive.odom_imu.effects import GainEffectModel
from calib.diff_drive.odom_imu.windows import FOLD_S, Windows
from calib.discovery import EffectSpec, ModelFit
from calib.results import Estimate
from calib.stats import bartlett_long_run, cube_root_lag, sandwich

__all__ = ["GainFitter"]

Array = NDArray[np.float64]


class GainFitter:
    """Nominal: the odometry's yaw rate is the true one (G = 1) up to a gyro bias; effects:
    a constant gain, its growth with |turn rate| and with speed."""

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

    def _res(
        self,
        th: Array,
        names: Sequence[str],
        rows: NDArray[np.intp],
        effects: Sequence[EffectSpec[GainEffectModel]],
    ) -> Array:
        v = dict(zip(names, th, strict=True))
        w = self.w
        const: float | Array = 0.0
        grow: float | Array = 1.0
        for e in sorted(effects, key=lambda e: self.order.get(e.key, len(self.order))):
            if e.model is None:
                raise ValueError(f"effect {e.key}: no model hook (a GainEffectModel)")
            c, d = e.model.gain({p.name: v[f"{e.key}:{p.name}"] for p in e.params}, w, rows)
            const, grow = const + c, grow + d
        g = (1 + const) * grow
        pred = w.odo[rows] / np.maximum(g, 1e-3) + v["bias"] * w.dt[rows]
        return np.asarray((w.gyro[rows] - pred) / self.sigma, dtype=float)

    def _solve(
        self, names: list[str], effects: Sequence[EffectSpec], rows: NDArray[np.intp]
    ) -> Any:
        spec = {f"{e.key}:{p.name}": p for e in effects for p in e.params}
        lo = np.array([spec[n].lower if n in spec else -np.inf for n in names])
        hi = np.array([spec[n].upper if n in spec else np.inf for n in names])
        x0 = np.zeros(len(names))
        return least_squares(lambda th: self._res(th, names, rows, effects), x0, bounds=(lo, hi))

    def __call__(self, effects: tuple[EffectSpec, ...]) -> ModelFit | None:
        names = ["bias"] + [f"{e.key}:{p.name}" for e in effects for p in e.params]
        try:
            sol = self._solve(names, effects, self.use)
        except ValueError:
            return None
        J, r = np.asarray(sol.jac, float), np.asarray(sol.fun, float)
        S = bartlett_long_run(J * r[:, None], cube_root_lag(r.size))
        std = np.sqrt(np.maximum(np.diag(sandwich(J.T @ J, S)), 0.0))
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
        return ModelFit(
            effects,
            pars,
            eff,
            float(r @ r),
            held,
            r.size,
            len(names),
            payload=dict(zip(names, map(float, sol.x), strict=True)),
        )
