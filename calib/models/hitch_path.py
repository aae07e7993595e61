"""The hitch (joint) angle driven by the tractor's path, integrated in distance and heading.

Along the path of link 1 the joint angle obeys (METHODS.md, section 1, written per increment
of arc length ``s`` and heading ``theta`` of link 1 instead of per second):

    d psi = d theta (1 + (L1 / L2) cos psi) - sin(psi) ds / L2

Time does not appear: a log sampled at 5 Hz or 200 Hz, with jitter or per-topic rates, gives
the same increments as long as the cumulative arc length and heading are known at the
joint-angle sample times (they are interpolated there from whatever the path was measured
with). Standing still (ds = d theta = 0) leaves psi unchanged; reversing is ds < 0.

Between two nodes the increments are taken at a constant rate (cumulative s and theta linear in
between), and psi is advanced by classical RK4 (``calib.models.rk4``) with ``n_sub`` equal
substeps, for many independent columns at once: chunks of the log times parameter sets, so that
one numpy call per step serves them all (a Python loop over 10^5 nodes per column would be
~100x slower; ``solve_ivp`` is another ~70x slower again at the same accuracy).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from calib.errors import SolverError
from calib.models.rk4 import rk4_batched

__all__ = ["MAX_SUBSTEPS", "advance_psi", "advance_psi_gain", "rk4_substeps"]

MAX_SUBSTEPS = 1000
"""Substeps per node step beyond which a path is not a robot's: a heading or distance step
that large between two samples (e.g. a yaw in the wrong unit) would make the integration's
time and memory unbounded, so it is refused instead."""

FloatArray = NDArray[np.float64]


def rk4_substeps(
    dtheta: np.ndarray, ds: np.ndarray, L1: np.ndarray, L2: np.ndarray, max_step: float = 0.4
) -> int:
    """Substeps per node step that keep RK4 well inside its stability region.

    The linearised rate is |d theta| |L1/L2| + |ds| / L2 per step; ``max_step`` bounds it.

    Raises:
        SolverError: the path's increments need more than ``MAX_SUBSTEPS`` substeps (or are
            not finite): the path is not one a robot drove between two samples.
    """
    L2a = np.abs(np.asarray(L2, dtype=float))
    r = float(np.max(np.abs(np.asarray(L1, dtype=float)) / L2a))
    il2 = float(np.max(1.0 / L2a))
    worst = float(np.max(np.abs(dtheta), initial=0.0)) * (1.0 + r) + float(
        np.max(np.abs(ds), initial=0.0)
    ) * il2
    if not math.isfinite(worst) or worst / max_step > MAX_SUBSTEPS:
        raise SolverError(
            f"the path moves up to {worst:.3g} rad-equivalent between two samples, which needs "
            f"more than {MAX_SUBSTEPS} integration substeps per sample: check the heading and "
            "distance signals' units and outliers"
        )
    return max(1, math.ceil(worst / max_step))


def _substep_inputs(
    dtheta: np.ndarray, ds: np.ndarray, L1: np.ndarray, L2: np.ndarray, n_sub: int | None
) -> tuple[int, list[tuple[FloatArray, FloatArray, FloatArray]]]:
    """Substeps per node step and, per substep, the rate's inputs (d theta, d theta L1/L2,
    ds / L2 per substep; constant over a node step). RK4 runs in units of one substep (h = 1),
    so that the kernel adds exactly the increments."""
    A = np.asarray(dtheta, dtype=float)
    B = np.asarray(ds, dtype=float)
    L1 = np.atleast_1d(np.asarray(L1, dtype=float))
    L2 = np.atleast_1d(np.asarray(L2, dtype=float))
    if n_sub is None:
        n_sub = rk4_substeps(A, B, L1, L2)
    r = (L1 / L2)[None, :]
    il2 = (1.0 / L2)[None, :]
    h = 1.0 / n_sub
    per_step = []
    for i in range(A.shape[0]):
        a = (A[i] * h)[:, None]
        per_step.append((a, a * r, (B[i] * h)[:, None] * il2))
    return n_sub, [u for u in per_step for _ in range(n_sub)]


def advance_psi(
    dtheta: np.ndarray,
    ds: np.ndarray,
    L1: np.ndarray,
    L2: np.ndarray,
    psi0: np.ndarray,
    n_sub: int | None = None,
) -> FloatArray:
    """Integrate psi over node steps for many columns.

    Args:
        dtheta: heading increments of link 1 per step (rad), shape (k, c): k steps, c chunks.
        ds: signed arc-length increments of link 1's reference point per step (m), (k, c).
        L1, L2: link lengths (m), shape (m,) (parameter sets); L1 may be negative or zero.
        psi0: joint angle at the first node (rad), shape (c, m).
        n_sub: RK4 substeps per step; None chooses them with ``rk4_substeps``.

    Returns:
        psi at the k + 1 nodes, shape (k + 1, c, m) (rad).
    """
    n_sub, inputs = _substep_inputs(dtheta, ds, L1, L2, n_sub)
    steps = len(inputs)
    cos, sin = np.cos, np.sin

    def rate(p: FloatArray, a: FloatArray, ar: FloatArray, b: FloatArray) -> FloatArray:
        return a + ar * cos(p) - b * sin(p)

    return rk4_batched(
        rate, np.asarray(psi0, dtype=float), [1.0] * steps, inputs, inputs, inputs,
        keep=range(n_sub, steps + 1, n_sub),
    )


def advance_psi_gain(
    dtheta: np.ndarray,
    ds: np.ndarray,
    L1: np.ndarray,
    L2: np.ndarray,
    psi0: np.ndarray,
    n_sub: int | None = None,
) -> tuple[FloatArray, FloatArray]:
    """``advance_psi`` and, per column, the gain d psi(last node) / d psi0.

    The gain is the forward sensitivity, integrated by the same RK4 steps alongside psi (the
    variational equation d S = -(d theta (L1/L2) sin psi + ds cos(psi) / L2) S), so it is the
    exact derivative of the discrete map. Callers use it to make chunks integrated side by side
    continuous by Newton steps on their start values instead of sweeps that only propagate
    (which need one sweep per chunk where the motion is unstable, as when reversing).

    Returns:
        psi at the k + 1 nodes, shape (k + 1, c, m) (rad), and the gain after the last node,
        shape (c, m).
    """
    n_sub, inputs = _substep_inputs(dtheta, ds, L1, L2, n_sub)
    steps = len(inputs)
    cos, sin = np.cos, np.sin

    def rate(y: FloatArray, a: FloatArray, ar: FloatArray, b: FloatArray) -> FloatArray:
        c, s = cos(y[0]), sin(y[0])
        out = np.empty_like(y)  # cheaper than np.stack, called 4 times per step
        out[0] = a + ar * c - b * s
        out[1] = -(ar * s + b * c) * y[1]
        return out

    p0 = np.asarray(psi0, dtype=float)
    y0 = np.stack([p0, np.ones_like(p0)])
    out = rk4_batched(
        rate, y0, [1.0] * steps, inputs, inputs, inputs,
        keep=range(n_sub, steps + 1, n_sub),
    )
    return out[:, 0], out[-1, 1]
