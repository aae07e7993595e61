"""Loading the project's compiled loops: C extension modules called through ctypes.

``pip install`` builds each ``_*.c`` file pyproject.toml names as an extension module; a source
checkout never installed has none, and each caller then runs its numpy (or polars) route to the
same results. Why each loop is compiled is said where it is used.
"""

from __future__ import annotations

import ctypes
import importlib.util

import numpy as np

__all__ = ["DOUBLES", "INT64S", "UINT8S", "load_library"]

DOUBLES = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
"""ctypes argument type of a C-contiguous float64 array."""
INT64S = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
"""ctypes argument type of a C-contiguous int64 array."""
UINT8S = np.ctypeslib.ndpointer(dtype=np.uint8, flags="C_CONTIGUOUS")
"""ctypes argument type of a C-contiguous uint8 array."""


def load_library(module: str) -> ctypes.CDLL | None:
    """The built extension module ``module`` (dotted name) as a ctypes library; None when it
    was not built or does not load."""
    try:
        spec = importlib.util.find_spec(module)
    except ModuleNotFoundError:
        return None
    if spec is None or spec.origin is None:
        return None
    try:
        return ctypes.CDLL(spec.origin)
    except OSError:
        return None
