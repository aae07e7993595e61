"""Held-out folds that respect correlation: a log's samples cut into consecutive blocks, every
other block held out, so a neighbour of a held-out sample (correlated with it through slow
noise or drift) is seldom in the fit. Every robot's discovery judges an effect on held-out
samples; one split, one meaning."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["alternate_blocks"]


def alternate_blocks(n: int, block: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Indices of samples ``0..n-1`` in the even-numbered and in the odd-numbered blocks of
    ``block`` consecutive samples (the two folds: fit on one, judge on the other, and back).

    Raises:
        ValueError: ``n`` < 0 or ``block`` < 1.
    """
    if n < 0 or block < 1:
        raise ValueError(f"alternate_blocks: n = {n}, block = {block}; need n >= 0, block >= 1")
    parity = (np.arange(n) // block) % 2
    return np.flatnonzero(parity == 0), np.flatnonzero(parity == 1)
