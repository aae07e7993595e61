"""Regression rows from prepared joint signals: the classic (acceleration) rows and the
momentum-integral rows, over short windows (batch fits) or from the start (the paper's u(t)).

Momentum rows, from ``int_a^b tau dt = [Xp theta]_a^b + int_a^b Xr theta dt`` (trapezoid rule
on the grid): no joint acceleration enters, and the torque and the rest of the equation are
integrated, which averages their noise instead of differentiating it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.integrate import cumulative_trapezoid

from calib.errors import InsufficientDataError
from calib.manipulator.design import Design
from calib.manipulator.signals import JointSignals

__all__ = ["Regressors", "compute_regressors"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Regressors:
    """The design's columns along a log, computed once and sliced by the fits.

    ``Xc``/``kc``: classic columns and known part (N, n, P) / (N, n); ``Xp``, ``Xr``, ``kp``,
    ``kr``: momentum and rest; ``sig``: the signals they were computed on.
    """

    sig: JointSignals
    Xc: Array
    kc: Array
    Xp: Array
    Xr: Array
    kp: Array
    kr: Array

    def classic_rows(self, start: int, stop: int) -> tuple[Array, Array]:
        """(X, y): filtered torque minus the known part, on samples [start, stop)."""
        return self.Xc[start:stop], self.sig.tau_f[start:stop] - self.kc[start:stop]

    def predict(self, theta: Array, start: int, stop: int) -> Array:
        """Torque predicted by ``theta`` on samples [start, stop) (classic form)."""
        return self.Xc[start:stop] @ np.nan_to_num(theta) + self.kc[start:stop]

    def _cumulative(self, start: int, stop: int) -> tuple[Array, Array, Array]:
        t = self.sig.t_s[start:stop]
        ci = cumulative_trapezoid(self.Xr[start:stop], t, axis=0, initial=0.0)
        ct = cumulative_trapezoid(self.sig.tau_f[start:stop], t, axis=0, initial=0.0)
        ck = cumulative_trapezoid(self.kr[start:stop], t, axis=0, initial=0.0)
        return ci, ct, ck

    def momentum_windows(
        self, start: int, stop: int, window_s: float
    ) -> tuple[Array, Array, Array]:
        """(X (W, n, P), u (W, n), t_end (W,)) over consecutive windows of ``window_s``."""
        step = max(1, round(window_s * self.sig.rate_hz))
        if stop - start <= step:
            raise InsufficientDataError(
                f"{(stop - start) / self.sig.rate_hz:.2f} s of joint data; a momentum window "
                f"needs {window_s:g} s"
            )
        ci, ct, ck = self._cumulative(start, stop)
        b = np.arange(0, stop - start, step)
        Xp, kp = self.Xp[start:stop], self.kp[start:stop]
        X = (Xp[b[1:]] - Xp[b[:-1]]) + (ci[b[1:]] - ci[b[:-1]])
        known = (kp[b[1:]] - kp[b[:-1]]) + (ck[b[1:]] - ck[b[:-1]])
        u = (ct[b[1:]] - ct[b[:-1]]) - known
        return X, u, self.sig.t_s[start:stop][b[1:]]

    def cumulative_rows(self, start: int, stop: int, every: int = 1) -> tuple[Array, Array, Array]:
        """The paper's rows u(t) = int_0^t tau = Y_H(t) theta, every ``every``-th sample."""
        ci, ct, ck = self._cumulative(start, stop)
        Xp, kp = self.Xp[start:stop], self.kp[start:stop]
        idx = np.arange(1, stop - start, every)
        X = Xp[idx] - Xp[0] + ci[idx]
        u = ct[idx] - (kp[idx] - kp[0] + ck[idx])
        return X, u, self.sig.t_s[start:stop][idx]


def compute_regressors(design: Design, sig: JointSignals) -> Regressors:
    """Evaluate ``design``'s classic and momentum columns on ``sig``."""
    Xc, kc = design.classic(sig.q, sig.qd, sig.qdd)
    Xp, Xr, kp, kr = design.momentum(sig.q, sig.qd)
    return Regressors(sig, Xc, kc, Xp, Xr, kp, kr)
