"""Sparse regression of a residual on a library of candidate terms (STLSQ), with ensembling.

Sequentially thresholded least squares (Brunton et al. 2016, pysindy's ``STLSQ``): solve least
squares, zero the terms whose standardised contribution is below a threshold, refit on the rest,
repeat. :func:`fit_sparse_residual` chooses the threshold on held-out blocks (the sparsest
model within 0.02 of the best held-out R^2) and describes what a residual follows.
:func:`select_terms` is the residual model's screen (:mod:`calib.discovery.residual_model`): the
threshold chosen by cross-validation over the held-out folds, then the terms kept that an
ensemble of fits on resampled blocks of the training data selects in most of its members
(pysindy's ``EnsembleOptimizer`` with bagging; Fasel et al. 2022), so that a term one lucky
stretch of the log favours does not pass for physics.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.results import json_safe

__all__ = [
    "SparseResidualModel",
    "SparseTerm",
    "TermSelection",
    "fit_sparse_residual",
    "select_terms",
    "stlsq",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

THRESHOLDS: tuple[float, ...] = (0.02, 0.05, 0.1, 0.2, 0.3, 0.5)


def _ridge(x: FloatArray, y: FloatArray, alpha: float) -> FloatArray:
    """Ridge solution with the penalty on columns scaled to unit RMS (stable when collinear)."""
    scale = np.sqrt(np.mean(x * x, axis=0))
    scale = np.where(scale > 0, scale, 1.0)
    xs = x / scale
    a = xs.T @ xs + alpha * x.shape[0] * np.eye(x.shape[1])
    return np.linalg.solve(a, xs.T @ y) / scale


def stlsq(
    x: FloatArray, y: FloatArray, threshold: float, max_iter: int = 10, alpha: float = 1e-3
) -> FloatArray:
    """Coefficients of y ~ x with every |coef_j| std(x_j) / std(y) < ``threshold`` zeroed.

    Each solve is a light ridge regression (``alpha`` per sample on unit-RMS columns) so that
    nearly collinear library terms do not get huge opposite gains. Columns with zero spread
    (a constant) are never thresholded.
    """
    sx = x.std(axis=0)
    sy = float(np.std(y)) or 1.0
    active = np.ones(x.shape[1], dtype=bool)
    coef = np.zeros(x.shape[1])
    for _ in range(max_iter):
        coef = np.zeros(x.shape[1])
        if active.any():
            coef[active] = _ridge(x[:, active], y, alpha)
        small = (np.abs(coef) * sx / sy < threshold) & (sx > 0)
        new_active = active & ~small
        if np.array_equal(new_active, active):
            break
        active = new_active
    return coef


@dataclass(frozen=True)
class SparseTerm:
    """One selected library term: residual ~ gain * term; ``share`` its standardised weight."""

    name: str
    gain: float
    unit: str
    share: float

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {"name": self.name, "gain": self.gain, "unit": self.unit, "share": self.share}
        )


@dataclass(frozen=True)
class SparseResidualModel:
    """What the residual of one output still follows after the best augmented model.

    ``r2_holdout``: fraction of the held-out residual variance the terms explain;
    ``ljung_box_p``: whiteness p-value of the residual before this regression.
    """

    channel: str
    terms: list[SparseTerm]
    r2_holdout: float
    ljung_box_p: float
    threshold: float
    extra: Mapping[str, Any] = field(default_factory=dict)

    def describe(self) -> str:
        parts = [f"{t.name} with gain {t.gain:.4g} {t.unit}" for t in self.terms]
        return (
            f"unexplained {self.channel} residual follows {' + '.join(parts)} "
            f"({100 * self.r2_holdout:.0f} % of the held-out residual variance)"
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "channel": self.channel,
                "terms": [t.to_dict() for t in self.terms],
                "r2_holdout": self.r2_holdout,
                "ljung_box_p": self.ljung_box_p,
                "threshold": self.threshold,
                "description": self.describe(),
            }
        )


def fit_sparse_residual(
    channel: str,
    residual: FloatArray,
    library: Mapping[str, FloatArray],
    units: Mapping[str, str],
    train: BoolArray,
    test: BoolArray,
    ljung_box_p: float,
    thresholds: Sequence[float] = THRESHOLDS,
) -> SparseResidualModel | None:
    """STLSQ of ``residual`` on ``library`` (name -> column), threshold chosen on ``test``.

    Returns None when no term survives. ``units`` maps each term to the gain's unit.
    """
    names = list(library)
    x = np.column_stack([library[k] for k in names])
    fits = []
    for thr in thresholds:
        coef = stlsq(x[train], residual[train], thr)
        pred = x[test] @ coef
        ss = float(np.sum((residual[test] - residual[test].mean()) ** 2)) or 1.0
        r2 = 1.0 - float(np.sum((residual[test] - pred) ** 2)) / ss
        fits.append((thr, coef, r2, int(np.count_nonzero(coef))))
    best_r2 = max(f[2] for f in fits)
    good = [f for f in fits if f[2] >= best_r2 - 0.02 and f[3] > 0]
    if not good:
        return None
    thr, coef, r2, _ = min(good, key=lambda f: (f[3], -f[2]))
    sx = x[train].std(axis=0)
    sy = float(np.std(residual[train])) or 1.0
    weights = np.abs(coef) * sx / sy
    terms = [
        SparseTerm(names[j], float(coef[j]), units[names[j]], float(weights[j]))
        for j in np.argsort(-weights)
        if coef[j] != 0
    ]
    return SparseResidualModel(channel, terms, r2, ljung_box_p, thr)


INCLUSION = 0.6
"""A term is kept when at least this share of the ensemble's members select it."""
ENSEMBLE = 24
"""Members of the ensemble (fits on resampled blocks)."""
SCREEN_THRESHOLDS: tuple[float, ...] = (0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3)


