"""Repeat statistics: mean ± σ over data sets, block length, moving-block bootstrap."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.errors import InsufficientDataError
from calib.tractor_trailer.methods import evaluate_methods
from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.repeats import (
    block_length,
    bootstrap_counts,
    bootstrap_datasets,
    methods_over_repeats,
    methods_table,
)

NAMES = ["OLS1(EM1)", "TLS(EM2)", "OLS1(PM1)", "OLS2(PM2)", "M17", "M24"]


def _data(rng: np.random.Generator, sigma: float = 0.0173, n: int = 630):
    t = np.linspace(0.0, 63.0, n)
    k = 0.2 * np.sin(0.1 * t)
    p = steady_state_psi(k, 1.25, 2.48)
    return k + rng.normal(0, sigma, n), p + rng.normal(0, sigma, n)


def _ar1(rng: np.random.Generator, phi: float, n: int) -> np.ndarray:
    e = rng.normal(size=n)
    x = np.empty(n)
    x[0] = e[0]
    for i in range(1, n):
        x[i] = phi * x[i - 1] + e[i]
    return x


def test_mean_and_std_over_datasets_match_numpy() -> None:
    rng = np.random.default_rng(0)
    sets = [_data(rng) for _ in range(4)]
    rows = methods_over_repeats(sets, segment="harmonic", names=NAMES)
    runs = [evaluate_methods(k, p, NAMES) for k, p in sets]
    assert [r.name for r in rows] == NAMES
    for r in rows:
        assert r.segment == "harmonic"
        assert r.n_repeats == 4
        if r.family == "PMLS":
            a = [run[r.name].extra["a"] for run in runs]
            assert r.extra["a"] == pytest.approx(np.mean(a))
            assert r.extra["a_std"] == pytest.approx(np.std(a, ddof=1))
            assert math.isnan(r.L1)
        else:
            l1 = [run[r.name].L1 for run in runs]
            assert pytest.approx(np.mean(l1)) == r.L1
            assert r.L1_std == pytest.approx(np.std(l1, ddof=1))
        cn = [run[r.name].condition_number for run in runs]
        if all(math.isfinite(c) for c in cn):
            assert r.condition_number == pytest.approx(np.mean(cn))
    assert rows[0].family == "EMLS"
    assert rows[-1].family == "CLS"


def test_one_dataset_has_zero_spread() -> None:
    rows = methods_over_repeats([_data(np.random.default_rng(1))], names=["M17"])
    assert rows[0].L1_std == 0.0
    assert rows[0].n_repeats == 1


def test_block_length_follows_the_autocorrelation() -> None:
    rng = np.random.default_rng(2)
    white = block_length(rng.normal(size=4000))
    mild = block_length(_ar1(rng, 0.5, 4000))
    strong = block_length(_ar1(rng, 0.95, 4000))
    assert white <= 3
    assert white < mild < strong
    # Politis-White optimum for AR(1), moving blocks: (2 G²/((4/3) g²))^(1/3) n^(1/3) with
    # G/g = 2φ/(1-φ²): about 120 for φ = 0.95, n = 4000 (estimated, so a wide band)
    assert 40 <= strong <= 300


def test_bootstrap_keeps_pairs_and_contiguous_blocks() -> None:
    k = np.arange(100.0)
    p = 2.0 * k + 1.0
    draws = list(bootstrap_datasets(k, p, n=3, rng=np.random.default_rng(4), block_len=10))
    assert len(draws) == 3
    for kb, pb in draws:
        assert kb.size == 100
        np.testing.assert_array_equal(pb, 2.0 * kb + 1.0)  # (κ, Ψ) pairs stay together
        steps = np.diff(kb.reshape(10, 10), axis=1)
        np.testing.assert_array_equal(steps, 1.0)  # consecutive samples inside each block
    again = list(bootstrap_datasets(k, p, n=3, rng=np.random.default_rng(4), block_len=10))
    np.testing.assert_array_equal(draws[2][0], again[2][0])


def test_bootstrap_spread_matches_fresh_noise_spread_on_white_noise() -> None:
    """On one simulated record, the bootstrap σ of the PM slope estimates the σ that fresh noise
    realisations give (the truth, from 60 independent records)."""
    rng = np.random.default_rng(5)
    fresh = methods_over_repeats([_data(rng) for _ in range(60)], names=["OLS1(PM2)"])[0]
    boot = methods_table(*_data(rng), repeats=60, rng=rng, names=["OLS1(PM2)"])[0]
    ratio = boot.extra["a_std"] / fresh.extra["a_std"]
    assert 0.6 < ratio < 1.6


def test_methods_table_with_one_repeat_is_the_plain_evaluation() -> None:
    k, p = _data(np.random.default_rng(6))
    row = methods_table(k, p, repeats=1, names=["M21"])[0]
    assert pytest.approx(evaluate_methods(k, p, ["M21"])["M21"].L1) == row.L1
    assert row.L1_std == 0.0
    assert row.to_dict()["family"] == "CLS"


def test_methods_table_rejects_degenerate_data_and_bad_repeats() -> None:
    with pytest.raises(InsufficientDataError, match="kappa"):
        methods_table(np.zeros(100), np.zeros(100))
    with pytest.raises(ValueError, match="repeats"):
        methods_table(*_data(np.random.default_rng(7)), repeats=0)


def test_bootstrap_counts_are_the_multiplicities_of_the_same_draws() -> None:
    k = np.arange(1000.0)  # the values are the sample indices
    p = np.sin(k / 50.0)
    for block_len in (1, 7, 333, None):
        draws = bootstrap_datasets(k, p, n=4, rng=np.random.default_rng(8), block_len=block_len)
        counts = bootstrap_counts(k, p, n=4, rng=np.random.default_rng(8), block_len=block_len)
        for (kb, _), c in zip(draws, counts, strict=True):
            np.testing.assert_array_equal(c, np.bincount(kb.astype(int), minlength=1000))


def _simulated_log() -> tuple[np.ndarray, np.ndarray]:
    """A simulated run of the patent's mixed commands (249 s at 50 Hz, transient trailer),
    with noise on κ and Ψ."""
    from calib.tractor_trailer.sim.presets import patent_mixed
    from calib.tractor_trailer.sim.tractor_trailer import simulate_tractor_trailer

    run = simulate_tractor_trailer(patent_mixed(rate_hz=50.0), seed=3)
    rng = np.random.default_rng(0)
    k = run.truth["kappa"].to_numpy()
    p = run.truth["psi"].to_numpy()
    return k + rng.normal(0, 0.005, k.size), p + rng.normal(0, 0.01, p.size)


def test_methods_table_equals_the_methods_on_each_drawn_data_set() -> None:
    """The table from weighted distinct rows equals the one from evaluating every bootstrap
    draw as repeated rows (same random draws), all 36 methods, to 1e-9 relative."""
    k, p = _simulated_log()
    fast = methods_table(k, p, segment="mixed", repeats=3, rng=np.random.default_rng(11))
    draws = bootstrap_datasets(k, p, n=3, rng=np.random.default_rng(11))
    slow = methods_over_repeats(draws, segment="mixed")
    assert [r.name for r in fast] == [r.name for r in slow]
    for a, b in zip(fast, slow, strict=True):
        da, db = a.to_dict(), b.to_dict()
        assert da.keys() == db.keys()
        for key in da:
            x, y = da[key], db[key]
            if isinstance(x, float) and isinstance(y, float):
                assert pytest.approx(x, rel=1e-9, abs=1e-15) == y, (a.name, key)
            elif key == "extra":
                assert x.keys() == y.keys()
                for e in x:
                    assert pytest.approx(x[e], rel=1e-9, abs=1e-15) == y[e], (a.name, e)
            else:
                assert x == y, (a.name, key)
