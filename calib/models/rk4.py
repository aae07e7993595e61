"""Classical fixed-step RK4, written once for every integrator of the hitch dynamics.

Every joint-angle integrator of the project (the simulator, the time-domain transient fit, the
path-driven fit, discovery's model) advances d y/dx = f(y, u(x)) where the inputs ``u`` are
known at the start, the middle and the end of each step (a half-step grid, or lines fitted per
bin). This module holds the one RK4 loop they share; each caller supplies its right-hand side
``f(y, *u)`` and the inputs per step.

Why hand-written rather than ``scipy.integrate.solve_ivp``: the inputs are sampled data, given
exactly where RK4 evaluates them (no interpolating callback), some callers reset the state at
given steps (anchors), and the loop is ~70x faster than ``solve_ivp`` at the same step (see
``bench/rk4_kernel.py``), which matters inside optimisers that integrate thousands of times.

Two forms share the loop:

- ``rk4_trajectory``: one trajectory in Python floats (``f`` written with ``math``); the fastest
  form for a single parameter set, where numpy's per-call overhead would dominate.
- ``rk4_batched``: the state is an array (many parameter sets and/or many independent
  trajectories side by side, ``f`` written with numpy), one numpy call per stage serving all.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = ["Rhs", "rk4_batched", "rk4_trajectory"]

FloatArray = NDArray[np.float64]
Y = TypeVar("Y", float, FloatArray)

#: Right-hand side ``f(y, *u) -> dy/dx``: the state and the inputs at one RK4 stage.
Rhs = Callable[..., Any]


def _march(
    f: Rhs,
    y0: Y,
    h: Sequence[float],
    start: Sequence[tuple[Any, ...]],
    mid: Sequence[tuple[Any, ...]],
    end: Sequence[tuple[Any, ...]],
    keep: Iterable[int] | None,
    resets: Mapping[int, Y] | None,
) -> list[Y]:
    """The RK4 loop: ``y`` after the steps named in ``keep`` (all when None), ``y0`` first."""
    y = y0
    out = [y0]
    marks = iter(keep) if keep is not None else None
    nxt = next(marks, -1) if marks is not None else -1
    reset = resets or {}
    for s in range(len(h)):
        hs = h[s]
        um = mid[s]
        k1 = f(y, *start[s])
        k2 = f(y + 0.5 * hs * k1, *um)
        k3 = f(y + 0.5 * hs * k2, *um)
        k4 = f(y + hs * k3, *end[s])
        y = y + hs * (k1 + 2.0 * (k2 + k3) + k4) / 6.0
        done = s + 1
        if marks is None:
            if reset and done in reset:
                y = reset[done]
            out.append(y)
        elif done == nxt:
            if reset and done in reset:
                y = reset[done]
            out.append(y)
            nxt = next(marks, -1)
    return out


def rk4_trajectory(
    f: Rhs,
    y0: float,
    h: Sequence[float],
    start: Sequence[tuple[Any, ...]],
    mid: Sequence[tuple[Any, ...]],
    end: Sequence[tuple[Any, ...]],
    *,
    keep: Iterable[int] | None = None,
    resets: Mapping[int, float] | None = None,
) -> FloatArray:
    """Integrate one scalar trajectory y' = f(y, *u) with classical RK4.

    Args:
        f: right-hand side on Python floats, ``f(y, *u)``.
        y0: state before the first step.
        h: step lengths (any unit of the independent variable), one per step.
        start, mid, end: the inputs ``u`` (a tuple per step) at the start, middle and end of
            each step; k1 uses ``start``, k2 and k3 ``mid``, k4 ``end``.
        keep: increasing step counts (1 = after the first step) at which to record the state;
            None records after every step.
        resets: step count -> state: after that step the state is set to this value (and
            recorded as such). Only counts that are recorded are looked at.

    Returns:
        ``y0`` followed by the recorded states, shape (1 + number recorded,).
    """
    return np.asarray(_march(f, float(y0), h, start, mid, end, keep, resets), dtype=float)


def rk4_batched(
    f: Rhs,
    y0: FloatArray,
    h: Sequence[float],
    start: Sequence[tuple[Any, ...]],
    mid: Sequence[tuple[Any, ...]],
    end: Sequence[tuple[Any, ...]],
    *,
    keep: Iterable[int] | None = None,
) -> FloatArray:
    """RK4 as ``rk4_trajectory`` for an array state: many trajectories side by side.

    ``f`` works on arrays (numpy) and the inputs may be scalars shared by all trajectories or
    arrays broadcasting against ``y0``; the step lengths are shared.

    Returns:
        ``y0`` and the recorded states stacked, shape (1 + number recorded, *y0.shape).
    """
    y = np.array(y0, dtype=float, copy=True)
    return np.stack(_march(f, y, h, start, mid, end, keep, None))
