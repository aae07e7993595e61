"""Pooling of several estimates of one parameter vector (time windows of a log, runs of a robot)
by their values and covariances: generalised least squares with a multivariate heterogeneity
test and a random-effects widening where the pieces disagree. Arrays in, arrays out; no robot.

Hand-written rather than taken from statsmodels: ``statsmodels.stats.meta_analysis`` pools one
parameter at a time (and is a test-only dependency here), and no library at hand handles pieces
that determine only some of the parameters (a window whose fit left a parameter undetermined,
its covariance row NaN). The univariate case is checked against statsmodels' ``combine_effects``
in the tests.

The model and the choices:

- Each piece i gives a value θ_i and covariance Σ_i over the p parameters. A parameter whose
  value or variance is not finite and positive in a piece is absent from that piece (it
  contributes nothing for it). Over the present parameters the piece's precision is
  P_i = D⁻¹ R⁺ D⁻¹ with D the standard deviations and R⁺ the pseudo-inverse of the correlation
  matrix (eigenvalues below ``RCOND`` of the largest dropped): a direction the piece claims to
  know exactly (a correlation of ±1) is treated as one it tells nothing about, the conservative
  reading; standardising first keeps a well-determined combination (the tractor's L1 + L2,
  whose variance may be 1e-8 of the split's) from being the one dropped. A NaN correlation
  counts as 0.
- Fixed effect (GLS): A = Σ_i P_i, θ = A⁻¹ Σ_i P_i θ_i, Σ = A⁻¹ (with one piece: that piece;
  with identical pieces: Σ_i / k). A parameter no piece informs has NaN value and NaN row; a
  direction no piece informs (A singular) makes the parameters it involves NaN too.
- Heterogeneity: Q = Σ_i (θ_i - θ)ᵀ P_i (θ_i - θ), χ² with df = Σ_i rank(P_i) - rank(A)
  (= (k - 1) p when every piece has all p parameters) under the hypothesis that every piece
  estimates the same θ with its stated covariance. Heterogeneous: p(Q) < ``alpha``.
- Random effects (``random`` "always", the default; "auto": only where heterogeneous;
  "never"): a between-piece
  covariance Ψ by the matrix method of moments (Jackson, White and Riley 2013, the multivariate
  DerSimonian-Laird): E[Σ_i W_i (θ_i - θ)(θ_i - θ)ᵀ] = (k - 1) I + (A - Σ_i W_i A⁻¹ W_i) Ψ
  with W_i = P_i, solved for Ψ, symmetrised and its negative eigenvalues set to 0; then GLS
  with weights (Σ_i + Ψ)⁻¹. With one parameter this is the DerSimonian-Laird estimator
  τ² = max(0, (Q - df) / (W - Σ w_i² / W)) (statsmodels' ``combine_effects(method_re="dl")``,
  which leaves a negative τ² untruncated). It needs every piece to inform every parameter;
  where some piece lacks one, the fixed-effect covariance is widened by the single factor
  φ = max(1, Q / df) instead (the value kept). Both under-cover with few heterogeneous pieces,
  as DerSimonian-Laird is known to; bench/pooling_coverage.py measures by how much. Random
  effects are applied always by default, not only where the Q test rejects: an estimated Ψ of
  0 (pieces that agree) leaves the fixed effect unchanged, and testing first under-covers where
  the heterogeneity is real but the test misses it (the bench: with τ of half the pieces' std,
  "auto" covers 88-90 % per parameter, "always" 93-95 %; with none, "always" 96-97 %).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy import stats

__all__ = ["RCOND", "Pooled", "piece_precision", "pool_gls", "pool_univariate"]

RCOND = 1e-10
"""Eigenvalues of a correlation matrix below this fraction of its largest are dropped."""

RandomEffects = Literal["auto", "always", "never"]


@dataclass(frozen=True)
class Pooled:
    """The pooled estimate of p parameters over k pieces.

    Attributes:
        value: the pooled values (p,); NaN where no piece informs the parameter.
        cov: their covariance (p, p), random-effects widened where applied; NaN rows and
            columns for parameters no piece informs.
        fixed_value, fixed_cov: the fixed-effect (GLS) value and covariance.
        pieces: how many pieces inform each parameter (p,).
        q, df, p_value: the generalised Cochran's Q, its degrees of freedom and p-value
            (NaN with df 0: nothing to compare).
        heterogeneous: p_value < alpha.
        random: random effects were applied.
        inflation: the factor by which the random effects widened the variances (1 when not
            applied; with one parameter the ratio of the DerSimonian-Laird variance to the
            fixed-effect one).
        tau2: the DerSimonian-Laird between-piece variance (one parameter; NaN otherwise).
        between: the between-piece covariance Ψ (p, p) by the method of moments where every
            piece informs every informed parameter (NaN otherwise, and with df 0).
        method: how the value and covariance were obtained, in words.
    """

    value: np.ndarray
    cov: np.ndarray
    fixed_value: np.ndarray
    fixed_cov: np.ndarray
    pieces: np.ndarray
    q: float
    df: int
    p_value: float
    heterogeneous: bool
    random: bool
    inflation: float
    tau2: float
    between: np.ndarray
    method: str


def _pinv_standardised(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pseudo-inverse of symmetric positive semi-definite ``m`` (positive diagonal) through
    its correlation form, and the null directions (columns, in the original coordinates'
    standardised form) dropped."""
    s = np.sqrt(np.diag(m))
    r = m / np.outer(s, s)
    r = 0.5 * (r + r.T)
    w, v = np.linalg.eigh(r)
    keep = w > RCOND * max(float(w.max()), 0.0)
    inv = (v[:, keep] / w[keep]) @ v[:, keep].T
    return inv / np.outer(s, s), v[:, ~keep]


