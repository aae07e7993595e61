"""Unit checks of calib.tractor_trailer.estimators against closed forms and brute-force
computations."""

from __future__ import annotations

import json

import numpy as np
import pytest

from calib.errors import InsufficientDataError, SolverError
from calib.stats import hac_covariance, hf_noise_std
from calib.tractor_trailer.estimators import SteadyStateEIV, TransientFit, identifiability
from calib.tractor_trailer.estimators._integrate import plan_steps, simulate_psi
from calib.tractor_trailer.estimators._propagate import adjoint_apply
from calib.tractor_trailer.estimators.eiv import project_onto_curve
from calib.tractor_trailer.models.hitch_kinematics import steady_state_kappa, steady_state_psi

# --------------------------------------------------------------------------- identifiability


def test_identifiability_sum_variance_is_closed_form() -> None:
    cov = np.array([[0.04, -0.039], [-0.039, 0.04]])  # strongly anti-correlated: sum sharp
    v = identifiability(cov, (1.25, 2.48), rel_tol=0.1)
    assert v.sum_L1_L2.std == pytest.approx(np.sqrt(0.04 + 0.04 - 2 * 0.039))
    assert v.L1.std == pytest.approx(0.2)
    assert v.sum_determined
    assert not v.split_determined
    assert "split is not determined" in v.sentence
    assert v.best_direction == pytest.approx((1 / np.sqrt(2), 1 / np.sqrt(2)))
    assert v.correlation == pytest.approx(-0.975)
    json.dumps(v.to_dict())


def test_identifiability_from_singular_fisher() -> None:
    # information only about L1 + L2 (rank 1): the split has infinite variance
    a = np.array([1.0, 1.0])
    fisher = 1e4 * np.outer(a, a)
    v = identifiability(fisher, (1.2, 2.5), is_fisher=True)
    assert v.sum_L1_L2.std == pytest.approx(0.01)  # var = 2 / (2e4): a = sqrt(2) unit vector
    assert np.isinf(v.L1.std)
    assert not v.L1.identifiable
    assert v.sum_L1_L2.identifiable


def test_identifiability_determined_split() -> None:
    v = identifiability(np.diag([1e-4, 1e-4]), (1.25, 2.48))
    assert v.split_determined
    assert v.sentence.startswith("This log determines L1 = 1.250")


def test_identifiability_rejects_bad_matrix() -> None:
    with pytest.raises(SolverError, match="2 x 2"):
        identifiability(np.eye(3), (1.0, 2.0))


# --------------------------------------------------------------------------- statistics


def test_hf_noise_std_recovers_white_noise_on_smooth_signal() -> None:
    rng = np.random.default_rng(1)
    t = np.linspace(0, 60, 6000)
    x = 0.3 * np.sin(0.1 * t) + rng.normal(0, 0.01, t.size)
    assert hf_noise_std(x) == pytest.approx(0.01, rel=0.05)


def test_hac_covariance_reduces_to_ols_for_white_residuals() -> None:
    rng = np.random.default_rng(2)
    n = 20000
    J = np.column_stack([np.ones(n), np.linspace(-1, 1, n)])
    r = rng.normal(0, 0.5, n)
    cov = hac_covariance(J, r, 0)
    ols = 0.25 * np.linalg.inv(J.T @ J)
    assert np.diag(cov) == pytest.approx(np.diag(ols), rel=0.05)


def test_adjoint_matches_explicit_matrix() -> None:
    rng = np.random.default_rng(3)
    n, p = 40, 3
    a = rng.uniform(0.5, 1.0, n)
    b = rng.normal(size=n)
    x = rng.normal(size=(n, p))
    G = np.zeros((n, n))  # d_k = sum_{i<k} prod_{l=i+1}^{k-1} a_l b_i e_i
    for k in range(n):
        for i in range(k):
            G[k, i] = np.prod(a[i + 1 : k]) * b[i]
    assert adjoint_apply(a, b, x) == pytest.approx(G.T @ x, abs=1e-12)


def test_integrator_matches_steady_state_under_constant_input() -> None:
    # constant curvature: psi relaxes to the closed-form steady state
    n = 600
    t = np.arange(n) * 0.1 + 0.05
    edges = np.arange(n + 1) * 0.1
    kappa, L1, L2 = 0.2, 1.25, 2.48
    plan = plan_steps(t, edges, np.full(n, kappa), np.zeros(n), np.ones(n), np.zeros(n))
    psi = simulate_psi(plan, np.array([L1]), np.array([L2]), np.array([0.0]))[::2, 0]
    assert psi[-1] == pytest.approx(steady_state_psi(kappa, L1, L2), abs=1e-9)


# --------------------------------------------------------------------------- EIV


