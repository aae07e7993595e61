"""Command templates fitted to one segment (least squares), simplest first.

Templates (patent H, C, L plus our own), value in 1/m at local time t:

* constant: ``c`` (1 parameter)
* linear: ``a t + b`` (2)
* step: ``c1`` before ``t_step``, ``c2`` from it on (3); ``t_step`` is the local time of the
  first sample at the second level
* harmonic: ``M sin(omega t + phi) + c`` (4), omega searched on a grid from a quarter of a
  period in the segment up to 20 periods (or a quarter of the sample rate), then polished
* curve: ``M tanh(omega (t - t0)) + c`` (4), (omega, t0) searched on a grid, then polished
* other: a cubic least-squares spline with interior knots every ``max(5 s, length / 20)``
  (4 + knots parameters), the fallback when no template fits.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import make_lsq_spline
from scipy.optimize import least_squares, minimize_scalar

from calib.tractor_trailer.results import CommandType

__all__ = ["N_PARAMS_MIN", "TEMPLATE_ORDER", "TemplateFit", "fit_all", "fit_template"]


_GRID_POINTS = 1200  # at most this many samples in the grid searches


@dataclass(frozen=True)
class TemplateFit:
    """One template fitted to (t, y): parameters, residual sum of squares, parameter count."""

    kind: CommandType
    params: dict[str, float]
    rss: float
    n_params: int
    func: Callable[[np.ndarray], np.ndarray] = field(repr=False, compare=False)

    def __call__(self, t_local: np.ndarray) -> np.ndarray:
        """Template value (1/m) at local times (s)."""
        return self.func(np.asarray(t_local, dtype=float))


def _rss(y: np.ndarray, f: np.ndarray | float) -> float:
    return float(np.sum((y - f) ** 2))


def _constant(t: np.ndarray, y: np.ndarray) -> TemplateFit:
    c = float(np.mean(y))
    return TemplateFit(CommandType.CONSTANT, {"c": c}, _rss(y, c), 1, lambda s: np.full(s.shape, c))


def _linear(t: np.ndarray, y: np.ndarray) -> TemplateFit:
    if t.size < 2:
        return _constant(t, y)
    tm = float(np.mean(t))
    a, b0 = np.polyfit(t - tm, y, 1)
    a, b = float(a), float(b0 - a * tm)
    return TemplateFit(
        CommandType.LINEAR, {"a": a, "b": b}, _rss(y, a * t + b), 2, lambda s: a * s + b
    )


def _step(t: np.ndarray, y: np.ndarray) -> TemplateFit:
    n = y.size
    if n < 2:
        return _constant(t, y)
    cs, cs2 = np.cumsum(y), np.cumsum(y * y)
    j = np.arange(1, n)  # first index of the second level
    left = cs2[j - 1] - cs[j - 1] ** 2 / j
    right = (cs2[-1] - cs2[j - 1]) - (cs[-1] - cs[j - 1]) ** 2 / (n - j)
    k = int(np.argmin(left + right))
    jj = int(j[k])
    c1, c2, ts = float(np.mean(y[:jj])), float(np.mean(y[jj:])), float(t[jj])
    rss = float(max(left[k] + right[k], 0.0))
    return TemplateFit(
        CommandType.STEP,
        {"c1": c1, "c2": c2, "t_step": ts},
        rss,
        3,
        lambda s: np.where(s >= ts, c2, c1),
    )


def _thin(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    step = max(1, int(np.ceil(t.size / _GRID_POINTS)))
    return t[::step], y[::step]


def _harmonic_rss(w: np.ndarray, tc: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RSS and [a, b, c] of y ~ a sin(w tc) + b cos(w tc) + c for each w."""
    ph = np.outer(w, tc)
    cols = np.empty((ph.shape[0], 3, ph.shape[1]))  # (m, 3, n): sin, cos, 1
    np.sin(ph, out=cols[:, 0])
    np.cos(ph, out=cols[:, 1])
    cols[:, 2] = 1.0
    A = np.einsum("mik,mjk->mij", cols, cols)
    r = np.einsum("mik,k->mi", cols, y)
    A += np.eye(3) * 1e-12 * np.trace(A, axis1=1, axis2=2)[:, None, None]
    beta = np.linalg.solve(A, r[..., None])[..., 0]
    rss = float(y @ y) - np.einsum("mi,mi->m", beta, r)
    return np.maximum(rss, 0.0), beta


def _harmonic(t: np.ndarray, y: np.ndarray) -> TemplateFit | None:
    n = t.size
    length = float(t[-1] - t[0]) if n > 1 else 0.0
    if n < 6 or length <= 0:
        return None
    dt = length / (n - 1)
    w_lo = np.pi / (4 * length)
    w_hi = max(min(40 * np.pi / length, np.pi / (4 * dt)), 2 * w_lo)
    tm = 0.5 * (t[0] + t[-1])
    tg, yg = _thin(t, y)
    grid = np.arange(w_lo, w_hi, np.pi / (4 * length))
    rss, _ = _harmonic_rss(grid, tg - tm, yg)
    i = int(np.argmin(rss))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    if hi > lo:
        res = minimize_scalar(
            lambda w: float(_harmonic_rss(np.array([w]), t - tm, y)[0][0]),
            bounds=(lo, hi),
            method="bounded",
            options={"xatol": 1e-7 * hi},
        )
        w = float(res.x)
    else:
        w = float(grid[i])
    rss1, beta = _harmonic_rss(np.array([w]), t - tm, y)
    a, b, c = (float(v) for v in beta[0])
    M = float(np.hypot(a, b))
    phi = float(np.arctan2(b, a) - w * tm)  # in local time t (not centred)
    phi = float((phi + np.pi) % (2 * np.pi) - np.pi)
    return TemplateFit(
        CommandType.HARMONIC,
        {"M": M, "omega": w, "phi": phi, "c": c},
        float(rss1[0]),
        4,
        lambda s: M * np.sin(w * s + phi) + c,
    )


