"""RK4 of the joint-angle dynamics in compiled code, with a numpy reference of the same steps.

Every joint-angle integrator of the project (the time-domain transient fit, the path-driven
fit, discovery's model, the simulator) advances

    dy/dx = p0 U + p1 U cos y - p2 V sin y

with inputs ``U`` and ``V`` known at the start, middle and end of each step and parameters
``p0, p1, p2`` (for instance U = yaw rate, V = speed, p0 = 1, p1 = L1/L2, p2 = 1/L2). Inside
optimisers that integrate a whole log hundreds of times this loop is the cost of ``analyze``:
RK4 in Python floats costs microseconds per step, a noticeable fraction of a second per
simulation of a 1-hour 100 Hz log (``bench/rk4_kernel.py`` measures it). The loop is
sequential (each step needs the last), so numpy cannot vectorise it along time; it is
written in C (``_hitch_rk4.c``, built by ``pip install`` as an extension module and called
through ctypes). We write it ourselves because no library
integrates a scalar ODE on sampled inputs given exactly where RK4 evaluates them, with resets
and chained chunks, at this speed; numba would do it too but costs about a hundred MB of RSS and
a JIT compile per process, more than the whole memory budget leaves.

Several parameter sets on the same inputs (a start-point grid of 100-200 sets, the four columns
of a finite-difference Jacobian) are stepped together, the loop over the sets vectorised with a
branch-free sin/cos (``calib/tractor_trailer/_sincos.h``, a few units in the last place from
libm's); ``bench/rk4_kernel.py`` measures the batched sets against one set on libm, numpy,
Python and ``solve_ivp`` in the same run. A series whose angle leaves that
sin/cos's accurate range (|y| > 1e5 rad) or turns NaN is redone with libm. One parameter set
runs on libm's sin and cos, bit for bit the numpy reference's arithmetic.

The numpy reference (``reference=True``) runs the same arithmetic with numpy across columns; it
is the fallback when the compiled library is missing (a source checkout never installed) and
the reference the tests hold the compiled loop to.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterable, Mapping
from functools import cache

import numpy as np
from numpy.typing import NDArray

from calib._compiled import DOUBLES, INT64S, load_library

__all__ = [
    "compiled_available",
    "lag_recursion",
    "rk4_hitch",
    "rk4_hitch_half",
    "rk4_hitch_sensitivities",
]

FloatArray = NDArray[np.float64]
_DBL = DOUBLES
_I64 = INT64S


@cache
def _library() -> ctypes.CDLL | None:
    """The compiled loops, or None when the extension was not built."""
    lib = load_library("calib.tractor_trailer.models._hitch_rk4")
    if lib is None:
        return None
    i64 = ctypes.c_int64
    lib.logcal_rk4_hitch.restype = ctypes.c_int
    lib.logcal_rk4_hitch.argtypes = [
        i64, i64, i64, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL,
        i64, _I64, i64, _I64, _DBL, _DBL, ctypes.POINTER(ctypes.c_int64),
    ]  # fmt: skip
    lib.logcal_rk4_hitch_sens.restype = ctypes.c_int
    lib.logcal_rk4_hitch_sens.argtypes = [
        i64, i64, i64, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL,
        i64, _I64, _DBL, ctypes.POINTER(ctypes.c_int64),
    ]  # fmt: skip
    lib.logcal_lag_recursion.restype = ctypes.c_int
    lib.logcal_lag_recursion.argtypes = [i64, _DBL, _DBL, _DBL]
    dbl = ctypes.c_double
    if hasattr(lib, "logcal_rk4_hitch_half"):  # absent from a build older than this file
        lib.logcal_rk4_hitch_half.restype = ctypes.c_int
        lib.logcal_rk4_hitch_half.argtypes = [
            i64, _DBL, _DBL, _DBL, dbl, dbl, dbl, dbl, dbl, dbl, i64, _I64, _DBL, _DBL,
        ]  # fmt: skip
    return lib


def compiled_available() -> bool:
    """Whether the compiled loops were built (``pip install`` builds them)."""
    return _library() is not None


def _prepare(
    h: FloatArray | Iterable[float],
    U: FloatArray,
    V: FloatArray,
    p0: FloatArray | float,
    p1: FloatArray | float,
    p2: FloatArray | float,
    y0: FloatArray | float,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    hh = np.ascontiguousarray(np.asarray(h, dtype=float).reshape(-1))
    n = hh.size
    uu = np.asarray(U, dtype=float)
    vv = np.asarray(V, dtype=float)
    if uu.ndim == 2:
        uu = uu[None]
    if vv.ndim == 2:
        vv = vv[None]
    series = max(uu.shape[0], vv.shape[0])
    uu = np.ascontiguousarray(np.broadcast_to(uu, (series, n, 3)))
    vv = np.ascontiguousarray(np.broadcast_to(vv, (series, n, 3)))
    a, b, c = (np.atleast_1d(np.asarray(p, dtype=float)) for p in (p0, p1, p2))
    m = max(a.size, b.size, c.size)
    a, b, c = (np.ascontiguousarray(np.broadcast_to(p, (m,))) for p in (a, b, c))
    y = np.ascontiguousarray(np.broadcast_to(np.asarray(y0, dtype=float), (series, m)))
    return hh, uu, vv, a, b, c, y


def _chain_array(chain: FloatArray, series: int) -> NDArray[np.int64]:
    ch = np.ascontiguousarray(np.asarray(chain, dtype=np.int64).reshape(-1))
    if ch.size != series or bool(np.any(ch >= np.arange(series))):
        raise ValueError("chain: one index per series, each -1 or an earlier series")
    return ch


def _keep_array(keep: Iterable[int] | None) -> NDArray[np.int64] | None:
    return None if keep is None else np.ascontiguousarray(np.fromiter(keep, dtype=np.int64))


def rk4_hitch(
    h: FloatArray | Iterable[float],
    U: FloatArray,
    V: FloatArray,
    p0: FloatArray | float,
    p1: FloatArray | float,
    p2: FloatArray | float,
    y0: FloatArray | float,
    *,
    keep: Iterable[int] | None = None,
    resets: Mapping[int, float] | None = None,
    chain: FloatArray | None = None,
    reference: bool = False,
) -> FloatArray:
    """RK4 of dy/dx = p0 U + p1 U cos y - p2 V sin y for many series and parameter sets.

    Args:
        h: step lengths, shape (n,) (any unit of x).
        U, V: stage inputs (start, middle, end of each step), shape (n, 3) shared by every
            series, or (s, n, 3) for s series.
        p0, p1, p2: parameters, scalars or shape (m,) (m parameter sets).
        y0: start state, broadcast to (s, m).
        keep: increasing step counts (1 = after the first step) at which to record the state;
            None records after every step.
        resets: step count -> state: after that (recorded) step every column is set to the
            value.
        chain: None, or per series the index of an earlier series (or -1): series i then
            starts from the last recorded state of series ``chain[i]`` (``y0`` ignored), so
            that the consecutive chunks of one run are integrated as one trajectory.
        reference: run the numpy reference even when the compiled loop is built.

    Returns:
        ``y0`` and the recorded states, shape (1 + recorded, s, m).
    """
    lib = None if reference else _library()
    if lib is None:
        return _run_reference(h, U, V, p0, p1, p2, y0, keep=keep, resets=resets, chain=chain)
    hh, uu, vv, a, b, c, y = _prepare(h, U, V, p0, p1, p2, y0)
    n, series, m = hh.size, uu.shape[0], a.size
    ks = _keep_array(keep)
    n_out = 1 + (n if ks is None else ks.size)
    out = np.empty((n_out, series, m))
    r_at = np.ascontiguousarray(np.fromiter(sorted(resets or {}), dtype=np.int64))
    r_val = np.ascontiguousarray([float((resets or {})[k]) for k in r_at.tolist()], dtype=float)
    ch = None if chain is None else _chain_array(chain, series)
    status = lib.logcal_rk4_hitch(
        n, series, m, hh, uu, vv, a, b, c, y,
        -1 if ks is None else ks.size, np.zeros(1, np.int64) if ks is None else ks,
        r_at.size, r_at if r_at.size else np.zeros(1, np.int64),
        r_val if r_val.size else np.zeros(1),
        out, None if ch is None else ch.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)),
    )  # fmt: skip
    if status != 0:
        raise MemoryError(f"rk4_hitch: no memory for {m} parameter sets")
    return out


def _run_reference(
    h: FloatArray | Iterable[float],
    U: FloatArray,
    V: FloatArray,
    p0: FloatArray | float,
    p1: FloatArray | float,
    p2: FloatArray | float,
    y0: FloatArray | float,
    *,
    keep: Iterable[int] | None = None,
    resets: Mapping[int, float] | None = None,
    chain: FloatArray | None = None,
) -> FloatArray:
    """``rk4_hitch`` in numpy (columns side by side, a Python loop over steps): the same
    arithmetic in the same order, used when the compiled loop is missing and as its
    reference in the tests."""
    hh, uu, vv, a, b, c, y = _prepare(h, U, V, p0, p1, p2, y0)
    if chain is not None:  # series one after another, each from its predecessor's end
        ch = _chain_array(chain, uu.shape[0]).tolist()
        outs: list[FloatArray] = []
        for i, prev in enumerate(ch):
            start = y[i] if prev < 0 else outs[prev][-1, 0]
            outs.append(_run_reference(hh, uu[i], vv[i], a, b, c, start, keep=keep, resets=resets))
        return np.concatenate(outs, axis=1)
    y = y.copy()
    ks = _keep_array(keep)
    keep_set = None if ks is None else set(ks.tolist())
    reset = dict(resets or {})
    out = [y.copy()]
    cos, sin = np.cos, np.sin

    def f(q: FloatArray, t: int, st: int) -> FloatArray:
        u, v = uu[:, t, st, None], vv[:, t, st, None]
        return a * u + b * u * cos(q) - c * v * sin(q)

    for t in range(hh.size):
        hs = float(hh[t])
        k1 = f(y, t, 0)
        y2 = y + 0.5 * hs * k1
        k2 = f(y2, t, 1)
        y3 = y + 0.5 * hs * k2
        k3 = f(y3, t, 1)
        y4 = y + hs * k3
        k4 = f(y4, t, 2)
        y = y + hs * (k1 + 2.0 * (k2 + k3) + k4) / 6.0
        done = t + 1
        if keep_set is None or done in keep_set:
            if done in reset:
                y = np.full_like(y, float(reset[done]))
            out.append(y.copy())
    return np.stack(out)


def rk4_hitch_sensitivities(
    h: FloatArray | Iterable[float],
    U: FloatArray,
    V: FloatArray,
    p0: FloatArray | float,
    p1: FloatArray | float,
    p2: FloatArray | float,
    y0: FloatArray | float,
    *,
    keep: Iterable[int] | None = None,
    chain: FloatArray | None = None,
    reference: bool = False,
) -> FloatArray:
    """``rk4_hitch`` (without resets) and the forward sensitivities of y to y0, p0, p1, p2,
    integrated by the same RK4 steps alongside y: the exact derivatives of the discrete map,
    one trajectory instead of one per perturbed parameter. A chained series carries its
    predecessor's sensitivities on (dy/dy0 then refers to the chain's first series' y0).

    Returns:
        shape (1 + recorded, s, m, 5): y, dy/dy0, dy/dp0, dy/dp1, dy/dp2.
    """
    hh, uu, vv, a, b, c, y = _prepare(h, U, V, p0, p1, p2, y0)
    n, series, m = hh.size, uu.shape[0], a.size
    ks = _keep_array(keep)
    ch = None if chain is None else _chain_array(chain, series)
    lib = None if reference else _library()
    if lib is None:
        return _sensitivities_reference(hh, uu, vv, a, b, c, y, ks, ch)
    out = np.empty((1 + (n if ks is None else ks.size), series, m, 5))
    lib.logcal_rk4_hitch_sens(
        n, series, m, hh, uu, vv, a, b, c, y,
        -1 if ks is None else ks.size, np.zeros(1, np.int64) if ks is None else ks, out,
        None if ch is None else ch.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)),
    )  # fmt: skip
    return out


def _sensitivities_reference(
    hh: FloatArray,
    uu: FloatArray,
    vv: FloatArray,
    a: FloatArray,
    b: FloatArray,
    c: FloatArray,
    y0: FloatArray,
    ks: NDArray[np.int64] | None,
    ch: NDArray[np.int64] | None,
) -> FloatArray:
    """``rk4_hitch_sensitivities`` in numpy, series one after another."""
    keep_set = None if ks is None else set(ks.tolist())
    cos, sin = np.cos, np.sin
    per_series: list[FloatArray] = []
    for i in range(uu.shape[0]):
        x = np.zeros((a.size, 5))
        x[:, 0], x[:, 1] = y0[i], 1.0
        if ch is not None and ch[i] >= 0:
            x = per_series[int(ch[i])][-1].copy()
        rows = [x.copy()]
        for t in range(hh.size):
            hs = float(hh[t])
            k: list[FloatArray] = []
            for r, (st, w) in enumerate(((0, 0.0), (1, 0.5), (1, 0.5), (2, 1.0))):
                z = x if r == 0 else x + w * hs * k[-1]
                u, v = uu[i, t, st], vv[i, t, st]
                co, si = cos(z[:, 0]), sin(z[:, 0])
                fy = -(b * u * si + c * v * co)
                kr = np.empty_like(x)
                kr[:, 0] = a * u + b * u * co - c * v * si
                kr[:, 1] = fy * z[:, 1]
                kr[:, 2] = fy * z[:, 2] + u
                kr[:, 3] = fy * z[:, 3] + u * co
                kr[:, 4] = fy * z[:, 4] + -v * si
                k.append(kr)
            x = x + hs * (k[0] + 2.0 * (k[1] + k[2]) + k[3]) / 6.0
            if keep_set is None or t + 1 in keep_set:
                rows.append(x.copy())
        per_series.append(np.stack(rows))
    return np.stack(per_series, axis=1)


def rk4_hitch_half(
    th: FloatArray,
    kappa_h: FloatArray,
    v_h: FloatArray,
    p0: float,
    p1: float,
    p2: float,
    inv_len: float,
    max_len: float,
    y0: float,
    resets: Mapping[int, float] | None = None,
) -> FloatArray | None:
    """``rk4_hitch`` with U = v kappa, V = v on a half-step grid (samples at even, midpoints
    at odd indices of ``th``, ``kappa_h``, ``v_h``): the state at every sample, shape (n,).

    A sample step whose travel h max|v| ``inv_len`` exceeds ``max_len`` is split into
    ceil(travel / ``max_len``) sub-steps, the inputs linear on each half of the step;
    ``resets`` (sample index >= 1 -> state) sets the state at those samples, the step that
    ends there left out. This is discovery's joint-angle model
    (``calib.tractor_trailer.discovery.model``
    builds the same steps in numpy for ``rk4_hitch``; here no stage arrays are built, the
    cost of a prediction on its coarse grid otherwise). None when the compiled loops were
    not built.
    """
    lib = _library()
    if lib is None or not hasattr(lib, "logcal_rk4_hitch_half"):
        return None
    n = (th.size + 1) // 2
    r_at = np.ascontiguousarray([i for i in sorted(resets or {}) if 1 <= i < n], dtype=np.int64)
    r_val = np.ascontiguousarray([float((resets or {})[i]) for i in r_at.tolist()], dtype=float)
    out = np.empty(n)
    lib.logcal_rk4_hitch_half(
        n, np.ascontiguousarray(th, dtype=float), np.ascontiguousarray(kappa_h, dtype=float),
        np.ascontiguousarray(v_h, dtype=float), p0, p1, p2, inv_len, max_len, float(y0),
        r_at.size, r_at if r_at.size else np.zeros(1, np.int64),
        r_val if r_val.size else np.zeros(1), out,
    )  # fmt: skip
    return out


def lag_recursion(a: FloatArray, u: FloatArray, y0: float) -> FloatArray:
    """y[0] = y0, y[k+1] = a[k] y[k] + u[k]: the first-order lag's exact update on any grid.

    Compiled when available (the recursion is sequential); otherwise a Python loop."""
    aa = np.ascontiguousarray(a, dtype=float)
    uu = np.ascontiguousarray(u, dtype=float)
    y = np.empty(aa.size + 1)
    y[0] = y0
    lib = _library()
    if lib is not None:
        lib.logcal_lag_recursion(y.size, aa, uu, y)
        return y
    al, ul = aa.tolist(), uu.tolist()
    cur = float(y0)
    out = [cur]
    for k in range(len(al)):
        cur = al[k] * cur + ul[k]
        out.append(cur)
    return np.asarray(out)
