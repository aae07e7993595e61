"""Split a curvature command into segments and label each with its template type.

Pipeline (``segment_command``):

1. **Decimate** the command onto a uniform grid of at most 10 Hz by picking the nearest sample
   (no averaging, so jumps stay sharp). The noise level sigma is estimated from second
   differences (robust MAD and a trimmed RMS) with a floor of 1e-3 of the command's scale and,
   for a quantised command (its changes are multiples of a step q), of q / sqrt(12).
2. **Change points.** Value jumps are found on the first differences (larger than
   8 sigma sqrt(2), 2 % of the scale and 2.5 q, beyond what the local slope explains), placed on
   the exact sample of the full-rate signal. Between jumps, binary segmentation splits each
   stretch where two straight lines fit best (so breaks land on slope changes), until a piece
   is fitted by one template to within the noise (reduced chi^2 <= 1 + 4 sqrt(2 / n)) or is
   shorter than 2 s.
3. **Merge by BIC.** Each piece is fitted with every template (see Templates below);
   its cost is BIC = RSS / sigma^2 + (k + 1) ln N (k template parameters, + 1 for the
   boundary, N samples). Adjacent pieces not separated by a jump are merged, greediest first,
   while the merged segment's best template has a lower BIC than the two apart. A template
   segment is never merged into "other".
4. **Dissolve and refine.** A segment of at most 30 s between two others, not separated by
   jumps, usually straddles a smooth join (a harmonic ending at 0 followed by a tanh from 0):
   it is handed to its neighbours when that lowers the BIC. Then each boundary that is not a
   jump is refined: both neighbours' templates are fitted away from it (margin: a quarter of
   the window), extrapolated over a window of +-8 s, and the boundary moves to where the
   summed squared residuals are least, if that lowers the BIC (up to 4 passes, relabelling
   both sides in between). Merging (3.) and refining are then run once more.
5. **Step rule.** A jump between two constant levels is held by a ``step`` segment made of
   both levels (template: levels ``c1``, ``c2`` and the local jump time ``t_step``). Where
   several levels follow each other across jumps, they are grouped into as many steps as
   possible, and among those groupings the one whose jumps lie nearest the middle of their
   steps wins (the simulator's step has its jump in the middle); a level left over is a
   ``constant``. E.g. levels of 30 s, 15 s, 15 s give constant + step (jump in the middle);
   two levels give one step.
6. Segments shorter than ``min_len_s`` are merged into the neighbour that fits best; every
   segment is finally labelled by the lowest BIC over the templates, and its parameters
   (segment-local time, s) go into ``Segment.parameters`` with ``rms`` (1/m), the fit's
   residual RMS.

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

from calib.results import CommandType, Segment
from logtools.errors import SignalValueError

__all__ = ["SegmentationSettings", "TemplateFit", "fit_template", "segment_command"]


# ---------------------------------------------------------------------------- templates

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


def _rss(y: np.ndarray, f: np.ndarray) -> float:
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
    s, c = np.sin(ph), np.cos(ph)
    one = np.ones_like(s)
    cols = np.stack([s, c, one], axis=1)  # (m, 3, n)
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
_K = {
    CommandType.CONSTANT: 1,
    CommandType.LINEAR: 2,
    CommandType.STEP: 3,
    CommandType.HARMONIC: 4,
    CommandType.CURVE: 4,
    CommandType.OTHER: 5,  # at least
}

_FITTERS = {
    CommandType.CONSTANT: _constant,
    CommandType.LINEAR: _linear,
    CommandType.STEP: _step,
    CommandType.HARMONIC: _harmonic,
    CommandType.CURVE: _curve,
    CommandType.OTHER: _other,
}


def fit_template(kind: CommandType, t: np.ndarray, y: np.ndarray) -> TemplateFit | None:
    """Fit one template to (t local s, y 1/m); None when the segment is too short for it."""
    return _FITTERS[CommandType(kind)](np.asarray(t, float), np.asarray(y, float))


def fit_all(
    t: np.ndarray, y: np.ndarray, kinds: tuple[CommandType, ...] = tuple(_FITTERS)
) -> list[TemplateFit]:
    """Fit every template in ``kinds`` that the segment is long enough for."""
    fits = [fit_template(k, t, y) for k in kinds]
    return [f for f in fits if f is not None]


# ---------------------------------------------------------------------------- settings


@dataclass(frozen=True)
class SegmentationSettings:
    """Tuning of ``segment_command`` (the defaults are the documented method).

    Args:
        max_rate_hz: rate (Hz) of the decimated grid the search runs on.
        merge_rate_hz: rate (Hz) of the grid on which merge decisions fit templates.
        jump_sigmas: a jump exceeds this many noise standard deviations of a difference.
        jump_frac: ... and this fraction of the command's scale.
        min_piece_s: shortest piece (s) binary segmentation makes.
        refine_window_s: half-width (s) of the boundary refinement window.
        sigma_floor_frac: floor of the noise level, as a fraction of the scale.
        dissolve_max_s: longest segment (s) that may be handed to its neighbours.
    """

    max_rate_hz: float = 10.0
    merge_rate_hz: float = 2.0
    jump_sigmas: float = 8.0
    jump_frac: float = 0.02
    min_piece_s: float = 1.0
    refine_window_s: float = 8.0
    sigma_floor_frac: float = 1e-3
    dissolve_max_s: float = 30.0


@dataclass
class _Seg:
    a: int  # decimated index, inclusive
    b: int  # decimated index, exclusive
    jump_left: bool  # the boundary at a is a jump
    fit: TemplateFit | None = None
    bic: float = np.inf
    hint: int = 0  # refinement half-window (samples) the boundary at a needs at least


# ---------------------------------------------------------------------------- preparation


def _clean_inputs(t_s: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(t_s, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or t.shape != y.shape:
        raise SignalValueError(
            f"segment_command: t_s and kappa_cmd must be 1-D of equal length, got shapes "
            f"{t.shape} and {y.shape}"
        )
    if t.size and (not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0)):
        raise SignalValueError("segment_command: t_s (s) must be finite and strictly increasing")
    ok = np.isfinite(y)
    if ok.any() and not ok.all():
        y = np.interp(t, t[ok], y[ok])  # bridge missing command samples
    return t, y


def _decimate(
    t: np.ndarray, y: np.ndarray, rate_hz: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid of period max(median dt, 1 / rate_hz), nearest-sample values and their indices.

    Grid points farther than half a period from any sample (dropouts) get linearly
    interpolated values instead, so a gap does not look like a jump.
    """
    dt = max(float(np.median(np.diff(t))), 1.0 / rate_hz)
    n = int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1
    grid = t[0] + np.arange(n) * dt
    hi = np.clip(np.searchsorted(t, grid), 0, t.size - 1)
    lo = np.clip(hi - 1, 0, t.size - 1)
    idx = np.where(np.abs(t[lo] - grid) <= np.abs(t[hi] - grid), lo, hi)
    values = y[idx]
    gap = np.abs(t[idx] - grid) > 0.5 * dt  # inside a dropout: bridge linearly
    values[gap] = np.interp(grid[gap], t, y)
    return grid, values, idx


