"""The patent's 36 methods: names, exact recovery, METHODS.md's verified numbers, CLS."""

from __future__ import annotations

import math

import numpy as np
import pytest

from calib.errors import InsufficientDataError
from calib.lsq import OLS1, OLS2, TLS, triangular_factor
from calib.tractor_trailer.methods import (
    CLS_TABLE,
    METHOD_NAMES,
    MethodEstimate,
    ResampledData,
    evaluate_methods,
    family_of,
    method_spec,
)
from calib.tractor_trailer.models.hitch_kinematics import steady_state_psi
from calib.tractor_trailer.patent_models import (
    ExactModel,
    em_columns,
    em_design,
    lengths_from_beta,
    pm_design,
)
from calib.tractor_trailer.predicted_rows import predicted_rows_factor

L1, L2 = 1.25, 2.48
EMLS = ("OLS1(EM1)", "OLS1(EM2)", "OLS1(EM3)", "TLS(EM1)", "TLS(EM2)", "TLS(EM3)")


def harmonic(
    M: float, n: int = 631, t_end: float = 63.0, l1: float = L1, l2: float = L2
) -> tuple[np.ndarray, np.ndarray]:
    """METHODS.md's verified scenario: κ = M sin(0.1 t), ideal steady-state Ψ."""
    t = np.linspace(0.0, t_end, n)
    k = M * np.sin(0.1 * t)
    return k, steady_state_psi(k, l1, l2)


def test_names_families_and_table3() -> None:
    assert len(METHOD_NAMES) == 36
    assert len(set(METHOD_NAMES)) == 36
    fams = [str(family_of(n)) for n in METHOD_NAMES]
    assert (fams.count("EMLS"), fams.count("PMLS"), fams.count("CLS")) == (6, 6, 24)
    # patent Table 3, a few rows verbatim
    assert CLS_TABLE["M1"].description == "OLS1(PM2) + OLS1(EM1)"
    assert CLS_TABLE["M4"].description == "OLS1(PM2) + TLS(EM1,2,3)"
    assert CLS_TABLE["M7"].description == "OLS2(PM2) + OLS1(EM3)"
    assert CLS_TABLE["M10"].description == "TLS(PM2) + OLS1(EM2)"
    assert CLS_TABLE["M13"].description == "OLS1(PM1) + OLS1(EM1)"
    assert CLS_TABLE["M20"].description == "OLS2(PM1) + TLS(EM1,2,3)"
    assert CLS_TABLE["M24"].description == "TLS(PM1) + TLS(EM1,2,3)"
    with pytest.raises(ValueError, match="unknown method"):
        method_spec("M25")


@pytest.mark.parametrize(("l1", "l2"), [(1.25, 2.48), (0.6, 3.0), (2.0, 2.2)])
def test_emls_recovers_lengths_exactly_on_ideal_data(l1: float, l2: float) -> None:
    k, p = harmonic(0.2, l1=l1, l2=l2)
    est = evaluate_methods(k, p, EMLS)
    for name in EMLS:
        assert pytest.approx(l1, rel=1e-9) == est[name].L1, name
        assert pytest.approx(l2, rel=1e-9) == est[name].L2, name


def _one_unit(printed: str) -> float:
    """One unit in the last printed digit."""
    return 10.0 ** -len(printed.partition(".")[2])


