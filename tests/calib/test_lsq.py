"""OLS1 / OLS2 / TLS against closed forms and an independent orthogonal-distance minimisation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import minimize

from calib.errors import InsufficientDataError
from calib.lsq import OLS1, OLS2, TLS, LeastSquares, triangular_factor, triangular_factor_by_rows
from calib.lsq.base import block_factors

SOLVERS = (OLS1, OLS2, TLS)


@pytest.fixture(scope="module")
def noisy_line() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    x = np.linspace(-2.0, 3.0, 200)
    y = 1.7 * x - 0.4
    return x + rng.normal(0, 0.2, x.size), y + rng.normal(0, 0.3, x.size)


def _line_design(x: np.ndarray) -> np.ndarray:
    return np.column_stack([x, np.ones_like(x)])


@pytest.mark.parametrize("solver", SOLVERS)
def test_exact_line_is_recovered_by_every_variant(solver: type[LeastSquares]) -> None:
    x = np.linspace(-1.0, 2.0, 50)
    fit = solver().fit(_line_design(x), 2.5 * x + 1.0)
    np.testing.assert_allclose(fit.beta_, [2.5, 1.0], rtol=1e-12, atol=1e-12)


def test_line_fits_match_the_textbook_closed_forms(noisy_line) -> None:
    x, y = noisy_line
    dx, dy = x - x.mean(), y - y.mean()
    sxx, syy, sxy = dx @ dx, dy @ dy, dx @ dy
    a_ols1 = sxy / sxx  # regress y on x
    a_ols2 = syy / sxy  # regress x on y, invert
    a_tls = (syy - sxx + np.hypot(syy - sxx, 2 * sxy)) / (2 * sxy)  # orthogonal (Deming, δ=1)
    # TLS with an intercept column treats the ones as data too, so compare it without one
    A = _line_design(x)
    for solver, a in ((OLS1, a_ols1), (OLS2, a_ols2)):
        beta = solver().fit(A, y).beta_
        np.testing.assert_allclose(beta, [a, y.mean() - a * x.mean()], rtol=1e-10)
    beta_tls = TLS().fit(dx, dy).beta_
    np.testing.assert_allclose(beta_tls, [a_tls], rtol=1e-10)


def test_tls_matches_independent_orthogonal_distance_minimisation() -> None:
    rng = np.random.default_rng(7)
    A_true = rng.normal(size=(40, 2))
    beta_true = np.array([0.8, -1.3])
    A = A_true + rng.normal(0, 0.05, A_true.shape)
    y = A_true @ beta_true + rng.normal(0, 0.05, 40)

    def orthogonal_sq_distance(b: np.ndarray) -> float:
        r = y - A @ b
        return float(r @ r / (1.0 + b @ b))

    ref = minimize(orthogonal_sq_distance, x0=np.zeros(2), method="BFGS", tol=1e-14).x
    np.testing.assert_allclose(TLS().fit(A, y).beta_, ref, rtol=1e-6)


def test_ols2_on_another_column_inverts_the_swapped_regression() -> None:
    rng = np.random.default_rng(1)
    A = rng.normal(size=(30, 3))
    y = A @ np.array([0.5, -2.0, 1.5])
    fit = OLS2(column=1).fit(A, y)
    np.testing.assert_allclose(fit.beta_, [0.5, -2.0, 1.5], rtol=1e-10)
    np.testing.assert_allclose(fit.extra_["beta_prime"], [-0.5, 0.25, 0.75], rtol=1e-10)


def test_ols_condition_number_is_the_singular_value_ratio() -> None:
    rng = np.random.default_rng(2)
    A = rng.normal(size=(25, 3)) * [1.0, 5.0, 0.2]
    y = rng.normal(size=25)
    assert OLS1().fit(A, y).condition_number_ == pytest.approx(np.linalg.cond(A), rel=1e-10)
    x = A[:, 0]
    assert OLS1().fit(x, y).condition_number_ == pytest.approx(np.linalg.norm(x), rel=1e-12)
    swapped = np.column_stack([y, A[:, 1:]])
    assert OLS2().fit(A, y).condition_number_ == pytest.approx(np.linalg.cond(swapped), rel=1e-10)


def test_tls_condition_number_bounds_first_order_sensitivity() -> None:
    """Jia–Li's number is the absolute normwise condition: ‖δβ‖ ≤ κ ‖[δA δy]‖_F to first order."""
    rng = np.random.default_rng(5)
    A = rng.normal(size=(30, 2))
    y = A @ np.array([1.0, 0.5]) + rng.normal(0, 0.3, 30)
    fit = TLS().fit(A, y)
    eps = 1e-7
    ratios = []
    for _ in range(300):
        E = rng.normal(size=(30, 3))
        E *= eps / np.linalg.norm(E)
        beta = TLS().fit(A + E[:, :2], y + E[:, 2]).beta_
        ratios.append(np.linalg.norm(beta - fit.beta_) / eps)
    assert max(ratios) <= fit.condition_number_ * 1.01
    assert max(ratios) >= 0.2 * fit.condition_number_  # the bound is not vacuous