@dataclass(frozen=True)
class TermSelection:
    """The screen's choice: column indices ``kept`` with their ensemble mean coefficients
    ``coef`` and inclusion shares; the threshold chosen and the cross-validated residual sum of
    squares of the chosen model against none (``cv_sse``, ``cv_sse_none``)."""

    kept: tuple[int, ...]
    coef: tuple[float, ...]
    inclusion: tuple[float, ...]
    threshold: float
    cv_sse: float
    cv_sse_none: float


def _cv_sse(x: FloatArray, y: FloatArray, folds: NDArray[np.intp], threshold: float) -> float:
    """Sum of squared held-out errors over the folds (each fold predicted by the others)."""
    total = 0.0
    for f in np.unique(folds[folds >= 0]):
        tr, te = (folds >= 0) & (folds != f), folds == f
        if tr.sum() < x.shape[1] + 2 or not te.any():
            continue
        coef = stlsq(x[tr], y[tr], threshold)
        total += float(np.sum((y[te] - x[te] @ coef) ** 2))
    return total


def _blocks(n: int, size: int) -> list[NDArray[np.intp]]:
    starts = range(0, n, size)
    return [np.arange(a, min(a + size, n), dtype=np.intp) for a in starts]


def select_terms(
    x: FloatArray,
    y: FloatArray,
    folds: NDArray[np.intp],
    *,
    thresholds: Sequence[float] = SCREEN_THRESHOLDS,
    members: int = ENSEMBLE,
    block: int = 50,
    seed: int = 0,
) -> TermSelection | None:
    """The terms (columns of ``x``) that model ``y``: the threshold with the least
    cross-validated error over ``folds`` (the sparsest within one standard error of it), then
    the terms that at least ``INCLUSION`` of ``members`` bagged fits (blocks of ``block``
    consecutive samples drawn with replacement) select at that threshold. None when no term is
    kept or the cross-validated error does not fall below the model without terms."""
    ok = np.all(np.isfinite(x), axis=1) & np.isfinite(y)
    x, y, folds = x[ok], y[ok], folds[ok]
    if x.shape[0] < 2 * max(x.shape[1], 5):
        return None
    none = float(np.sum(y[folds >= 0] ** 2))
    scores = [(thr, _cv_sse(x, y, folds, thr)) for thr in thresholds]
    best = min(s for _, s in scores)
    se = math.sqrt(2.0 / max(int((folds >= 0).sum()), 1)) * best
    thr = max(t for t, s in scores if s <= best + se)
    cv = dict(scores)[thr]
    if not cv < none:
        return None
    rng = np.random.default_rng(seed)
    blocks = _blocks(x.shape[0], block)
    picks = np.zeros(x.shape[1])
    coefs = np.zeros(x.shape[1])
    for _ in range(members):
        rows = np.concatenate([blocks[i] for i in rng.integers(0, len(blocks), len(blocks))])
        c = stlsq(x[rows], y[rows], thr)
        picks += c != 0
        coefs += c
    share = picks / members
    kept = tuple(int(j) for j in np.flatnonzero(share >= INCLUSION))
    if not kept:
        return None
    mean = coefs / np.maximum(picks, 1)
    return TermSelection(
        kept,
        tuple(float(mean[j]) for j in kept),
        tuple(float(share[j]) for j in kept),
        float(thr),
        cv,
        none,
    )