@pytest.mark.parametrize(
    ("M", "ols1", "tls"),
    [
        (0.2, ("24.91", "159.3", "78.07"), ("16.2", "29.3", "7.35")),
        (0.1, ("110.8", "673.7", "337.3"), ("134.0", "236.4", "59.86")),
    ],
)
def test_condition_numbers_match_methods_md(M: float, ols1, tls) -> None:
    """OLS1 ones are scale-free (631-sample grid of METHODS.md); the TLS ones are absolute and
    match the 630-sample grid of calib.tractor_trailer.reproduce. Allowed: one unit in the last
    printed digit
    (we get 673.78 and 337.24 for the printed 673.7 and 337.3)."""
    est = evaluate_methods(*harmonic(M), EMLS)
    for i, printed in enumerate(ols1, 1):
        got = est[f"OLS1(EM{i})"].condition_number
        assert got == pytest.approx(float(printed), abs=_one_unit(printed)), (i, printed)
    est = evaluate_methods(*harmonic(M, n=630), EMLS)
    for i, printed in enumerate(tls, 1):
        got = est[f"TLS(EM{i})"].condition_number
        assert got == pytest.approx(float(printed), abs=_one_unit(printed)), (i, printed)
    # one TLS estimate for all three models
    assert pytest.approx(est["TLS(EM1)"].L1, rel=1e-10) == est["TLS(EM2)"].L1


def test_pm_slopes_and_condition_numbers_match_methods_md() -> None:
    est = evaluate_methods(*harmonic(0.2))
    for name in ("OLS1(PM1)", "OLS2(PM1)", "TLS(PM1)", "OLS1(PM2)", "OLS2(PM2)", "TLS(PM2)"):
        assert est[name].extra["a"] == pytest.approx(3.733, abs=5e-4), name
        assert math.isnan(est[name].L1)
    assert est["OLS1(PM2)"].condition_number == pytest.approx(7.09, abs=5e-3)
    assert est["OLS2(PM2)"].condition_number == pytest.approx(1.90, abs=5e-3)
    assert est["TLS(PM2)"].condition_number == pytest.approx(1.09, abs=5e-3)
    # the patent prints μ1 for OLS on PM1, and "-" as its condition number
    assert math.isnan(est["OLS1(PM1)"].condition_number)
    assert est["OLS1(PM1)"].extra["mu1"] == pytest.approx(np.linalg.norm(harmonic(0.2)[0]))
    assert evaluate_methods(*harmonic(0.1))["TLS(PM2)"].extra["a"] == pytest.approx(3.730, abs=5e-4)


@pytest.mark.parametrize(("M", "err1", "err2"), [(0.2, 1.9, -0.8), (0.1, 0.04, -0.02)])
def test_cls_errors_with_pm1_match_methods_md(M: float, err1: float, err2: float) -> None:
    est = evaluate_methods(*harmonic(M), [f"M{i}" for i in range(13, 25)])
    for name, e in est.items():
        assert pytest.approx(err1, abs=0.05 if M == 0.2 else 0.005) == 100 * (e.L1 / L1 - 1), name
        assert pytest.approx(err2, abs=0.05 if M == 0.2 else 0.005) == 100 * (e.L2 / L2 - 1), name


@pytest.mark.parametrize(("l1", "l2", "e1", "e2"), [(1.8, 1.8, 1.19, 2.30), (0.5, 3.2, 1.33, 2.56)])
def test_cls_split_tends_to_a_third_whatever_the_truth(l1, l2, e1, e2) -> None:
    est = evaluate_methods(*harmonic(0.2, l1=l1, l2=l2), ["M13"])["M13"]
    assert (pytest.approx(e1, abs=0.005), pytest.approx(e2, abs=0.005)) == (est.L1, est.L2)