def test_projection_lands_on_curve_and_is_closest() -> None:
    rng = np.random.default_rng(4)
    L1, L2 = 1.25, 2.48
    psi_true = np.linspace(-0.6, 0.6, 50)
    k = steady_state_kappa(psi_true, L1, L2) + rng.normal(0, 0.01, 50)
    p = psi_true + rng.normal(0, 0.01, 50)
    ph = project_onto_curve(k, p, L1, L2, 0.01, 0.01)
    # the first-order condition of the weighted distance holds at the projection
    g = steady_state_kappa(ph, L1, L2)
    dg = (L2 * np.cos(ph) + L1) / (L2 + L1 * np.cos(ph)) ** 2
    assert (k - g) * dg + (p - ph) == pytest.approx(np.zeros(50), abs=1e-12)
    # and no point on a fine grid of the curve is closer
    grid = np.linspace(-0.8, 0.8, 20001)
    d_grid = (k[:, None] - steady_state_kappa(grid, L1, L2)) ** 2 + (p[:, None] - grid) ** 2
    d_hat = (k - g) ** 2 + (p - ph) ** 2
    assert np.all(d_hat <= d_grid.min(axis=1) + 1e-12)


def test_projection_of_a_long_log_is_each_points_own_projection() -> None:
    """Points are projected in blocks of 65536; each point's result is the one it gets alone."""
    rng = np.random.default_rng(5)
    L1, L2, n = 1.25, 2.48, 70_000
    psi_true = rng.uniform(-0.7, 0.7, n)
    k = steady_state_kappa(psi_true, L1, L2) + rng.normal(0, 0.02, n)
    p = psi_true + rng.normal(0, 0.01, n)
    ph = project_onto_curve(k, p, L1, L2, 0.02, 0.01)
    for lo, hi in ((0, 10), (65_530, 65_540), (n - 10, n)):
        alone = project_onto_curve(k[lo:hi], p[lo:hi], L1, L2, 0.02, 0.01)
        np.testing.assert_array_equal(ph[lo:hi], alone)


@pytest.mark.parametrize(("L1", "L2"), [(1.25, 2.48), (1.8, 1.8), (2.4, 1.3)])
def test_eiv_exact_on_ideal_steady_data(L1: float, L2: float) -> None:
    t = np.arange(0, 63.05, 0.1)
    k = 0.2 * np.sin(0.1 * t)
    psi = steady_state_psi(k, L1, L2)
    fit = SteadyStateEIV(noise_std=(1e-3, 1e-3)).fit(k, psi)
    assert pytest.approx(L1, abs=1e-6) == fit.L1_
    assert pytest.approx(L2, abs=1e-6) == fit.L2_


def test_eiv_intervals_cover_truth_on_noisy_high_curvature_data() -> None:
    # L1 > L2: no curvature limit, so large joint angles determine the split
    rng = np.random.default_rng(5)
    L1, L2 = 2.4, 1.3
    t = np.arange(0, 63.05, 0.1)
    hits = []
    for _ in range(10):
        k = 0.5 * np.sin(0.1 * t)
        psi = steady_state_psi(k, L1, L2)
        fit = SteadyStateEIV().fit(
            k + rng.normal(0, 0.0173, k.size), psi + rng.normal(0, 0.0173, k.size)
        )
        v = fit.verdict_
        hits.append(v.L1.ci95[0] <= L1 <= v.L1.ci95[1] and v.L2.ci95[0] <= L2 <= v.L2.ci95[1])
        assert v.split_determined
    # A tiny random slice: two nominal 95 % intervals cover jointly at least 90 % of the time
    # (Bonferroni), and P(at most 5 of 10 | 0.9) = 0.0016, so an honest method fails this
    # with probability below 0.2 %.
    assert sum(hits) >= 6


def test_eiv_low_curvature_steady_log_sum_determined_split_not() -> None:
    rng = np.random.default_rng(6)
    L1, L2 = 1.25, 2.48
    t = np.arange(0, 63.05, 0.1)
    k = 0.1 * np.sin(0.1 * t)
    psi = steady_state_psi(k, L1, L2)
    fit = SteadyStateEIV().fit(
        k + rng.normal(0, 0.0173, k.size), psi + rng.normal(0, 0.0173, k.size)
    )
    v = fit.verdict_
    assert v.sum_determined
    assert not v.split_determined
    # the sum's coverage on such logs: bench/coverage_study.py (many seeds), not one seed here
    assert v.sum_L1_L2.ci95[0] < v.sum_L1_L2.value < v.sum_L1_L2.ci95[1]
    assert "the split is not determined" in fit.result_.verdict
    assert fit.method_result_.family == "EIV"
    doc = json.loads(json.dumps(fit.result_.to_dict()))
    assert doc["identifiable"] is False


def test_eiv_rejects_bad_input() -> None:
    with pytest.raises(InsufficientDataError, match="kappa has 3 samples but psi has 2"):
        SteadyStateEIV().fit([0.1, 0.2, 0.3], [0.1, 0.2])
    with pytest.raises(InsufficientDataError, match="constant"):
        SteadyStateEIV().fit(np.full(50, 0.1), np.linspace(0, 1, 50))


# --------------------------------------------------------------------------- transient inputs


def test_transient_rejects_bad_input() -> None:
    t = np.arange(100) * 0.01
    with pytest.raises(InsufficientDataError, match="equal lengths"):
        TransientFit().fit(t, np.zeros(99), np.ones(100), np.zeros(100))
    with pytest.raises(InsufficientDataError, match="strictly increasing"):
        TransientFit().fit(t[::-1], np.zeros(100), np.ones(100), np.zeros(100))
    with pytest.raises(InsufficientDataError, match="psi samples"):
        TransientFit().fit(t, np.zeros(100), np.ones(100), np.full(100, np.nan))