def piece_precision(value: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """One piece's precision (p, p) over its present parameters (zero rows elsewhere), its
    value with absent parameters set to 0, and the precision's rank (see the module
    docstring)."""
    value = np.asarray(value, dtype=float)
    cov = np.asarray(cov, dtype=float)
    p = value.shape[0]
    d = np.diag(cov)
    use = np.isfinite(value) & np.isfinite(d) & (d > 0)
    prec = np.zeros((p, p))
    y = np.where(use, value, 0.0)
    if not use.any():
        return prec, y, 0
    sub = cov[np.ix_(use, use)]
    sub = np.where(np.isfinite(sub), sub, 0.0)
    np.fill_diagonal(sub, d[use])
    inv, null = _pinv_standardised(0.5 * (sub + sub.T))
    prec[np.ix_(use, use)] = inv
    return prec, y, int(use.sum()) - null.shape[1]


def _fixed(
    precs: Sequence[np.ndarray], ys: Sequence[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, int]:
    """GLS value and covariance from the pieces' precisions, and the rank of their sum."""
    p = precs[0].shape[0]
    a = np.sum(precs, axis=0)
    b = np.sum([pi @ yi for pi, yi in zip(precs, ys, strict=True)], axis=0)
    informed = np.diag(a) > 0
    value = np.full(p, np.nan)
    cov = np.full((p, p), np.nan)
    if not informed.any():
        return value, cov, 0
    idx = np.ix_(informed, informed)
    inv, null = _pinv_standardised(a[idx])
    sub_val = inv @ b[informed]
    sub_cov = inv.copy()
    if null.shape[1]:  # a direction no piece informs: the parameters it involves are unknown
        loose = np.any(np.abs(null) > 1e-8, axis=1)
        sub_cov[loose, :] = np.nan
        sub_cov[:, loose] = np.nan
        sub_val[loose] = np.nan
    value[informed] = sub_val
    cov[idx] = sub_cov
    return value, cov, int(informed.sum()) - null.shape[1]


def _between_moments(
    ws: Sequence[np.ndarray], ys: Sequence[np.ndarray], mean: np.ndarray
) -> np.ndarray:
    """The between-piece covariance Ψ by the matrix method of moments (Jackson, White and
    Riley 2013; DerSimonian-Laird for one parameter): with W_i the pieces' precisions,
    A = Σ W_i and Q = Σ W_i (y_i - θ)(y_i - θ)ᵀ, E[Q] = (k - 1) I + (A - Σ W_i A⁻¹ W_i) Ψ,
    solved for Ψ, symmetrised and its negative eigenvalues set to 0."""
    k = len(ws)
    a = np.sum(ws, axis=0)
    a_inv = np.linalg.inv(a)
    q = np.sum([w @ np.outer(y - mean, y - mean) for w, y in zip(ws, ys, strict=True)], axis=0)
    d = a - np.sum([w @ a_inv @ w for w in ws], axis=0)
    psi = np.linalg.solve(d, q - (k - 1) * np.eye(len(mean)))
    psi = 0.5 * (psi + psi.T)
    lam, vec = np.linalg.eigh(psi)
    out: np.ndarray = (vec * np.maximum(lam, 0.0)) @ vec.T
    return out


def pool_gls(
    values: np.ndarray | Sequence[Sequence[float]],
    covs: np.ndarray | Sequence[Sequence[Sequence[float]]],
    *,
    alpha: float = 0.05,
    random: RandomEffects = "always",
) -> Pooled:
    """Pool k pieces' values (k, p) with their covariances (k, p, p) (see the module
    docstring).

    Raises:
        ValueError: shapes that do not match, or no piece.
    """
    vals = np.asarray(values, dtype=float)
    cvs = np.asarray(covs, dtype=float)
    if vals.ndim != 2 or vals.shape[0] == 0 or cvs.shape != (*vals.shape, vals.shape[1]):
        raise ValueError(
            f"pool_gls: values (k, p) and covariances (k, p, p) expected, got "
            f"{vals.shape} and {cvs.shape}"
        )
    p = vals.shape[1]
    pieces = [piece_precision(v, c) for v, c in zip(vals, cvs, strict=True)]
    precs = [pr for pr, _, _ in pieces]
    ys = [y for _, y, _ in pieces]
    fixed_value, fixed_cov, rank = _fixed(precs, ys)
    n_informing = np.array([sum(1 for pr in precs if pr[j, j] > 0) for j in range(p)])
    df = sum(r for _, _, r in pieces) - rank
    q, pval = _cochran_q(precs, ys, fixed_value, df)
    heterogeneous = bool(df > 0 and pval < alpha)
    apply = df > 0 and (random == "always" or (random == "auto" and heterogeneous))
    value, cov = fixed_value, fixed_cov
    inflation, tau2 = 1.0, math.nan
    between_full = np.full((p, p), math.nan)
    method = "single piece" if len(pieces) == 1 else "generalised least squares (fixed effect)"
    informed = np.isfinite(np.diag(fixed_cov))
    ni = int(informed.sum())
    idx = np.ix_(informed, informed)
    taking = [i for i, (pr, _, r) in enumerate(pieces) if r > 0]
    complete = df > 0 and all(
        pieces[i][2] == ni and bool(np.all(np.diag(pieces[i][0])[informed] > 0)) for i in taking
    )
    if complete:
        ws = [precs[i][idx] for i in taking]
        yv = [ys[i][informed] for i in taking]
        between = _between_moments(ws, yv, fixed_value[informed])
        between_full[idx] = between
        tau2 = float(between[0, 0]) if p == 1 else math.nan
        if apply and not np.any(between):
            method += ", the between-piece covariance estimated 0"
        elif apply:
            value, cov, inflation = _random_effects(
                ws, yv, between, fixed_value, fixed_cov, informed
            )
            method = (
                "random effects (DerSimonian-Laird)"
                if p == 1
                else "generalised least squares, random effects (multivariate "
                "DerSimonian-Laird between-piece covariance)"
            )
    elif apply:
        inflation = max(1.0, q / df)
        cov = fixed_cov * inflation
        method = f"generalised least squares, random effects (covariance x Q/df = {inflation:.3g})"
    return Pooled(
        value,
        cov,
        fixed_value,
        fixed_cov,
        n_informing,
        q,
        int(df),
        pval,
        heterogeneous,
        bool(apply),
        inflation,
        tau2,
        between_full,
        method,
    )


def _cochran_q(
    precs: Sequence[np.ndarray], ys: Sequence[np.ndarray], fixed_value: np.ndarray, df: int
) -> tuple[float, float]:
    """The generalised Cochran's Q of the pieces (precisions ``precs``, values ``ys``) about
    the fixed-effect value, and its p-value at ``df`` degrees of freedom (NaN, NaN: df 0)."""
    if df <= 0:
        return math.nan, math.nan
    fv = np.where(np.isfinite(fixed_value), fixed_value, 0.0)
    q = float(sum((y - fv) @ pr @ (y - fv) for pr, y in zip(precs, ys, strict=True)))
    return q, float(stats.chi2.sf(q, df))


def _random_effects(
    ws: Sequence[np.ndarray],
    yv: Sequence[np.ndarray],
    between: np.ndarray,
    fixed_value: np.ndarray,
    fixed_cov: np.ndarray,
    informed: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, float]:
    """The GLS value and covariance with weights (Σ_i + Ψ)⁻¹ over the ``informed``
    parameters (``ws``, ``yv``: the pieces' precisions and values there; ``between``: Ψ), the
    rest as the fixed effect left them, and the largest factor by which a variance widened."""
    idx = np.ix_(informed, informed)
    prec_re = [np.linalg.inv(np.linalg.inv(w) + between) for w in ws]
    sub_cov = np.linalg.inv(np.sum(prec_re, axis=0))
    sub_val = sub_cov @ np.sum([w @ y for w, y in zip(prec_re, yv, strict=True)], axis=0)
    value = fixed_value.copy()
    cov = fixed_cov.copy()
    value[informed] = sub_val
    cov[idx] = sub_cov
    return value, cov, float(np.max(np.diag(sub_cov) / np.diag(fixed_cov[idx])))


def pool_univariate(
    values: Sequence[float] | np.ndarray,
    stds: Sequence[float] | np.ndarray,
    *,
    alpha: float = 0.05,
    random: RandomEffects = "always",
) -> Pooled:
    """One parameter pooled over pieces by inverse-variance weighting (:func:`pool_gls` with
    p = 1): a piece without a finite positive std contributes nothing."""
    v = np.asarray(values, dtype=float).reshape(-1, 1)
    s = np.asarray(stds, dtype=float)
    return pool_gls(v, (s**2).reshape(-1, 1, 1), alpha=alpha, random=random)