def test_cls_equals_a_step_by_step_computation_on_explicit_arrays() -> None:
    rng = np.random.default_rng(0)
    k0, p0 = harmonic(0.2)
    k, p = k0 + rng.normal(0, 0.01, k0.size), p0 + rng.normal(0, 0.01, k0.size)
    a, b = OLS2().fit(*pm_design("PM2", k, p)).beta_  # M5..M8 start with OLS2(PM2)
    kk = np.concatenate([k, (p - b) / a])
    pp = np.concatenate([a * k + b, p])
    m6 = lengths_from_beta(ExactModel.EM2, OLS1().fit(*em_design("EM2", kk, pp)).beta_)
    m8 = lengths_from_beta(ExactModel.EM1, TLS().fit(*em_design("EM1", kk, pp)).beta_)
    est = evaluate_methods(k, p, ["M6", "M8", "OLS1(EM3)"])
    assert (pytest.approx(m6[0]), pytest.approx(m6[1])) == (est["M6"].L1, est["M6"].L2)
    assert (pytest.approx(m8[0]), pytest.approx(m8[1])) == (est["M8"].L1, est["M8"].L2)
    em3 = lengths_from_beta(ExactModel.EM3, OLS1().fit(*em_design("EM3", k, p)).beta_)
    assert pytest.approx(em3[0]) == est["OLS1(EM3)"].L1
    assert list(est) == ["M6", "M8", "OLS1(EM3)"]
    assert est["M6"].extra["a"] == pytest.approx(a)


def test_long_data_cls_and_emls_equal_the_explicit_fits() -> None:
    """More samples than one stretch of the factorisation (65536 rows): the shared factor of
    [sin Ψ, κ cos Ψ, κ, 1, Ψ, Ψ cos Ψ, cos Ψ] gives what fits on the explicit arrays give."""
    rng = np.random.default_rng(1)
    k0, p0 = harmonic(0.2, n=70_001, t_end=630.0)
    k, p = k0 + rng.normal(0, 0.01, k0.size), p0 + rng.normal(0, 0.01, k0.size)
    est = evaluate_methods(k, p, ["M21", "M12", "TLS(EM2)", "OLS1(PM2)"])
    a = float(TLS().fit(*pm_design("PM1", k, p)).beta_[0])  # M21 starts with TLS(PM1)
    kk, pp = np.concatenate([k, p / a]), np.concatenate([a * k, p])
    m21 = lengths_from_beta(ExactModel.EM1, OLS1().fit(*em_design("EM1", kk, pp)).beta_)
    assert pytest.approx(m21[0], rel=1e-9) == est["M21"].L1
    assert pytest.approx(m21[1], rel=1e-9) == est["M21"].L2
    a, b = TLS().fit(*pm_design("PM2", k, p)).beta_  # M12: TLS(PM2) + TLS(EM1,2,3)
    kk, pp = np.concatenate([k, (p - b) / a]), np.concatenate([a * k + b, p])
    fit = TLS().fit(*em_design("EM1", kk, pp))
    m12 = lengths_from_beta(ExactModel.EM1, fit.beta_)
    assert pytest.approx(m12[0], rel=1e-9) == est["M12"].L1
    assert pytest.approx(m12[1], rel=1e-9) == est["M12"].L2
    assert est["M12"].condition_number == pytest.approx(fit.condition_number_, rel=1e-9)
    fit = TLS().fit(*em_design("EM2", k, p))
    assert est["TLS(EM2)"].condition_number == pytest.approx(fit.condition_number_, rel=1e-9)
    assert est["OLS1(PM2)"].extra["b"] == pytest.approx(
        OLS1().fit(*pm_design("PM2", k, p)).beta_[1], rel=1e-9
    )


def test_degenerate_data_raise_naming_what_is_missing() -> None:
    with pytest.raises(InsufficientDataError, match="kappa does not vary"):
        evaluate_methods(np.zeros(50), np.zeros(50))
    with pytest.raises(InsufficientDataError, match="kappa does not vary"):
        evaluate_methods(np.full(50, 0.1), np.full(50, 0.37))
    with pytest.raises(InsufficientDataError, match="at least 3"):
        evaluate_methods([0.1, 0.2], [0.3, 0.7])
    with pytest.raises(InsufficientDataError, match="same length"):
        evaluate_methods(np.ones(5), np.ones(4))