def _scale(y: np.ndarray) -> float:
    return float(np.percentile(np.abs(y - np.median(y)), 99)) if y.size else 0.0


def _noise_sigma(y: np.ndarray, floor: float) -> float:
    """Noise standard deviation from second differences (robust), at least ``floor``."""
    if y.size < 5:
        return floor
    d2 = y[2:] - 2 * y[1:-1] + y[:-2]
    mad = 1.4826 * float(np.median(np.abs(d2 - np.median(d2)))) / np.sqrt(6)
    a = np.sort(np.abs(d2))[: max(1, int(0.98 * d2.size))]
    trimmed = float(np.sqrt(np.mean(a * a))) / np.sqrt(6)
    return max(mad, trimmed, floor)


# ---------------------------------------------------------------------------- change points


def _quantum(y: np.ndarray, scale: float) -> float:
    """Quantisation step (1/m) of the command, 0 when its changes are not on a lattice."""
    d = np.abs(np.diff(y))
    nz = d[d > 1e-9 * max(scale, 1e-300)]
    if nz.size < 10:
        return 0.0
    q = float(np.percentile(nz, 5))
    r = nz / q
    on_lattice = np.mean(np.abs(r - np.round(r)) < 0.02)
    return q if on_lattice >= 0.95 else 0.0