def _tanh_lin(w: float, t0: float, t: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Best (M, c) and RSS of y ~ M tanh(w (t - t0)) + c."""
    g = np.tanh(w * (t - t0))
    gm, ym = g.mean(), y.mean()
    var = float(np.sum((g - gm) ** 2))
    M = float(np.sum((g - gm) * (y - ym)) / var) if var > 1e-300 else 0.0
    c = float(ym - M * gm)
    return M, c, _rss(y, M * g + c)


def _curve(t: np.ndarray, y: np.ndarray) -> TemplateFit | None:
    n = t.size
    length = float(t[-1] - t[0]) if n > 1 else 0.0
    if n < 6 or length <= 0:
        return None
    tg, yg = _thin(t, y)
    ws = np.geomspace(0.3, 60.0, 14) / length
    t0s = t[0] + np.linspace(-0.5, 1.5, 25) * length
    W, T0 = np.meshgrid(ws, t0s, indexing="ij")
    G = np.tanh(W.ravel()[:, None] * (tg[None, :] - T0.ravel()[:, None]))
    Gc = G - G.mean(axis=1, keepdims=True)
    yc = yg - yg.mean()
    var = np.einsum("ij,ij->i", Gc, Gc)
    cov = Gc @ yc
    with np.errstate(divide="ignore", invalid="ignore"):
        rss = float(yc @ yc) - np.where(var > 1e-300, cov**2 / var, 0.0)
    k = int(np.argmin(rss))
    w0, t00 = W.ravel()[k], T0.ravel()[k]
    M0, c0, _ = _tanh_lin(w0, t00, t, y)
    x0 = np.array([M0, np.log(w0 * length), (t00 - t[0]) / length, c0])

    def model(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        w = np.exp(np.clip(p[1], -20.0, 20.0)) / length
        u = w * (t - (t[0] + p[2] * length))
        return u, np.tanh(u), w

    def resid(p: np.ndarray) -> np.ndarray:
        _, g, _ = model(p)
        return p[0] * g + p[3] - y

    def jac(p: np.ndarray) -> np.ndarray:
        u, g, w = model(p)
        sech2 = 1.0 - g * g
        return np.column_stack([g, p[0] * sech2 * u, -p[0] * sech2 * w * length, np.ones_like(u)])

    sol = least_squares(
        resid, x0, jac=jac, method="lm", xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200
    )
    p = sol.x if sol.cost <= 0.5 * float(np.sum(resid(x0) ** 2)) else x0
    w, t0 = float(np.exp(np.clip(p[1], -20.0, 20.0)) / length), float(t[0] + p[2] * length)
    M, c, rss1 = _tanh_lin(w, t0, t, y)
    return TemplateFit(
        CommandType.CURVE,
        {"M": M, "omega": w, "t0": t0, "c": c},
        rss1,
        4,
        lambda s: M * np.tanh(w * (s - t0)) + c,
    )


def _other(t: np.ndarray, y: np.ndarray) -> TemplateFit:
    n = t.size
    length = float(t[-1] - t[0]) if n > 1 else 0.0
    spacing = max(5.0, length / 20)
    n_inner = int(length // spacing)
    if n < n_inner + 8:
        n_inner = max(0, n - 8)
    if n < 5:
        return _linear(t, y)
    inner = t[0] + np.arange(1, n_inner + 1) * (length / (n_inner + 1))
    knots = np.concatenate([[t[0]] * 4, inner, [t[-1]] * 4])
    spl = make_lsq_spline(t, y, knots, k=3)
    t_lo, t_hi = float(t[0]), float(t[-1])
    return TemplateFit(
        CommandType.OTHER,
        {"knots": float(n_inner)},
        _rss(y, spl(t)),
        4 + n_inner,
        lambda s: spl(np.clip(s, t_lo, t_hi)),
    )


TEMPLATE_ORDER = (
    CommandType.CONSTANT,
    CommandType.LINEAR,
    CommandType.STEP,
    CommandType.HARMONIC,
    CommandType.CURVE,
    CommandType.OTHER,
)
N_PARAMS_MIN = {
    CommandType.CONSTANT: 1,
    CommandType.LINEAR: 2,
    CommandType.STEP: 3,
    CommandType.HARMONIC: 4,
    CommandType.CURVE: 4,
    CommandType.OTHER: 5,  # at least
}

FITTERS = {
    CommandType.CONSTANT: _constant,
    CommandType.LINEAR: _linear,
    CommandType.STEP: _step,
    CommandType.HARMONIC: _harmonic,
    CommandType.CURVE: _curve,
    CommandType.OTHER: _other,
}


def fit_template(kind: CommandType, t: np.ndarray, y: np.ndarray) -> TemplateFit | None:
    """Fit one template to (t local s, y 1/m); None when the segment is too short for it."""
    return FITTERS[CommandType(kind)](np.asarray(t, float), np.asarray(y, float))


def fit_all(
    t: np.ndarray, y: np.ndarray, kinds: tuple[CommandType, ...] = tuple(FITTERS)
) -> list[TemplateFit]:
    """Fit every template in ``kinds`` that the segment is long enough for."""
    fits = [fit_template(k, t, y) for k in kinds]
    return [f for f in fits if f is not None]
