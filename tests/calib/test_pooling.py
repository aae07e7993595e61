"""calib.pooling: GLS pooling of estimates with their covariances, against references.

The univariate case against statsmodels' ``combine_effects`` (fixed effect and
DerSimonian-Laird random effects; statsmodels is a test-only reference), the multivariate fixed
effect against the closed form on random data, pieces that determine only some parameters,
property tests (one piece returns it, permutation invariance, identical pieces give Σ/k), and a
small random slice of bench/pooling_coverage.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from bench_scripts import load_bench
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from calib.pooling import pool_gls, pool_univariate


def _random_cov(rng: np.random.Generator, p: int) -> np.ndarray:
    a = rng.normal(size=(p, p))
    return a @ a.T + 0.1 * np.eye(p)


@pytest.mark.parametrize("seed", range(8))
def test_univariate_matches_statsmodels_fixed_and_dersimonian_laird(seed: int) -> None:
    from statsmodels.stats.meta_analysis import combine_effects

    rng = np.random.default_rng(seed)
    k = int(rng.integers(3, 9))
    s = rng.uniform(0.1, 1.0, k)
    x = rng.normal(0.0, 1.0, k) + rng.normal(0.0, s)  # heterogeneous: tau = 1
    with np.errstate(invalid="ignore"):  # statsmodels' sqrt of a negative variance (Q < df)
        ref = combine_effects(x, s**2, method_re="dl")
    fe = pool_univariate(x, s, random="never")
    re = pool_univariate(x, s, random="always")
    assert fe.value[0] == pytest.approx(ref.mean_effect_fe, rel=1e-12)
    assert math.sqrt(fe.cov[0, 0]) == pytest.approx(ref.sd_eff_w_fe, rel=1e-12)
    assert fe.q == pytest.approx(ref.q, rel=1e-12)
    # statsmodels leaves a negative DerSimonian-Laird tau^2 (Q < df) untruncated; the
    # estimator truncates it at 0, where the random effects are the fixed effect
    assert re.tau2 == pytest.approx(max(0.0, ref.tau2), rel=1e-10, abs=1e-14)
    if ref.tau2 > 0:
        assert re.value[0] == pytest.approx(ref.mean_effect_re, rel=1e-12)
        assert math.sqrt(re.cov[0, 0]) == pytest.approx(ref.sd_eff_w_re, rel=1e-12)
    else:
        assert re.value[0] == pytest.approx(ref.mean_effect_fe, rel=1e-12)
        assert math.sqrt(re.cov[0, 0]) == pytest.approx(ref.sd_eff_w_fe, rel=1e-12)
    assert fe.df == k - 1
    assert fe.p_value == pytest.approx(stats.chi2.sf(ref.q, k - 1), rel=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_multivariate_fixed_effect_is_the_closed_form(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    k, p = int(rng.integers(2, 7)), int(rng.integers(2, 5))
    covs = np.array([_random_cov(rng, p) for _ in range(k)])
    vals = rng.normal(size=(k, p))
    res = pool_gls(vals, covs, random="never")
    inv = [np.linalg.inv(c) for c in covs]
    sigma = np.linalg.inv(np.sum(inv, axis=0))
    theta = sigma @ np.sum([w @ v for w, v in zip(inv, vals, strict=True)], axis=0)
    q = sum((v - theta) @ w @ (v - theta) for w, v in zip(inv, vals, strict=True))
    np.testing.assert_allclose(res.value, theta, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(res.cov, sigma, rtol=1e-9, atol=1e-12)
    assert res.q == pytest.approx(q, rel=1e-9)
    assert res.df == (k - 1) * p
    assert list(res.pieces) == [k] * p


def test_random_effects_with_equal_covariances_are_the_sample_covariance_over_k() -> None:
    """With one covariance S for every piece, the method of moments gives Ψ = C - S (C the
    sample covariance of the pieces' values), so the random-effects covariance is C / k: the
    spread the pieces show, whatever they claimed."""
    rng = np.random.default_rng(7)
    cov = np.array([[1.0, 0.6], [0.6, 1.0]]) * 1e-4
    vals = rng.normal(size=(6, 2))  # spread of 1 against stds of 0.01
    auto = pool_gls(vals, np.array([cov] * 6))
    never = pool_gls(vals, np.array([cov] * 6), random="never")
    c = np.cov(vals, rowvar=False)
    assert auto.heterogeneous
    assert auto.random
    np.testing.assert_allclose(auto.between, c - cov, rtol=1e-9)
    np.testing.assert_allclose(auto.cov, c / 6, rtol=1e-9)
    np.testing.assert_allclose(auto.value, vals.mean(axis=0), rtol=1e-9)
    np.testing.assert_allclose(never.cov, cov / 6, rtol=1e-9)
    agree = pool_gls(
        np.array([[1.0, 2.0]] * 3) + rng.normal(size=(3, 2)) * 1e-2,
        np.array([cov] * 3),
        random="auto",
    )
    assert not agree.heterogeneous
    assert not agree.random
    assert agree.inflation == 1.0


def test_a_piece_lacking_a_parameter_makes_the_random_effects_a_single_factor() -> None:
    rng = np.random.default_rng(8)
    cov = np.array([[1.0, 0.6], [0.6, 1.0]]) * 1e-4
    vals = rng.normal(size=(5, 2))
    covs = np.array([cov] * 5)
    vals[0, 1] = math.nan
    covs[0, 1, :] = covs[0, :, 1] = math.nan
    auto = pool_gls(vals, covs)
    never = pool_gls(vals, covs, random="never")
    assert auto.random
    assert np.isnan(auto.between).all()
    assert auto.df == 9 - 2
    assert auto.inflation == pytest.approx(auto.q / auto.df)
    np.testing.assert_allclose(auto.cov, never.cov * auto.q / auto.df)
    np.testing.assert_allclose(auto.value, never.value)


def test_a_parameter_a_piece_does_not_determine_comes_from_the_others() -> None:
    nan = math.nan
    vals = np.array([[1.0, 2.0], [1.2, nan], [nan, nan]])
    covs = np.array(
        [
            [[0.04, 0.01], [0.01, 0.09]],
            [[0.04, nan], [nan, nan]],
            [[nan, nan], [nan, nan]],
        ]
    )
    res = pool_gls(vals, covs, random="never")
    assert list(res.pieces) == [2, 1]
    # only the first two pieces, the second one over L1 alone
    inv0 = np.linalg.inv(covs[0])
    a = inv0 + np.diag([1 / 0.04, 0.0])
    sigma = np.linalg.inv(a)
    theta = sigma @ (inv0 @ vals[0] + np.array([1.2 / 0.04, 0.0]))
    np.testing.assert_allclose(res.value, theta)
    np.testing.assert_allclose(res.cov, sigma)
    assert res.df == 1  # 3 informed ranks, 2 parameters
    none = pool_gls(np.array([[nan, 1.0]]), np.array([[[nan, nan], [nan, 1.0]]]))
    assert math.isnan(none.value[0])
    assert np.isnan(none.cov[0]).all()
    assert none.value[1] == 1.0


def test_a_direction_no_piece_informs_leaves_its_parameters_unknown() -> None:
    exact = np.array([[1.0, 1.0], [1.0, 1.0]])  # correlation 1: dropped as uninformative
    res = pool_gls(np.array([[1.0, 1.0], [2.0, 2.0]]), np.array([exact, exact]))
    assert np.isnan(res.cov).all()


def test_bad_shapes_are_refused() -> None:
    with pytest.raises(ValueError, match="values"):
        pool_gls(np.zeros((2, 2)), np.zeros((2, 3, 3)))


_finite = st.floats(-100, 100, allow_nan=False, allow_infinity=False)


@st.composite
def _pieces(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    k = draw(st.integers(1, 5))
    p = draw(st.integers(1, 3))
    seed = draw(st.integers(0, 2**31))
    rng = np.random.default_rng(seed)
    covs = np.array([_random_cov(rng, p) for _ in range(k)])
    vals = np.array([[draw(_finite) for _ in range(p)] for _ in range(k)])
    return vals, covs


@settings(max_examples=60, deadline=None)
@given(_pieces())
def test_one_piece_pools_to_itself(pieces: tuple[np.ndarray, np.ndarray]) -> None:
    vals, covs = pieces
    res = pool_gls(vals[:1], covs[:1])
    np.testing.assert_allclose(res.value, vals[0], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(res.cov, covs[0], rtol=1e-8, atol=1e-10)
    assert res.df == 0
    assert not res.random


@settings(max_examples=60, deadline=None)
@given(_pieces(), st.randoms(use_true_random=False))
def test_permutation_invariance(pieces: tuple[np.ndarray, np.ndarray], r: object) -> None:
    vals, covs = pieces
    order = list(range(len(vals)))
    r.shuffle(order)  # type: ignore[attr-defined]
    a = pool_gls(vals, covs)
    b = pool_gls(vals[order], covs[order])
    np.testing.assert_allclose(a.value, b.value, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(a.cov, b.cov, rtol=1e-8, atol=1e-10)
    assert (a.random, a.df) == (b.random, b.df)


@settings(max_examples=60, deadline=None)
@given(_pieces(), st.integers(2, 6))
def test_identical_pieces_give_sigma_over_k(pieces: tuple[np.ndarray, np.ndarray], k: int) -> None:
    vals, covs = pieces
    res = pool_gls(np.repeat(vals[:1], k, axis=0), np.repeat(covs[:1], k, axis=0))
    np.testing.assert_allclose(res.value, vals[0], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(res.cov, covs[0] / k, rtol=1e-8, atol=1e-10)
    assert res.q == pytest.approx(0.0, abs=1e-8)
    assert not res.heterogeneous
    assert res.inflation == 1.0  # random effects with a between-piece covariance of 0


def test_coverage_slice() -> None:
    """A small random slice of bench/pooling_coverage.py: without heterogeneity the fixed
    effect covers near 95 %; with it the fixed effect under-covers and the random effects
    (applied always, logcal's default) recover most of the gap (the full study: many more
    replicates, in the bench)."""
    mod = load_bench("pooling_coverage")
    seed = int(np.random.default_rng().integers(2**31))
    homo = mod.coverage(400, k=6, tau=0.0, seed=seed)
    het = mod.coverage(400, k=6, tau=1.0, seed=seed + 1)
    # 400 replicates: binomial std of a 95 % coverage is 1.1 points; bounds at ~4 std
    assert homo["fixed"]["joint"] > 0.90, (seed, homo)
    assert het["fixed"]["joint"] < 0.80, (seed, het)
    assert het["always"]["joint"] > het["fixed"]["joint"] + 0.15, (seed, het)
