"""RK4 of the joint-angle kinematics on binned inputs, for one or many parameter sets at once.

The log is summarised per bin by the mean sample time, the mean and the least-squares slope of
each input; inputs are linear within a bin (exact for the bin's mean and first moment, which
is what drives psi, also across jumps), and psi is simulated from one bin's mean sample time to
the next, split at the bin edge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.tractor_trailer.models.hitch_rk4 import rk4_hitch

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


def simulate_psi(plan: StepPlan, L1: np.ndarray, L2: np.ndarray, psi0: np.ndarray) -> FloatArray:
    """Joint angle (rad) at the nodes and bin edges of ``plan`` for m parameter sets.

    d psi/dt = u (1 + (L1/L2) cos psi) - v sin(psi) / L2 by classical RK4
    (``calib.tractor_trailer.models.hitch_rk4``).

    Args:
        plan: steps and inputs from ``plan_steps``.
        L1, L2, psi0: parameter sets, shape (m,) (m, m, rad); psi0 at the first node.

    Returns:
        psi at tbar[0], edges[1], tbar[1], edges[2], ..., tbar[n-1], shape (2 n - 1, m).
    """
    L1 = np.atleast_1d(np.asarray(L1, dtype=float))
    L2 = np.atleast_1d(np.asarray(L2, dtype=float))
    psi0 = np.broadcast_to(np.asarray(psi0, dtype=float), L1.shape)
    per = plan.per_node // 2
    k = plan.h.size
    out = rk4_hitch(
        plan.h, plan.u, plan.v, 1.0, L1 / L2, 1.0 / L2, psi0, keep=range(per, k + 1, per)
    )
    return np.asarray(out)[:, 0, :]
