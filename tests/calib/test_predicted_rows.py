"""The compiled factor of the CLS predicted-angle rows against explicit rows and the numpy path."""

from __future__ import annotations

import numpy as np
import pytest

from calib.lsq import triangular_factor
from calib.tractor_trailer.patent_models import em_columns
from calib.tractor_trailer.predicted_rows import compiled_available, predicted_rows_factor


def _explicit_gram(k: np.ndarray, a: float, b: float, w: np.ndarray | None) -> np.ndarray:
    D = em_columns(k, a * k + b)
    if w is not None:
        D = D * w[:, None]
    return D.T @ D


def _assert_gram(R: np.ndarray, gram: np.ndarray) -> None:
    assert R.shape == (3, 3)
    np.testing.assert_array_equal(np.tril(R, -1), 0.0)
    err = np.abs(R.T @ R - gram).max() / np.abs(gram).max()
    assert err < 1e-12, err


def test_the_compiled_loop_is_built() -> None:
    assert compiled_available(), (
        "calib/tractor_trailer/_predicted_rows.c was not built: run pip install -e ."
    )


@pytest.mark.parametrize("p", [1, 2, 7, 256, 257, 5000])
@pytest.mark.parametrize(("a", "b"), [(3.73, 0.01), (-40.0, -2.5), (900.0, 1.0)])
@pytest.mark.parametrize("weighted", [False, True])
def test_factor_is_a_factor_of_the_explicit_rows(
    p: int, a: float, b: float, weighted: bool
) -> None:
    """Angles over many quadrants (|a κ + b| up to ~2700 rad), ragged last blocks, weights."""
    rng = np.random.default_rng(p)
    k = rng.uniform(-3.0, 3.0, p)
    w = np.sqrt(rng.integers(1, 5, p).astype(float)) if weighted else None
    gram = _explicit_gram(k, a, b, w)
    for reference in (False, True):
        _assert_gram(predicted_rows_factor(k, a, b, w, reference=reference), gram)


def test_zero_columns_inside_a_block() -> None:
    """κ = 0 over a whole block (columns 2 and 3 vanish there), and rows that are all zero."""
    k = np.concatenate([np.zeros(256), np.linspace(-0.2, 0.2, 300)])
    for b in (0.3, 0.0):
        gram = _explicit_gram(k, 3.7, b, None)
        _assert_gram(predicted_rows_factor(k, 3.7, b), gram)
        R = predicted_rows_factor(k[:256], 3.7, b)  # the zero block alone
        np.testing.assert_allclose(R.T @ R, _explicit_gram(k[:256], 3.7, b, None), atol=1e-12)


def test_compiled_sin_cos_match_numpy_to_rounding() -> None:
    """One row per angle (weights 1, κ = 1, a = angle): R of a single row is the row itself up
    to sign (and the reflection's rounding), so its entries are sin and cos of the angle: within
    8e-16, under 4 units in the last place of 1 (measured at most 5.6e-16 up to 1e5 rad)."""
    angles = np.concatenate([
        np.linspace(-20.0, 20.0, 4001),
        np.pi / 4 * np.arange(-40, 41),  # quadrant edges
        np.linspace(-1e5, 1e5, 2001),
        [1e-300, -1e-300],
    ])  # fmt: skip
    for x in angles:
        R = predicted_rows_factor(np.array([1.0]), float(x), 0.0)
        row = R[0] * np.sign(R[0, 2])  # the κ column is +1
        assert abs(row[0] - np.sin(x)) < 8e-16, x
        assert abs(row[1] - np.cos(x)) < 8e-16, x


def test_angles_beyond_the_compiled_range_use_numpy() -> None:
    k = np.linspace(-1.0, 1.0, 3000)
    R = predicted_rows_factor(k, 2e5, 0.0)
    np.testing.assert_array_equal(R, predicted_rows_factor(k, 2e5, 0.0, reference=True))
    _assert_gram(R, _explicit_gram(k, 2e5, 0.0, None))


def test_reference_path_equals_one_qr_of_the_rows() -> None:
    k = np.random.default_rng(1).normal(0.0, 0.1, 70_000)  # two stretches of rows
    R = predicted_rows_factor(k, 3.7, 0.02, reference=True)
    gram = _explicit_gram(k, 3.7, 0.02, None)
    _assert_gram(R, gram)
    direct = triangular_factor(em_columns(k, 3.7 * k + 0.02))
    np.testing.assert_allclose(np.abs(np.diag(R)), np.abs(np.diag(direct)), rtol=1e-12)
