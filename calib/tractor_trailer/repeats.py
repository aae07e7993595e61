"""Repeat statistics: each method as mean ± σ over repeats, as the patent reports it.

Simulated data: one data set per repeat with fresh noise (``methods_over_repeats``). A recorded
log has one realisation of the noise, so ``methods_table`` draws repeats from it with a
moving-block bootstrap (Künsch 1989): blocks of consecutive (κ, Ψ) samples, drawn with
replacement, keep the serial correlation of the errors; the block length is chosen from the
autocorrelation of the prediction-line residual (Politis & White 2004, with Patton, Politis &
White's 2009 correction for the moving-block bootstrap).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calib.stats import autocorrelation
from calib.tractor_trailer.methods import (
    METHOD_NAMES,
    ResampledData,
    evaluate_methods,
    family_of,
)
from calib.tractor_trailer.patent_models import check_excitation
from calib.tractor_trailer.results import MethodResult

__all__ = [
    "block_length",
    "bootstrap_counts",
    "bootstrap_datasets",
    "line_residual",
    "methods_over_repeats",
    "methods_table",
]


def _mean_std(values: list[float]) -> tuple[float, float]:
    """Mean and sample standard deviation (ddof 1; 0 for one value) of the finite values."""
    x = np.asarray(values, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return math.nan, math.nan
    return float(x.mean()), float(x.std(ddof=1)) if x.size > 1 else 0.0


def methods_over_repeats(
    datasets: Iterable[tuple[ArrayLike, ArrayLike]],
    *,
    segment: str = "all",
    names: Iterable[str] | None = None,
) -> list[MethodResult]:
    """Evaluate methods on each (κ 1/m, Ψ rad) data set; mean ± σ over the data sets.

    Every number of a method (L1, L2, condition number, and each ``extra`` entry such as ``a``,
    ``b``, ``mu1``) is averaged over the repeats where it is finite; ``_std`` is the sample
    standard deviation (0 for one repeat). ``extra["n_failed"]`` counts repeats where the
    method's solve failed, if any.

    Raises:
        InsufficientDataError: a data set is degenerate (see ``evaluate_methods``).
        ValueError: no data sets, or an unknown method name.
    """
    order = list(METHOD_NAMES if names is None else names)
    runs = [evaluate_methods(k, p, order) for k, p in datasets]
    if not runs:
        raise ValueError("methods_over_repeats: no data sets given")
    return [_aggregate(name, [r[name] for r in runs], segment) for name in order]


def _aggregate(name: str, ests: list[Any], segment: str) -> MethodResult:
    L1, L1s = _mean_std([e.L1 for e in ests])
    L2, L2s = _mean_std([e.L2 for e in ests])
    cn, cns = _mean_std([e.condition_number for e in ests])
    keys = sorted({k for e in ests for k in e.extra})
    extra: dict[str, float] = {}
    for key in keys:
        m, s = _mean_std([e.extra.get(key, math.nan) for e in ests])
        extra[key], extra[f"{key}_std"] = m, s
    failed = sum(1 for e in ests if e.failed)
    if failed:
        extra["n_failed"] = float(failed)
    return MethodResult(
        name=name,
        family=family_of(name),
        segment=segment,
        L1=L1,
        L2=L2,
        L1_std=L1s,
        L2_std=L2s,
        condition_number=cn,
        condition_number_std=cns,
        n_repeats=len(ests),
        extra=extra,
    )


def block_length(x: ArrayLike) -> int:
    """Moving-block bootstrap block length (samples) from the autocorrelation of ``x``.

    Politis & White (2004) automatic choice with the flat-top lag window: m̂ is the first lag
    after which K_N = max(5, √log10 n) consecutive autocorrelations are insignificant
    (|ρ| < 2 √(log10 n / n)); with M = 2 m̂, G = Σ_{|k|≤M} λ(k/M) |k| R(k) and
    g = Σ_{|k|≤M} λ(k/M) R(k), b = (2 G² / ((4/3) g²))^{1/3} n^{1/3} (moving-block form, Patton
    et al. 2009). White noise gives 1; the result is clipped to [1, n // 2].

    Args:
        x: a series, e.g. the residual of Ψ about the prediction line.
    """
    x = np.asarray(x, dtype=float).ravel()
    n = x.size
    if n < 4 or not np.all(np.isfinite(x)) or np.ptp(x) == 0:
        return 1
    max_lag = min(n - 1, max(10, int(4 * math.sqrt(n)) + 10), 2000)
    rho = autocorrelation(x, max_lag)
    kn = max(5, math.ceil(math.sqrt(math.log10(n))))
    crit = 2.0 * math.sqrt(math.log10(n) / n)
    insignificant = np.abs(rho[1:]) < crit  # lag 1..max_lag
    m_hat = max_lag // 2
    for m in range(0, max_lag - kn + 1):
        if np.all(insignificant[m : m + kn]):
            m_hat = m
            break
    big_m = min(2 * max(m_hat, 1), max_lag)
    k = np.arange(-big_m, big_m + 1)
    t = np.abs(k) / big_m
    lam = np.where(t <= 0.5, 1.0, 2.0 * (1.0 - t))
    r = rho[np.abs(k)]  # correlations suffice: the variance cancels in the ratio
    g = float(np.sum(lam * r))
    big_g = float(np.sum(lam * np.abs(k) * r))
    if g <= 0.0:
        return 1
    b = (2.0 * big_g**2 / ((4.0 / 3.0) * g**2)) ** (1.0 / 3.0) * n ** (1.0 / 3.0)
    return int(min(max(1, math.ceil(b)), n // 2))


def line_residual(kappa: ArrayLike, psi: ArrayLike) -> np.ndarray:
    """Residual of Ψ (rad) about its output-error line fit Ψ ≈ a κ + b."""
    k = np.asarray(kappa, dtype=float)
    p = np.asarray(psi, dtype=float)
    A = np.column_stack([k, np.ones_like(k)])
    beta, *_ = np.linalg.lstsq(A, p, rcond=None)
    return p - A @ beta


def _block_starts(
    size: int, n: int, rng: np.random.Generator, block_len: int
) -> Iterator[np.ndarray]:
    """The start of each block of ``n`` moving-block draws (the draws' only random numbers)."""
    n_blocks = -(-size // block_len)
    for _ in range(n):
        yield rng.integers(0, size - block_len + 1, size=n_blocks)


def _checked_block_length(k: np.ndarray, p: np.ndarray, block_len: int | None) -> int:
    b = block_length(line_residual(k, p)) if block_len is None else int(block_len)
    return min(max(1, b), k.size)


def bootstrap_datasets(
    kappa: ArrayLike,
    psi: ArrayLike,
    *,
    n: int,
    rng: np.random.Generator,
    block_len: int | None = None,
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Yield ``n`` moving-block bootstrap resamples of the paired series (κ 1/m, Ψ rad).

    Each resample has the original length: blocks of ``block_len`` consecutive samples start at
    uniformly drawn positions and are concatenated, then cut to length. ``block_len`` None:
    ``block_length(line_residual(kappa, psi))``.

    Raises:
        InsufficientDataError: degenerate data (see ``check_excitation``).
    """
    k, p = check_excitation(kappa, psi)
    b = _checked_block_length(k, p, block_len)
    offsets = np.arange(b)
    for starts in _block_starts(k.size, n, rng, b):
        idx = (starts[:, None] + offsets[None, :]).ravel()[: k.size]
        yield k[idx], p[idx]


def bootstrap_counts(
    kappa: ArrayLike,
    psi: ArrayLike,
    *,
    n: int,
    rng: np.random.Generator,
    block_len: int | None = None,
) -> Iterator[np.ndarray]:
    """The draws of ``bootstrap_datasets`` (same arguments, same random numbers) as the number
    of times each sample appears in each resample (int array of the data's length).

    Built from the block starts alone (+1 at each start, −1 after each block's end, a
    cumulative sum), never from the resample's index list.
    """
    k, p = check_excitation(kappa, psi)
    size = k.size
    b = _checked_block_length(k, p, block_len)
    for starts in _block_starts(size, n, rng, b):
        ends = starts + b
        ends[-1] = starts[-1] + size - (starts.size - 1) * b  # the last block is cut to length
        steps = np.bincount(starts, minlength=size + 1) - np.bincount(ends, minlength=size + 1)
        yield np.cumsum(steps[:size])


def methods_table(
    kappa: ArrayLike,
    psi: ArrayLike,
    *,
    segment: str = "all",
    repeats: int = 10,
    rng: np.random.Generator | None = None,
    names: Iterable[str] | None = None,
) -> list[MethodResult]:
    """Methods on a recorded log as mean ± σ over ``repeats`` moving-block bootstrap draws.

    ``repeats`` = 1 evaluates the data as they are (σ = 0). The draws are those of
    ``bootstrap_datasets`` with the same ``rng``; each is evaluated from its row multiplicities
    (``ResampledData``), which gives ``methods_over_repeats`` of the drawn data sets up to
    rounding at a fraction of the cost.

    Args:
        kappa: curvature (1/m); psi: joint angle (rad), same length.
        segment: label stored in each ``MethodResult`` ("all" or a command type).
        repeats: number of bootstrap resamples (the patent uses 10).
        rng: random generator (default ``np.random.default_rng(0)``).
        names: methods (default all 36).

    Raises:
        InsufficientDataError: degenerate data. ValueError: repeats < 1 or unknown names.
    """
    if repeats < 1:
        raise ValueError(f"repeats must be >= 1, got {repeats}")
    k, p = check_excitation(kappa, psi)
    if repeats == 1:
        return methods_over_repeats([(k, p)], segment=segment, names=names)
    gen = rng if rng is not None else np.random.default_rng(0)
    order = list(METHOD_NAMES if names is None else names)
    data = ResampledData(k, p)
    runs = [data.evaluate(c, order) for c in bootstrap_counts(k, p, n=repeats, rng=gen)]
    return [_aggregate(name, [r[name] for r in runs], segment) for name in order]
