"""Base class of the linear least-squares family: one ``fit``, variants differ in ``_solve``.

Every variant works on a small factor ``M`` of the augmented data matrix C = [A y]
(p samples x (n + 1) columns) with Mᵀ M = Cᵀ C, e.g. the R of a thin QR, C = Q R. Because Q has
orthonormal columns, ``||C x|| = ||M x||`` for every x: least-squares solutions, singular values
and right singular vectors of C (and of any subset of its columns) are those of M. The p-long
data are touched once (one QR, backward stable, unlike the Gram matrix Cᵀ C whose rounding
squares the condition number); everything else is (n + 1) x (n + 1) work. Callers that evaluate
many models on the same columns (the tractor-trailer methods) factor once and call
``fit_factor`` with column selections of the factor.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from calib.errors import InsufficientDataError, SolverError

__all__ = [
    "LeastSquares",
    "Solution",
    "block_factors",
    "triangular_factor",
    "triangular_factor_by_rows",
]

FloatArray = NDArray[np.float64]


_BLOCK_ROWS = 1024


def triangular_factor(C: ArrayLike) -> FloatArray:
    """R of the thin QR of ``C`` (p x m): square, with Rᵀ R = Cᵀ C.

    Tall matrices are reduced as a tall-skinny QR (TSQR): blocks of 1024 rows are factored
    in one batched call and their stacked R factors factored again. Same backward stability
    as one Householder QR, about twice as fast on long logs (cache-sized blocks). The blocks
    are kept small enough that OpenBLAS does each one on the calling thread: with 4096-row
    blocks it hands them to its thread pool, whose hand-off and spin-waiting cost five times
    the work in CPU (and in wall time on a busy 2-core machine).

    Args:
        C: data matrix, one row per sample.

    Returns:
        The m x m upper-triangular factor (row signs are arbitrary; with p < m rows the last
        m - p rows are zero).
    """
    C = np.asarray(C, dtype=np.float64)
    p, m = C.shape
    if p < 2 * _BLOCK_ROWS:
        return _square(_r_factor(C)[:m], m)
    n_blocks = -(-p // _BLOCK_ROWS)
    padded = np.zeros((n_blocks * _BLOCK_ROWS, m))
    padded[:p] = C
    blocks = _r_factor(padded.reshape(n_blocks, _BLOCK_ROWS, m))
    return triangular_factor(blocks[:, :m, :].reshape(-1, m))


def _square(R: FloatArray, m: int) -> FloatArray:
    """``R`` (k x m, k <= m) with zero rows appended to m x m (the same Rᵀ R)."""
    if R.shape[0] == m:
        return R
    return np.vstack([R, np.zeros((m - R.shape[0], m))])


_CHUNK_ROWS = 65536


def triangular_factor_by_rows(
    p: int, m: int, fill: Callable[[int, int, FloatArray], None]
) -> FloatArray:
    """R (m x m) of a p x m matrix that is built a stretch of rows at a time.

    ``fill(start, stop, out)`` writes rows [start, stop) into ``out`` ((stop - start) x m).
    Each stretch of 65536 rows is written into a zero-padded buffer of whole 1024-row blocks,
    factored block by block in one batched call (as :func:`triangular_factor`, without its
    copy into a padded array), and all block factors are reduced again, so the whole matrix
    never exists: memory stays at one stretch (about 3.7 MB for 7 columns) whatever the log's
    length, and the stretch stays in cache.
    """
    if p < 1:
        raise ValueError(f"triangular_factor_by_rows: no rows (p = {p})")
    if p < 2 * _BLOCK_ROWS:
        out = np.empty((p, m))
        fill(0, p, out)
        return triangular_factor(out)
    buf = np.empty((min(_CHUNK_ROWS, -(-p // _BLOCK_ROWS) * _BLOCK_ROWS), m))
    factors = []
    for start in range(0, p, _CHUNK_ROWS):
        stop = min(start + _CHUNK_ROWS, p)
        rows = stop - start
        used = -(-rows // _BLOCK_ROWS) * _BLOCK_ROWS
        fill(start, stop, buf[:rows])
        buf[rows:used] = 0.0
        blocks = _r_factor(buf[:used].reshape(-1, _BLOCK_ROWS, m))
        factors.append(blocks[:, :m, :].reshape(-1, m))
    return triangular_factor(np.vstack(factors))


def block_factors(
    p: int, m: int, block_rows: int, fill: Callable[[int, int, FloatArray], None]
) -> FloatArray:
    """R (m x m) of each consecutive block of ``block_rows`` rows of a p x m matrix.

    The matrix is built a stretch at a time by ``fill`` as in
    :func:`triangular_factor_by_rows`; the last block is padded with zero rows (which do not
    change its Rᵀ R). Callers keep these factors to assemble the factor of any weighted
    selection of whole blocks without touching the rows again.

    Returns:
        (ceil(p / block_rows), m, m) upper-triangular factors.

    Raises:
        ValueError: p < 1 or block_rows < m.
    """
    if p < 1 or block_rows < m:
        raise ValueError(f"block_factors: need p >= 1 and block_rows >= m; got {p}, {block_rows}")
    n_blocks = -(-p // block_rows)
    per_stretch = max(1, _CHUNK_ROWS // block_rows)
    out = np.empty((n_blocks, m, m))
    buf = np.empty((min(per_stretch, n_blocks) * block_rows, m))
    for first in range(0, n_blocks, per_stretch):
        last = min(first + per_stretch, n_blocks)
        start, stop = first * block_rows, min(last * block_rows, p)
        used = (last - first) * block_rows
        fill(start, stop, buf[: stop - start])
        buf[stop - start : used] = 0.0
        out[first:last] = _r_factor(buf[:used].reshape(-1, block_rows, m))[:, :m, :]
    return out


def _r_factor(a: FloatArray) -> FloatArray:
    """R of ``a`` or of each matrix of a stack (numpy's stubs type ``mode="r"`` as a QRResult,
    but it returns the R array)."""
    r: Any = np.linalg.qr(a, mode="r")
    return np.asarray(r, dtype=np.float64)


@dataclass(frozen=True)
class Solution:
    """What a ``_solve`` hook returns.

    Attributes:
        beta: parameter vector, length n.
        condition_number: the variant's condition number (NaN if none).
        singular_values: singular values the condition number is built from, descending.
        extra: variant-specific numbers.
    """

    beta: FloatArray
    condition_number: float
    singular_values: FloatArray
    extra: dict[str, Any] = field(default_factory=dict)


class LeastSquares:
    """Fit y ≈ A β. Subclasses implement ``_solve(M)`` on a factor M of [A y] (Mᵀ M = Cᵀ C).

    After ``fit``: ``beta_`` (n,), ``condition_number_``, ``singular_values_``, ``n_samples_``,
    ``extra_`` (variant-specific numbers).
    """

    name: str = "LS"

    def fit(self, A: ArrayLike, y: ArrayLike) -> Self:
        """Fit on data.

        Args:
            A: regressors, shape (p, n) or (p,) for one column (units of the model).
            y: observations, shape (p,).

        Returns:
            self, with the learned state set.

        Raises:
            InsufficientDataError: fewer samples than unknowns + 1, or non-finite values.
        """
        A = np.asarray(A, dtype=float)
        y = np.asarray(y, dtype=float)
        if A.ndim == 1:
            A = A[:, None]
        if A.ndim != 2 or y.ndim != 1 or A.shape[0] != y.shape[0]:
            raise InsufficientDataError(
                f"{self.name}: A must be (p, n) and y (p,) with the same p; got A {A.shape}, "
                f"y {y.shape}"
            )
        p, n = A.shape
        if p < n + 1:
            raise InsufficientDataError(
                f"{self.name}: {p} samples for {n} unknowns; need at least {n + 1}"
            )
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(y))):
            raise InsufficientDataError(f"{self.name}: A and y must be finite (NaN/inf found)")
        return self.fit_factor(triangular_factor(np.column_stack([A, y])), p)

    def fit_factor(self, M: ArrayLike, n_samples: int) -> Self:
        """Fit from a factor M of C = [A y] (Mᵀ M = Cᵀ C; the last column is y).

        Args:
            M: m x (n + 1) factor, m >= n + 1 (e.g. R of a QR, or columns of one).
            n_samples: p, the number of rows of C (kept for reporting).

        Returns:
            self.

        Raises:
            InsufficientDataError: A has a zero column or is rank deficient.
        """
        M = np.asarray(M, dtype=float)
        if M.ndim != 2 or M.shape[0] < M.shape[1] or M.shape[1] < 2:
            raise InsufficientDataError(
                f"{self.name}: factor must be 2-D with rows >= columns >= 2; got {M.shape}"
            )
        col_norms = np.linalg.norm(M[:, :-1], axis=0)
        if np.any(col_norms == 0.0):
            raise InsufficientDataError(
                f"{self.name}: regressor column(s) {np.flatnonzero(col_norms == 0).tolist()} "
                "are all zero: the data do not excite these unknowns"
            )
        sol = self._solve(M)
        self.beta_ = sol.beta
        self.condition_number_ = float(sol.condition_number)
        self.singular_values_ = sol.singular_values
        self.extra_ = dict(sol.extra)
        self.n_samples_ = int(n_samples)
        return self

    def predict(self, A: ArrayLike) -> FloatArray:
        """Model output A β for new regressors ``A`` (p, n) or (p,)."""
        A = np.asarray(A, dtype=float)
        if A.ndim == 1:
            A = A[:, None]
        return A @ self.beta_

    def _solve(self, M: FloatArray) -> Solution:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"


def ols_on_factor(M: FloatArray, name: str) -> tuple[FloatArray, FloatArray]:
    """Output-error solution and singular values of A from a factor M of [A y].

    Raises:
        SolverError: A is numerically rank deficient.
    """
    Ma, my = M[:, :-1], M[:, -1]
    sv = np.linalg.svd(Ma, compute_uv=False)
    if sv[-1] <= sv[0] * np.finfo(float).eps * max(M.shape) * 16:
        raise SolverError(
            f"{name}: the regressor matrix is rank deficient (singular values {sv.tolist()})"
        )
    beta, *_ = np.linalg.lstsq(Ma, my, rcond=None)
    return np.asarray(beta, dtype=np.float64), np.asarray(sv, dtype=np.float64)
