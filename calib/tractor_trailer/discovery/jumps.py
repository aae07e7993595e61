"""Where a sampled signal jumps: the one test the discovery's data (interpolation of commands)
and its effects (held interpolation, shifts) share, in a leaf module that imports neither."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["jump_intervals"]


def jump_intervals(y: NDArray[np.float64], factor: float = 5.0) -> NDArray[np.bool_]:
    """Flags per interval (length n - 1): True where y jumps, i.e. its change exceeds
    ``factor`` times the larger change of the two neighbouring intervals (and 1e-9)."""
    d = np.abs(np.diff(y))
    if d.size == 0:
        return np.zeros(0, dtype=bool)
    pad = np.concatenate([[0.0], d, [0.0]])
    neighbours = np.maximum(pad[:-2], pad[2:])
    return (d > factor * neighbours) & (d > 1e-9)
