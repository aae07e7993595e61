"""Factor of the predicted-angle rows of a CLS data set, in compiled code with a numpy reference.

Every CLS method (patent Table 3) fits an exact model on data whose κm half has the angles
Ψp = a κm + b predicted by a PM fit: rows w [sin Ψp, κm cos Ψp, κm] (w the square root of the
row's multiplicity in a bootstrap resample, else 1). The line (a, b) is new for each PM fit of
each resample, so these rows cannot be reduced once ahead; they are the cost of the bootstrap
method tables of ``logcal analyze`` (10 resamples x 6 PM fits x every sample of the log and of
each command type). In numpy the sin and cos dominate (numpy's float64 sin and cos call the
scalar libm on x86), then building the rows and their QR.

The compiled loop (``_predicted_rows.c``, built by ``pip install`` as an extension module and
called through ctypes) builds the rows a block of 256 at a time, with a branch-free sin/cos
the compiler vectorises (Cody-Waite reduction and Taylor polynomials, accurate to a few units in
the last place), and reduces each block by a Householder QR while it is in cache (one build per
instruction set, chosen at load time); ``bench/bench_methods.py`` measures it against the numpy
rows in the same run. We write it ourselves because no library we may depend on offers
a vectorised float64 sin/cos (glibc's vector functions are only called from code compiled with
-ffast-math), and fusing the rows with their QR avoids writing them to memory; numba would do
it but costs ~115 MB of RSS and a JIT compile per process (see
``calib.tractor_trailer.models.hitch_rk4``).

The numpy reference (``reference=True``) computes the same factor with ``em_columns`` and the
blocked QR of ``calib.lsq.base``; it is the fallback when the compiled library is missing, for
angles beyond 1e5 rad (outside the compiled sin/cos's range), and the reference the tests hold
the compiled loop to. Both give R with Rᵀ R equal to the rows' Gram matrix up to rounding.
"""

from __future__ import annotations

import ctypes
from functools import cache

import numpy as np
from numpy.typing import NDArray

from calib._compiled import DOUBLES, load_library
from calib.lsq import triangular_factor, triangular_factor_by_rows
from calib.tractor_trailer.patent_models import em_columns

__all__ = ["compiled_available", "predicted_rows_factor"]

FloatArray = NDArray[np.float64]
_DBL = DOUBLES
_BLOCK = 256  # rows per block factor of the compiled loop (BLOCK in the C file)
_MAX_ANGLE = 1e5  # rad; the compiled sin/cos's range (|quadrant| < 2^20, with a margin)


@cache
def _library() -> ctypes.CDLL | None:
    """The compiled loop, or None when the extension was not built."""
    lib = load_library("calib.tractor_trailer._predicted_rows")
    if lib is None:
        return None
    lib.logcal_predicted_rows_factors.restype = ctypes.c_int
    lib.logcal_predicted_rows_factors.argtypes = [
        ctypes.c_int64, _DBL, _DBL, ctypes.c_double, ctypes.c_double, _DBL,
    ]  # fmt: skip
    return lib


def compiled_available() -> bool:
    """Whether the compiled loop was built (``pip install`` builds it)."""
    return _library() is not None


def predicted_rows_factor(
    kappa: FloatArray,
    a: float,
    b: float,
    weights: FloatArray | None = None,
    *,
    kappa_max: float | None = None,
    reference: bool = False,
) -> FloatArray:
    """3 x 3 R with Rᵀ R = Dᵀ D for the rows D = w [sin(a κ + b), κ cos(a κ + b), κ].

    Args:
        kappa: curvatures κ (1/m), shape (p,), finite, p >= 1.
        a: slope (m) and b: intercept (rad) of the predicted angle, finite.
        weights: row weights w, shape (p,) (default 1).
        kappa_max: max |κ| if the caller knows it (saves a pass over κ).
        reference: use the numpy reference even when the compiled loop is built.

    Returns:
        The upper-triangular factor (row signs arbitrary).
    """
    k = np.ascontiguousarray(kappa, dtype=np.float64)
    lib = None if reference else _library()
    kmax = float(np.max(np.abs(k))) if kappa_max is None else kappa_max
    if lib is None or abs(a) * kmax + abs(b) > _MAX_ANGLE:
        return _reference(k, a, b, weights)
    w = np.ones_like(k) if weights is None else np.ascontiguousarray(weights, dtype=np.float64)
    blocks = np.empty((-(-k.size // _BLOCK), 3, 3))
    lib.logcal_predicted_rows_factors(k.size, k, w, float(a), float(b), blocks)
    return triangular_factor(blocks.reshape(-1, 3))


def _reference(k: FloatArray, a: float, b: float, weights: FloatArray | None) -> FloatArray:
    def rows(start: int, stop: int, out: FloatArray) -> None:
        kk = k[start:stop]
        em_columns(kk, a * kk + b, out=out)
        if weights is not None:
            out *= weights[start:stop, None]

    return triangular_factor_by_rows(k.size, 3, rows)