def _resample(n: int = 3000, seed: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Noisy harmonic data and the multiplicities of a block-bootstrap-like draw: runs of
    consecutive rows (lengths 1..400) drawn with replacement, some rows absent."""
    rng = np.random.default_rng(seed)
    k0, p0 = harmonic(0.2, n=n, t_end=n / 10.0)
    k, p = k0 + rng.normal(0, 0.01, n), p0 + rng.normal(0, 0.01, n)
    counts = np.zeros(n, dtype=np.int64)
    while counts.sum() < n:
        start, length = int(rng.integers(0, n)), int(rng.integers(1, 400))
        counts[start : start + length] += 1
    return k, p, counts


def _same(a: MethodEstimate, b: MethodEstimate, rel: float) -> None:
    assert a.failed == b.failed
    for x, y in [(a.L1, b.L1), (a.L2, b.L2), (a.condition_number, b.condition_number)]:
        assert (math.isnan(x) and math.isnan(y)) or pytest.approx(x, rel=rel) == y, a.name
    assert a.extra.keys() == b.extra.keys()
    for key, x in a.extra.items():
        assert pytest.approx(x, rel=rel) == b.extra[key], (a.name, key)


def test_weighted_distinct_rows_factor_equals_the_factor_of_the_repeated_rows() -> None:
    """R of the distinct rows, each scaled by √(multiplicity), has Rᵀ R = the Gram matrix of
    the repeated rows: for the base columns (assembled from stored chunk factors) and for the
    CLS predicted-angle rows (compiled and numpy paths)."""
    k, p, counts = _resample()
    idx = np.repeat(np.arange(k.size), counts)
    cols = np.column_stack([np.sin(p), k * np.cos(p), k, np.ones_like(k), p, p * np.cos(p),
                            np.cos(p)])[idx]  # fmt: skip
    gram = cols.T @ cols
    R = ResampledData(k, p)._base_factor(counts)
    assert np.abs(R.T @ R - gram).max() <= 1e-12 * np.abs(gram).max()
    rows = np.flatnonzero(counts)
    w = np.sqrt(counts[rows].astype(float))
    D = em_columns(k[idx], 3.7 * k[idx] - 0.01)
    gram = D.T @ D
    for reference in (False, True):
        R = predicted_rows_factor(k[rows], 3.7, -0.01, w, reference=reference)
        assert np.abs(R.T @ R - gram).max() <= 1e-12 * np.abs(gram).max()
    R = triangular_factor(D)  # and both are factors of the same matrix as one QR's
    assert np.abs(R.T @ R - gram).max() <= 1e-12 * np.abs(gram).max()


def test_methods_on_a_resample_equal_the_methods_on_its_repeated_rows() -> None:
    k, p, counts = _resample(seed=3)
    idx = np.repeat(np.arange(k.size), counts)
    data = ResampledData(k, p)
    got = data.evaluate(counts)
    want = evaluate_methods(k[idx], p[idx])
    assert list(got) == list(METHOD_NAMES)
    for name in METHOD_NAMES:
        _same(got[name], want[name], rel=1e-9)
    ones = data.evaluate(np.ones(k.size, dtype=np.int64), ["M12", "TLS(PM2)"])
    plain = evaluate_methods(k, p, ["M12", "TLS(PM2)"])
    for name in ones:
        _same(ones[name], plain[name], rel=1e-9)


def test_resampled_data_rejects_bad_counts() -> None:
    k, p, counts = _resample(n=500)
    data = ResampledData(k, p)
    with pytest.raises(ValueError, match="non-negative integers"):
        data.evaluate(counts[:-1])
    with pytest.raises(ValueError, match="non-negative integers"):
        data.evaluate(counts.astype(float))
    with pytest.raises(ValueError, match="non-negative integers"):
        data.evaluate(-counts)
    with pytest.raises(InsufficientDataError, match="0 \\(kappa, psi\\) samples"):
        data.evaluate(np.zeros(500, dtype=np.int64))
    one_row = np.zeros(500, dtype=np.int64)
    one_row[7] = 5  # five copies of one sample: nothing varies
    with pytest.raises(InsufficientDataError, match="kappa does not vary"):
        data.evaluate(one_row)