def _jumps(
    y: np.ndarray, sigma: float, scale: float, quantum: float, cfg: SegmentationSettings
) -> np.ndarray:
    """Decimated indices i where a new level starts (jump between i - 1 and i)."""
    d = np.diff(y)
    if d.size < 3:
        return np.array([], dtype=int)
    pad = np.pad(d, 2, mode="edge")
    neigh = np.stack([pad[0:-4], pad[1:-3], pad[3:-1], pad[4:]])
    pred = np.median(neigh, axis=0)
    thr = max(cfg.jump_sigmas * sigma * np.sqrt(2), cfg.jump_frac * scale, 2.5 * quantum)
    excess = np.abs(d - pred)
    cand = np.flatnonzero(excess > thr)
    # one jump per cluster of neighbouring candidates: keep the largest
    keep: list[int] = []
    for i in cand:
        if keep and i - keep[-1] <= 1:
            if excess[i] > excess[keep[-1]]:
                keep[-1] = int(i)
        else:
            keep.append(int(i))
    return np.asarray(keep, dtype=int) + 1


def _line_rss_splits(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """RSS of two-line fits split before each index j (1..n-1), and of one line."""
    t = t - t.mean()
    cols = np.stack([np.ones_like(t), t, t * t, y, t * y, y * y])
    cs = np.cumsum(cols, axis=1)
    tot = cs[:, -1]

    def rss(s: np.ndarray) -> np.ndarray:
        n, st, stt, sy, sty, syy = s
        det = n * stt - st * st
        with np.errstate(divide="ignore", invalid="ignore"):
            fit = np.where(
                det > 0,
                (stt * sy * sy - 2 * st * sy * sty + n * sty * sty) / det,
                np.where(n > 0, sy * sy / np.maximum(n, 1), 0.0),
            )
        return np.maximum(syy - fit, 0.0)

    left = cs[:, :-1]
    right = tot[:, None] - left
    return rss(left) + rss(right), float(rss(tot[:, None])[0])


# ---------------------------------------------------------------------------- fitting, BIC


class _Scorer:
    """Fits templates on the merge grid and scores them by BIC."""

    def __init__(self, t: np.ndarray, y: np.ndarray, step: int, sigma: float) -> None:
        self.t, self.y, self.step, self.sigma = t, y, step, sigma
        self.log_n = float(np.log(max(t.size / step, 2)))

    def best_xy(
        self, tt: np.ndarray, yy: np.ndarray, weight: float, allow_other: bool = True
    ) -> tuple[TemplateFit, float]:
        """Lowest-BIC template on (tt local s, yy); ``weight`` merge-grid samples per point.

        Templates are tried simplest first; once the best so far fits to within the noise,
        templates with at least as many parameters are skipped (they cannot win by more
        than the noise).
        """
        best: tuple[TemplateFit, float] | None = None
        noise_rss = self.sigma**2 * tt.size * (1.0 + 4.0 * np.sqrt(2.0 / tt.size))
        for kind in TEMPLATE_ORDER:
            if kind is CommandType.OTHER and not allow_other:
                continue
            if best is not None and best[0].rss <= noise_rss and best[0].n_params <= _K[kind]:
                continue
            f = fit_template(kind, tt, yy)
            if f is None:
                continue
            score = f.rss * weight / (self.sigma**2) + (f.n_params + 1) * self.log_n
            if best is None or score < best[1]:
                best = (f, score)
        if best is None:  # cannot happen: the constant template always fits
            raise AssertionError("no template fitted")
        return best

    def thin(self, a: int, b: int) -> int:
        """Stride of the merge grid on decimated samples [a, b)."""
        return self.step if (b - a) // self.step >= 8 else 1

    def weight(self, a: int, b: int) -> float:
        """Merge-grid samples each thinned sample of [a, b) stands for."""
        return self.thin(a, b) / self.step

    def best(self, a: int, b: int, allow_other: bool = True) -> tuple[TemplateFit, float]:
        """Lowest-BIC template on decimated samples [a, b), thinned to the merge grid."""
        sl = slice(a, b, self.thin(a, b))
        return self.best_xy(self.t[sl] - self.t[a], self.y[sl], self.weight(a, b), allow_other)


def _score(seg: _Seg, sc: _Scorer, allow_other: bool = True) -> _Seg:
    seg.fit, seg.bic = sc.best(seg.a, seg.b, allow_other)
    return seg


def _binseg(
    t: np.ndarray, y: np.ndarray, a: int, b: int, sc: _Scorer, min_piece: int
) -> list[_Seg]:
    """Pieces of [a, b) from binary segmentation: split where two lines fit best, until a
    piece is fitted by one template to within the noise (or is too short to split)."""
    pieces: list[_Seg] = []
    stack = [(a, b)]
    while stack:
        lo, hi = stack.pop()
        seg = _Seg(lo, hi, False)
        _score(seg, sc, allow_other=False)
        n_eff = len(range(lo, hi, sc.thin(lo, hi)))
        chi2_red = seg.fit.rss * sc.weight(lo, hi) / sc.sigma**2 / n_eff
        if hi - lo < 2 * min_piece or chi2_red <= 1.0 + 4.0 * np.sqrt(2.0 / n_eff):
            pieces.append(seg)
            continue
        split, _ = _line_rss_splits(t[lo:hi], y[lo:hi])
        j = np.arange(1, hi - lo)
        ok = (j >= min_piece) & (j <= hi - lo - min_piece)
        k = int(j[ok][np.argmin(split[ok])])
        stack += [(lo + k, hi), (lo, lo + k)]
    return sorted(pieces, key=lambda p: p.a)


def _merge(segs: list[_Seg], sc: _Scorer) -> list[_Seg]:
    """Greedy bottom-up merging of neighbours across soft boundaries while BIC improves."""
    for s in segs:
        _score(s, sc)

    def union(i: int) -> tuple[float, TemplateFit | None, float]:
        left, right = segs[i], segs[i + 1]
        if right.jump_left:
            return -np.inf, None, np.inf
        both_other = left.fit.kind is CommandType.OTHER and right.fit.kind is CommandType.OTHER
        fit, bic = sc.best(left.a, right.b, allow_other=both_other)
        return left.bic + right.bic - bic, fit, bic

    gains = [union(i) for i in range(len(segs) - 1)]
    while gains:
        i = int(np.argmax([g[0] for g in gains]))
        gain, fit, bic = gains[i]
        if not gain >= 0:
            break
        left, right = segs[i], segs[i + 1]
        segs[i] = _Seg(left.a, right.b, left.jump_left, fit, bic)
        del segs[i + 1]
        del gains[i]
        if i < len(gains):
            gains[i] = union(i)
        if i > 0:
            gains[i - 1] = union(i - 1)
    return segs


# ---------------------------------------------------------------------------- refinement


def _dissolve_short(segs: list[_Seg], sc: _Scorer, max_len: int, win: int) -> list[_Seg]:
    """Hand short segments to their neighbours where that lowers the BIC.

    A short segment between two templates usually straddles a smooth join of the two. It goes
    to the neighbours it is not separated from by a jump (split at its middle, then the new
    boundary refined, when both qualify); the change is kept only if the total BIC drops.
    """
    i = 0
    while i < len(segs):
        mid_seg = segs[i]
        left = segs[i - 1] if i > 0 and not mid_seg.jump_left else None
        right = segs[i + 1] if i + 1 < len(segs) and not segs[i + 1].jump_left else None
        if mid_seg.b - mid_seg.a > max_len or (left is None and right is None):
            i += 1
            continue
        old = mid_seg.bic + (left.bic if left else 0.0) + (right.bic if right else 0.0)
        kinds = {x.fit.kind for x in (left, mid_seg, right) if x is not None}
        other = kinds == {CommandType.OTHER}  # never turn a template into "other"
        if left is not None and right is not None:
            half = (mid_seg.a + mid_seg.b) // 2
            new_l = _score(_Seg(left.a, half, left.jump_left), sc, other)
            new_r = _Seg(half, right.b, False, hint=mid_seg.b - mid_seg.a)
            _score(new_r, sc, other)
            _refine_pair(new_l, new_r, sc, win, allow_other=other)
            new = [new_l, new_r]
        elif left is not None:
            new = [_score(_Seg(left.a, mid_seg.b, left.jump_left), sc, other)]
        else:
            new = [_score(_Seg(mid_seg.a, right.b, mid_seg.jump_left), sc, other)]
        if sum(s.bic for s in new) < old:
            lo = i - 1 if left is not None else i
            hi = i + 2 if right is not None else i + 1
            segs[lo:hi] = new
            i = max(lo, 0)
        else:
            i += 1
    return segs


def _refine_pair(
    left: _Seg, right: _Seg, sc: _Scorer, win: int, passes: int = 4, allow_other: bool = True
) -> None:
    """Move the soft boundary between two segments to where their templates split best.

    Each side's template is fitted away from the boundary (a margin of a quarter of the
    window, or half the ``hint``) and extrapolated over the window; the boundary moves to the
    least summed squared residuals if that lowers the BIC. Both sides are relabelled (best
    template other than "other") before each pass, so a boundary that was off at first gets
    the right templates on both sides as it converges.
    """
    t, y = sc.t, sc.y
    for _ in range(passes):
        _score(left, sc, allow_other=False)
        _score(right, sc, allow_other=False)
        b = right.a
        w = min(max(win, right.hint), (b - left.a) // 3, (right.b - b) // 3)
        if w < 2:
            break
        m = min(max(w // 4, right.hint // 2), w)  # margin kept out of the fits
        fl = _fit_kind(left.fit.kind, t[left.a : b - m] - t[left.a], y[left.a : b - m])
        fr = _fit_kind(right.fit.kind, t[b + m : right.b] - t[b + m], y[b + m : right.b])
        if fl is None or fr is None:
            break
        tw, yw = t[b - w : b + w], y[b - w : b + w]
        rl = (yw - fl(tw - t[left.a])) ** 2
        rr = (yw - fr(tw - t[b + m])) ** 2
        cost = np.concatenate([[0.0], np.cumsum(rl)]) + np.concatenate(
            [np.cumsum(rr[::-1])[::-1], [0.0]]
        )
        nb = int(np.clip(b - w + int(np.argmin(cost)), left.a + 2, right.b - 2))
        if nb == b:
            break
        before = left.bic + right.bic
        left.b = right.a = nb
        after = _score(left, sc, False).bic + _score(right, sc, False).bic
        if after > before:  # keep only improvements
            left.b = right.a = b
            break
    _score(left, sc, allow_other)
    _score(right, sc, allow_other)


def _refine(segs: list[_Seg], sc: _Scorer, win: int) -> None:
    """Refine every boundary that is not a jump (see ``_refine_pair``)."""
    for i in range(1, len(segs)):
        if not segs[i].jump_left:
            _refine_pair(segs[i - 1], segs[i], sc, win)


def _fit_kind(kind: CommandType, t: np.ndarray, y: np.ndarray) -> TemplateFit | None:
    if t.size < 8:
        return None
    fits = fit_all(t, y, (kind,))
    return fits[0] if fits else None


# ---------------------------------------------------------------------------- step rule, short


def _pair_levels(lengths: list[int]) -> list[int]:
    """Group consecutive constant levels into steps (2 levels) and constants (1 level).

    As many steps as possible; among those groupings, the one whose jumps sit nearest the
    middle of their step segments. Returns the group sizes in order.
    """
    n = len(lengths)
    # best[i]: (-steps, off-centre penalty, groups) for the first i levels
    best: list[tuple[int, float, list[int]]] = [(0, 0.0, [])]
    for i in range(1, n + 1):
        prev = best[i - 1]
        cand = [(prev[0], prev[1], [*prev[2], 1])]
        if i >= 2:
            p2 = best[i - 2]
            off = abs(lengths[i - 2] / (lengths[i - 2] + lengths[i - 1]) - 0.5)
            cand.append((p2[0] - 1, p2[1] + off, [*p2[2], 2]))
        best.append(min(cand, key=lambda c: (c[0], c[1])))
    return best[n][2]


def _step_rule(segs: list[_Seg], sc: _Scorer) -> list[_Seg]:
    """Turn constant levels joined by jumps into step segments (see module doc)."""
    out: list[_Seg] = []
    i = 0
    while i < len(segs):
        j = i
        while (
            j + 1 < len(segs)
            and segs[j + 1].jump_left
            and segs[j].fit.kind is CommandType.CONSTANT
            and segs[j + 1].fit.kind is CommandType.CONSTANT
        ):
            j += 1
        run = segs[i : j + 1]
        k = 0
        for size in _pair_levels([s.b - s.a for s in run]):
            if size == 1:
                out.append(run[k])
            else:
                out.append(_score(_Seg(run[k].a, run[k + 1].b, run[k].jump_left), sc))
            k += size
        i = j + 1
    return out


def _absorb_short(segs: list[_Seg], sc: _Scorer, min_len: int) -> list[_Seg]:
    """Merge segments shorter than ``min_len`` samples into the better-fitting neighbour."""
    while len(segs) > 1:
        lengths = [s.b - s.a for s in segs]
        i = int(np.argmin(lengths))
        if lengths[i] >= min_len:
            break
        options = []
        for j in (i - 1, i):
            if j >= 0 and j + 1 < len(segs):
                pair = (segs[j].fit.kind, segs[j + 1].fit.kind)
                fit, bic = sc.best(segs[j].a, segs[j + 1].b, CommandType.OTHER in pair)
                extra = bic - segs[j].bic - segs[j + 1].bic
                options.append((extra, j, fit, bic))
        _, j, fit, bic = min(options, key=lambda o: o[0])
        segs[j] = _Seg(segs[j].a, segs[j + 1].b, segs[j].jump_left, fit, bic)
        del segs[j + 1]
    return segs


# ---------------------------------------------------------------------------- public


def segment_command(
    t_s: np.ndarray,
    kappa_cmd: np.ndarray,
    *,
    min_len_s: float = 5.0,
    settings: SegmentationSettings | None = None,
) -> list[Segment]:
    """Segment a curvature command by template type (see the module docstring).

    Args:
        t_s: sample times (s), strictly increasing (gaps allowed).
        kappa_cmd: curvature command (1/m) at those times; NaN samples are bridged.
        min_len_s: shortest segment (s) reported.
        settings: tuning; None for the defaults.

    Returns:
        Segments covering all samples in order; ``start_index``/``end_index`` index ``t_s``
        (end exclusive), ``start_s``/``end_s`` are times of the first sample of the segment
        and of the next one (or the last sample), relative to ``t_s[0]``.

    Raises:
        SignalValueError: mismatched shapes or times not strictly increasing.
    """
    cfg = settings or SegmentationSettings()
    t, y = _clean_inputs(t_s, kappa_cmd)
    n = t.size
    if n == 0:
        return []
    if n < 8 or not np.any(np.isfinite(y)):
        kind = CommandType.OTHER if not np.any(np.isfinite(y)) else CommandType.CONSTANT
        return [Segment(0.0, float(t[-1] - t[0]), kind, 0, n, {})]
    td, yd, picked = _decimate(t, y, cfg.max_rate_hz)
    dt = float(td[1] - td[0]) if td.size > 1 else 1.0
    scale = _scale(yd)
    quantum = _quantum(yd, scale)
    floor = max(cfg.sigma_floor_frac * scale, quantum / np.sqrt(12), 1e-12)
    sigma = _noise_sigma(yd, floor)
    step = max(1, round(1.0 / (cfg.merge_rate_hz * dt)))
    sc = _Scorer(td, yd, step, sigma)
    jumps = _jumps(yd, sigma, scale, quantum, cfg)
    edges = [0, *jumps.tolist(), td.size]
    min_piece = max(2, round(cfg.min_piece_s / dt))
    segs: list[_Seg] = []
    for k in range(len(edges) - 1):
        pieces = _binseg(td, yd, edges[k], edges[k + 1], sc, min_piece)
        pieces[0].jump_left = k > 0
        segs += pieces
    segs = _merge(segs, sc)
    win = max(2, round(cfg.refine_window_s / dt))
    segs = _dissolve_short(segs, sc, round(cfg.dissolve_max_s / dt), win)
    _refine(segs, sc, win)
    segs = _merge(segs, sc)  # refined boundaries can make neighbours one template again
    _refine(segs, sc, win)
    segs = _absorb_short(segs, sc, max(1, round(min_len_s / dt)))
    _final_fits(segs, t, y, picked, sc)  # labels at the full rate decide the step rule
    segs = _step_rule(segs, sc)
    return _to_segments(segs, t, y, picked, sc)


def _full_index(seg: _Seg, y: np.ndarray, picked: np.ndarray) -> int:
    """Index into the full-rate samples where ``seg`` starts (``picked``: decimated -> full)."""
    if seg.a == 0:
        return 0
    if seg.jump_left:  # the exact sample of the jump, between the decimated neighbours
        lo, hi = int(picked[seg.a - 1]), int(picked[seg.a])
        d = np.abs(np.diff(y[lo : hi + 1]))
        return lo + 1 + int(np.argmax(d)) if d.size else hi
    return int(picked[seg.a])


def _final_fits(
    segs: list[_Seg], t: np.ndarray, y: np.ndarray, picked: np.ndarray, sc: _Scorer
) -> list[tuple[int, int, TemplateFit]]:
    """Full-rate [start, end) indices and the best template of each segment."""
    starts = [_full_index(s, y, picked) for s in segs] + [t.size]
    out = []
    for k, s in enumerate(segs):
        i0, i1 = starts[k], starts[k + 1]
        if i1 <= i0:
            continue
        st = max(1, (i1 - i0) // 4000)
        weight = st * (s.b - s.a) / max(i1 - i0, 1) / sc.step
        fit, _ = sc.best_xy(t[i0:i1:st] - t[i0], y[i0:i1:st], weight)
        s.fit = fit
        out.append((i0, i1, fit))
    return out


def _to_segments(
    segs: list[_Seg], t: np.ndarray, y: np.ndarray, picked: np.ndarray, sc: _Scorer
) -> list[Segment]:
    out: list[Segment] = []
    for i0, i1, fit in _final_fits(segs, t, y, picked, sc):
        t_loc = t[i0:i1] - t[i0]
        rms = float(np.sqrt(np.mean((y[i0:i1] - fit(t_loc)) ** 2)))
        end = t[i1] if i1 < t.size else t[-1]
        params = {**fit.params, "rms": rms}
        out.append(Segment(float(t[i0] - t[0]), float(end - t[0]), fit.kind, i0, i1, params))
    return out
