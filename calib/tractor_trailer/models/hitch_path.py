"""The hitch (joint) angle driven by the tractor's path, integrated in distance and heading.

Along the path of link 1 the joint angle obeys (METHODS.md, section 1, written per increment
of arc length ``s`` and heading ``theta`` of link 1 instead of per second):

    d psi = d theta (1 + (L1 / L2) cos psi) - sin(psi) ds / L2

Time does not appear: a log sampled at 5 Hz or 200 Hz, with jitter or per-topic rates, gives
the same increments as long as the cumulative arc length and heading are known at the
joint-angle sample times (they are interpolated there from whatever the path was measured
with). Standing still (ds = d theta = 0) leaves psi unchanged; reversing is ds < 0.

Between two nodes the increments are taken at a constant rate (cumulative s and theta linear in
between), and psi is advanced by classical RK4 with ``n_sub`` equal
substeps, for many independent columns at once (chunks of the log times parameter sets) by the
compiled loop of ``calib.tractor_trailer.models.hitch_rk4``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from calib.errors import SolverError
from calib.tractor_trailer.models.hitch_rk4 import rk4_hitch, rk4_hitch_sensitivities

__all__ = [
    "MAX_SUBSTEPS",
    "advance_psi",
    "advance_psi_jacobian",
    "rk4_substeps",
    "substep_inputs",
]

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
    worst = (
        float(np.max(np.abs(dtheta), initial=0.0)) * (1.0 + r)
        + float(np.max(np.abs(ds), initial=0.0)) * il2
    )
    if not math.isfinite(worst) or worst / max_step > MAX_SUBSTEPS:
        raise SolverError(
            f"the path moves up to {worst:.3g} rad-equivalent between two samples, which needs "
            f"more than {MAX_SUBSTEPS} integration substeps per sample: check the heading and "
            "distance signals' units and outliers"
        )
    return max(1, math.ceil(worst / max_step))


def _substep_inputs(
    dtheta: np.ndarray, ds: np.ndarray, L1: np.ndarray, L2: np.ndarray, n_sub: int | None
) -> tuple[int, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Substeps per node step, the kernel's inputs per substep (d theta and ds per substep,
    constant over a node step, shape (c, k n_sub, 3)) and its parameters (1, L1/L2, 1/L2).
    RK4 runs in units of one substep (h = 1), so that the kernel adds exactly the increments."""
    A = np.asarray(dtheta, dtype=float)
    B = np.asarray(ds, dtype=float)
    L1 = np.atleast_1d(np.asarray(L1, dtype=float))
    L2 = np.atleast_1d(np.asarray(L2, dtype=float))
    if n_sub is None:
        n_sub = rk4_substeps(A, B, L1, L2)
    h = 1.0 / n_sub

    def per_substep(x: np.ndarray) -> FloatArray:
        return np.repeat(np.repeat((x * h).T, n_sub, axis=1)[:, :, None], 3, axis=2)

    return n_sub, per_substep(A), per_substep(B), np.ones_like(L1), L1 / L2, 1.0 / L2


def substep_inputs(
    dtheta: np.ndarray, ds: np.ndarray, n_sub: int
) -> tuple[int, FloatArray, FloatArray]:
    """(n_sub, U, V): the kernel's per-substep inputs of ``advance_psi_jacobian`` for these
    increments and ``n_sub`` substeps (its ``inputs``)."""
    _, U, V, _, _, _ = _substep_inputs(dtheta, ds, np.ones(1), np.ones(1), n_sub)
    return n_sub, U, V


def advance_psi(
    dtheta: np.ndarray,
    ds: np.ndarray,
    L1: np.ndarray,
    L2: np.ndarray,
    psi0: np.ndarray,
    n_sub: int | None = None,
    *,
    chain: np.ndarray | None = None,
) -> FloatArray:
    """Integrate psi over node steps for many columns.

    Args:
        dtheta: heading increments of link 1 per step (rad), shape (k, c): k steps, c chunks.
        ds: signed arc-length increments of link 1's reference point per step (m), (k, c).
        L1, L2: link lengths (m), shape (m,) (parameter sets); L1 may be negative or zero.
        psi0: joint angle at the first node (rad), shape (c, m).
        n_sub: RK4 substeps per step; None chooses them with ``rk4_substeps``.
        chain: None, or per chunk the index of the chunk it continues (an earlier one) or -1:
            a chunk that continues another starts from that chunk's last node (its ``psi0``
            row is ignored). Steps padded after a chunk's end must be zero.

    Returns:
        psi at the k + 1 nodes, shape (k + 1, c, m) (rad).
    """
    n_sub, U, V, p0, p1, p2 = _substep_inputs(dtheta, ds, L1, L2, n_sub)
    steps = U.shape[1]
    return rk4_hitch(
        np.ones(steps), U, V, p0, p1, p2, np.asarray(psi0, dtype=float),
        keep=range(n_sub, steps + 1, n_sub), chain=chain,
    )  # fmt: skip


def advance_psi_jacobian(
    dtheta: np.ndarray,
    ds: np.ndarray,
    L1: float,
    L2: float,
    psi0: np.ndarray,
    n_sub: int | None = None,
    *,
    chain: np.ndarray | None = None,
    inputs: tuple[int, FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``advance_psi`` for one parameter set with its exact derivatives.

    The forward sensitivities are integrated by the same RK4 steps alongside psi
    (``rk4_hitch_sensitivities``), so they are the derivatives of the discrete map that
    ``advance_psi`` computes, at the cost of about one trajectory (finite differences need one
    per parameter).

    Args:
        dtheta, ds, n_sub, chain: as ``advance_psi``.
        L1, L2: link lengths (m).
        inputs: (n_sub, U, V) of :func:`substep_inputs` for these ``dtheta``, ``ds``: used
            when ``n_sub`` is theirs (a fit integrating the same path many times builds the
            kernel's per-substep inputs once instead of every time).
        psi0: joint angle at the first node of each chunk (rad), shape (c,).

    Returns:
        psi, d psi / d psi0 (of the chunk's chain's first chunk), d psi / d L1, d psi / d L2,
        each shape (k + 1, c).
    """
    if inputs is not None and n_sub is not None and inputs[0] == n_sub:
        U, V = inputs[1], inputs[2]
        p0, p1, p2 = np.ones(1), np.array([L1 / L2]), np.array([1.0 / L2])
    else:
        n_sub, U, V, p0, p1, p2 = _substep_inputs(dtheta, ds, np.array([L1]), np.array([L2]), n_sub)
    steps = U.shape[1]
    out = rk4_hitch_sensitivities(
        np.ones(steps), U, V, p0, p1, p2, np.asarray(psi0, dtype=float)[:, None],
        keep=range(n_sub, steps + 1, n_sub), chain=chain,
    )[:, :, 0, :]  # fmt: skip
    # p1 = L1 / L2, p2 = 1 / L2
    d_l1 = out[..., 3] / L2
    d_l2 = -(out[..., 3] * L1 + out[..., 4]) / (L2 * L2)
    return out[..., 0], out[..., 1], d_l1, d_l2
