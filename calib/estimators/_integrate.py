"""Vectorised RK4 of the joint-angle kinematics for many parameter sets at once.

The log is summarised per bin by the mean sample time, the mean and the least-squares slope of
each input; inputs are linear within a bin (exact for the bin's mean and first moment, which
is what drives psi, also across jumps), and psi is simulated from one bin's mean sample time to
the next, split at the bin edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["StepPlan", "plan_steps", "simulate_psi"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class StepPlan:
    """RK4 steps between the bins' mean sample times.

    ``h`` (s) and the inputs ``u`` (yaw rate, rad/s) and ``v`` (speed, m/s) at the start,
    middle and end of each step, shape (k,) and (k, 3); ``per_node`` steps per node interval.
    """

    h: FloatArray
    u: FloatArray
    v: FloatArray
    per_node: int


def _line(mean: np.ndarray, slope: np.ndarray, tbar: np.ndarray, t: np.ndarray) -> np.ndarray:
    return mean + slope * (t - tbar)


def plan_steps(
    tbar: np.ndarray,
    edges: np.ndarray,
    u_mean: np.ndarray,
    u_slope: np.ndarray,
    v_mean: np.ndarray,
    v_slope: np.ndarray,
    n_sub: int = 1,
) -> StepPlan:
    """Steps from tbar[i] to tbar[i+1]: ``n_sub`` in bin i (up to edges[i+1]), ``n_sub`` in
    bin i+1. ``edges`` has length n + 1 (bin boundaries, s)."""
    n = tbar.size
    i = np.arange(n - 1)
    fr = np.arange(n_sub + 1) / n_sub
    # part A in bin i: tbar[i] -> edges[i+1]; part B in bin i+1: edges[i+1] -> tbar[i+1]
    ta = tbar[i, None] + (edges[i + 1] - tbar[i])[:, None] * fr  # (n-1, n_sub+1)
    tb = edges[i + 1, None] + (tbar[i + 1] - edges[i + 1])[:, None] * fr

    def seg(t: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t0, t1 = t[:, :-1], t[:, 1:]
        tm = 0.5 * (t0 + t1)
        pts = np.stack([t0, tm, t1], axis=-1)  # (n-1, n_sub, 3)
        jj = j[:, None, None]
        uu = _line(u_mean[jj], u_slope[jj], tbar[jj], pts)
        vv = _line(v_mean[jj], v_slope[jj], tbar[jj], pts)
        return t1 - t0, uu, vv

    ha, ua, va = seg(ta, i)
    hb, ub, vb = seg(tb, i + 1)
    h = np.concatenate([ha, hb], axis=1).reshape(-1)
    u = np.concatenate([ua, ub], axis=1).reshape(-1, 3)
    v = np.concatenate([va, vb], axis=1).reshape(-1, 3)
    return StepPlan(h, u, v, 2 * n_sub)


_SCALAR_MAX = 8  # up to this many parameter sets, scalar loops beat numpy on tiny arrays


def _simulate_one(plan: StepPlan, L1: float, L2: float, psi0: float) -> FloatArray:
    """``simulate_psi`` for one parameter set with Python floats."""
    r, il2 = L1 / L2, 1.0 / L2
    per = plan.per_node // 2
    out = [psi0]
    p = psi0
    cos, sin = math.cos, math.sin
    hs, U, V = plan.h.tolist(), plan.u.tolist(), plan.v.tolist()
    for s in range(len(hs)):
        h = hs[s]
        u0, uh, u1 = U[s]
        v0, vh, v1 = V[s]
        k1 = u0 + u0 * r * cos(p) - v0 * il2 * sin(p)
        q = p + 0.5 * h * k1
        k2 = uh + uh * r * cos(q) - vh * il2 * sin(q)
        q = p + 0.5 * h * k2
        k3 = uh + uh * r * cos(q) - vh * il2 * sin(q)
        q = p + h * k3
        k4 = u1 + u1 * r * cos(q) - v1 * il2 * sin(q)
        p = p + h / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)
        if (s + 1) % per == 0:
            out.append(p)
    return np.asarray(out)


def simulate_psi(
    plan: StepPlan, L1: np.ndarray, L2: np.ndarray, psi0: np.ndarray
) -> FloatArray:
    """Joint angle (rad) at the nodes and bin edges of ``plan`` for m parameter sets.

    d psi/dt = u (1 + (L1/L2) cos psi) - v sin(psi) / L2 by classical RK4.

    Args:
        plan: steps and inputs from ``plan_steps``.
        L1, L2, psi0: parameter sets, shape (m,) (m, m, rad); psi0 at the first node.

    Returns:
        psi at tbar[0], edges[1], tbar[1], edges[2], ..., tbar[n-1], shape (2 n - 1, m).
    """
    L1 = np.atleast_1d(np.asarray(L1, dtype=float))
    L2 = np.atleast_1d(np.asarray(L2, dtype=float))
    psi0 = np.broadcast_to(np.asarray(psi0, dtype=float), L1.shape)
    if L1.size <= _SCALAR_MAX:
        cols = [_simulate_one(plan, *map(float, x)) for x in zip(L1, L2, psi0, strict=True)]
        return np.column_stack(cols)
    r = L1 / L2
    il2 = 1.0 / L2
    k = plan.h.size
    per = plan.per_node // 2
    out = np.empty((k // per + 1, L1.size))
    p = np.array(psi0, dtype=float, copy=True) * np.ones_like(L1)
    out[0] = p
    cos, sin = np.cos, np.sin
    hs, U, V = plan.h.tolist(), plan.u.tolist(), plan.v.tolist()
    for s in range(k):
        h = hs[s]
        u0, uh, u1 = U[s]
        v0, vh, v1 = V[s]
        k1 = u0 + (u0 * r) * cos(p) - (v0 * il2) * sin(p)
        q = p + (0.5 * h) * k1
        k2 = uh + (uh * r) * cos(q) - (vh * il2) * sin(q)
        q = p + (0.5 * h) * k2
        k3 = uh + (uh * r) * cos(q) - (vh * il2) * sin(q)
        q = p + h * k3
        k4 = u1 + (u1 * r) * cos(q) - (v1 * il2) * sin(q)
        p = p + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        if (s + 1) % per == 0:
            out[(s + 1) // per] = p
    return out