@pytest.mark.parametrize("solver", SOLVERS)
def test_factor_path_equals_direct_fit(solver: type[LeastSquares]) -> None:
    rng = np.random.default_rng(9)
    A = rng.normal(size=(60, 2))
    y = A @ [1.0, 2.0] + rng.normal(0, 0.1, 60)
    direct = solver().fit(A, y)
    via_factor = solver().fit_factor(triangular_factor(np.column_stack([A, y])), 60)
    np.testing.assert_allclose(via_factor.beta_, direct.beta_, rtol=1e-12)
    assert via_factor.condition_number_ == pytest.approx(direct.condition_number_, rel=1e-12)


@pytest.mark.parametrize("solver", SOLVERS)
def test_fit_returns_self_and_leaves_inputs_alone(solver: type[LeastSquares]) -> None:
    A = np.column_stack([np.arange(5.0), np.ones(5)])
    y = np.array([0.1, 1.0, 2.1, 2.9, 4.0])
    A0, y0 = A.copy(), y.copy()
    est = solver()
    assert est.fit(A, y) is est
    np.testing.assert_array_equal(A, A0)
    np.testing.assert_array_equal(y, y0)
    assert est.n_samples_ == 5


@pytest.mark.parametrize("solver", SOLVERS)
def test_degenerate_inputs_raise(solver: type[LeastSquares]) -> None:
    with pytest.raises(InsufficientDataError, match="samples"):
        solver().fit(np.ones((2, 2)), np.ones(2))
    with pytest.raises(InsufficientDataError, match="all zero"):
        solver().fit(np.column_stack([np.zeros(5), np.arange(5.0)]), np.arange(5.0))
    with pytest.raises(InsufficientDataError, match="finite"):
        solver().fit(np.array([1.0, np.nan, 3.0]), np.array([1.0, 2.0, 3.0]))


def test_blocked_factor_of_a_long_matrix_is_a_valid_qr_factor() -> None:
    rng = np.random.default_rng(11)
    C = rng.normal(size=(20_001, 3)) * [1.0, 1e3, 1e-3]  # several 1024-row blocks, ragged end
    R = triangular_factor(C)
    assert R.shape == (3, 3)
    np.testing.assert_allclose(np.tril(R, -1), 0.0)
    gram = C.T @ C
    np.testing.assert_allclose(R.T @ R, gram, rtol=1e-12, atol=1e-12 * np.abs(gram).max())
    A, y = C[:, :2], C[:, 2]
    np.testing.assert_allclose(
        OLS1().fit(A, y).beta_, np.linalg.lstsq(A, y, rcond=None)[0], rtol=1e-10
    )


@pytest.mark.parametrize("p", [5, 70_000, 140_001])  # one stretch; two; three, ragged end
def test_factor_built_by_rows_is_a_factor_of_the_whole_matrix(p: int) -> None:
    rng = np.random.default_rng(12)
    C = rng.normal(size=(p, 4)) * [1.0, 1e3, 1e-3, 1.0]
    calls: list[tuple[int, int]] = []

    def fill(start: int, stop: int, out: np.ndarray) -> None:
        calls.append((start, stop))
        out[:] = C[start:stop]

    R = triangular_factor_by_rows(p, 4, fill)
    assert R.shape == (4, 4)
    np.testing.assert_allclose(np.tril(R, -1), 0.0)
    gram = C.T @ C
    np.testing.assert_allclose(R.T @ R, gram, rtol=1e-12, atol=1e-12 * np.abs(gram).max())
    assert calls[0][0] == 0  # every row once, in order
    assert calls[-1][1] == p
    assert all(a[1] == b[0] for a, b in itertools.pairwise(calls))
    with pytest.raises(ValueError, match="no rows"):
        triangular_factor_by_rows(0, 4, fill)


def test_factor_of_fewer_rows_than_columns_is_square() -> None:
    C = np.array([[1.0, 2.0, 3.0, 4.0], [0.5, -1.0, 2.0, 0.0]])
    R = triangular_factor(C)
    assert R.shape == (4, 4)
    np.testing.assert_allclose(R.T @ R, C.T @ C, atol=1e-14)
    np.testing.assert_array_equal(R[2:], 0.0)


@pytest.mark.parametrize("p", [1000, 70_000])  # one stretch, ragged last block; two stretches
def test_block_factors_are_the_factors_of_consecutive_blocks(p: int) -> None:
    rng = np.random.default_rng(13)
    C = rng.normal(size=(p, 4)) * [1.0, 1e3, 1e-3, 1.0]

    def fill(start: int, stop: int, out: np.ndarray) -> None:
        out[:] = C[start:stop]

    F = block_factors(p, 4, 256, fill)
    assert F.shape == (-(-p // 256), 4, 4)
    for i in (0, 1, F.shape[0] - 1):  # the last block holds p mod 256 rows
        block = C[256 * i : 256 * (i + 1)]
        gram = block.T @ block
        np.testing.assert_array_equal(np.tril(F[i], -1), 0.0)
        np.testing.assert_allclose(F[i].T @ F[i], gram, rtol=1e-12, atol=1e-12 * np.abs(gram).max())
    stacked = triangular_factor(F.reshape(-1, 4))  # blocks reduce to the whole matrix's factor
    gram = C.T @ C
    np.testing.assert_allclose(
        stacked.T @ stacked, gram, rtol=1e-12, atol=1e-12 * np.abs(gram).max()
    )
    with pytest.raises(ValueError, match="block_rows"):
        block_factors(p, 4, 3, fill)
