"""The patent's 36 link-length methods: EMLS (6), PMLS (6) and CLS M1–M24 (Table 3).

Names (``METHOD_NAMES``):

- EMLS: ``OLS1(EM1)``, ``OLS1(EM2)``, ``OLS1(EM3)``, ``TLS(EM1)``, ``TLS(EM2)``, ``TLS(EM3)``.
  TLS is invariant to which column of [A y] is the output, so the three TLS rows carry the
  same (L1, L2) (the patent's "TLS(EM1,2,3)") but each its own condition number (Fig. 8).
- PMLS: ``OLS1(PM1)``, ``OLS2(PM1)``, ``TLS(PM1)``, ``OLS1(PM2)``, ``OLS2(PM2)``, ``TLS(PM2)``.
  No link lengths (L1, L2 are NaN); ``extra`` has the slope ``a`` (m, ≈ L1 + L2), the
  intercept ``b`` (rad, PM2) and, for OLS on PM1, the singular value ``mu1`` (the patent prints
  it instead of a condition number, which is then NaN).
- CLS ``M1``..``M24`` exactly as patent Table 3: fit the PM, replace the data by the PM's
  predictions, fit the EM on them. Predictions: Ψp = a κm + b paired with κm, and
  κp = (Ψm − b)/a paired with Ψm; both sets (2p points, all on the fitted line) go into the
  EM step. ``condition_number`` is the EM step's (EM1's for TLS(EM1,2,3), all three in
  ``extra`` as ``cn_EM1``..``cn_EM3``); ``extra`` also has the PM step's ``a`` and ``b``.

Speed: the p-long data are reduced once by a QR to a 7 x 7 factor of the base columns
[sin Ψ, κ cos Ψ, κ, 1, Ψ, Ψ cos Ψ, cos Ψ] (see ``calib.lsq.base``); the EM factor
([sin Ψ, κ cos Ψ, κ]), the PM factor ([κ, 1, Ψ]) and the measured-Ψ half of every CLS data set
are column combinations of it, and every model is a signed column selection of a factor. So
the 12 EMLS/PMLS fits cost one QR, and each of the 6 PM fits is reused by its 4 CLS methods
(one QR of its p predicted-angle rows each, in compiled code: ``predicted_rows``).

Bootstrap resamples (``ResampledData``) repeat rows: each distinct row enters once, scaled by
the square root of its multiplicity (same Gram matrix, so the same results up to rounding),
and the base factor is assembled from factors of fixed chunks of the data computed once.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike

from calib.errors import SolverError
from calib.lsq import OLS1, OLS2, TLS, LeastSquares, triangular_factor, triangular_factor_by_rows
from calib.lsq.base import block_factors
from calib.results import JsonRecord
from calib.tractor_trailer.patent_models import (
    EXACT_MODELS,
    PREDICTION_MODELS,
    ExactModel,
    PredictionModel,
    check_excitation,
    check_variation,
    lengths_from_beta,
)
from calib.tractor_trailer.predicted_rows import predicted_rows_factor
from calib.tractor_trailer.results import Family

__all__ = [
    "CLS_ROWS",
    "CLS_TABLE",
    "METHOD_NAMES",
    "Family",
    "MethodEstimate",
    "MethodSpec",
    "ResampledData",
    "evaluate_methods",
    "family_of",
    "method_spec",
]

_SOLVERS: dict[str, type[LeastSquares]] = {"OLS1": OLS1, "OLS2": OLS2, "TLS": TLS}


@dataclass(frozen=True)
class MethodSpec:
    """What a method name means.

    Attributes:
        name: e.g. "OLS1(EM2)", "TLS(PM1)", "M17".
        family: EMLS, PMLS or CLS.
        pm_solver, pm: the prediction-model step (PMLS, CLS), else None.
        em_solver, em: the exact-model step (EMLS, CLS); ``em`` None means TLS(EM1,2,3).
    """

    name: str
    family: Family
    pm_solver: str | None = None
    pm: PredictionModel | None = None
    em_solver: str | None = None
    em: ExactModel | None = None

    @property
    def description(self) -> str:
        """Human-readable composition, e.g. "OLS2(PM1) + OLS1(EM1)"."""
        em = "" if self.em_solver is None else f"{self.em_solver}({self.em or 'EM1,2,3'})"
        pm = "" if self.pm_solver is None else f"{self.pm_solver}({self.pm})"
        return " + ".join(s for s in (pm, em) if s)


_PM1, _PM2 = PredictionModel.PM1, PredictionModel.PM2
_EM1, _EM2, _EM3 = ExactModel.EM1, ExactModel.EM2, ExactModel.EM3

#: Patent Table 3, one row per CLS method: name, PM step (solver, model), EM step (solver,
#: model; None is TLS(EM1,2,3)). M1–M12 use PM2, M13–M24 PM1.
CLS_ROWS: tuple[tuple[str, str, PredictionModel, str, ExactModel | None], ...] = (
    ("M1", "OLS1", _PM2, "OLS1", _EM1),
    ("M2", "OLS1", _PM2, "OLS1", _EM2),
    ("M3", "OLS1", _PM2, "OLS1", _EM3),
    ("M4", "OLS1", _PM2, "TLS", None),
    ("M5", "OLS2", _PM2, "OLS1", _EM1),
    ("M6", "OLS2", _PM2, "OLS1", _EM2),
    ("M7", "OLS2", _PM2, "OLS1", _EM3),
    ("M8", "OLS2", _PM2, "TLS", None),
    ("M9", "TLS", _PM2, "OLS1", _EM1),
    ("M10", "TLS", _PM2, "OLS1", _EM2),
    ("M11", "TLS", _PM2, "OLS1", _EM3),
    ("M12", "TLS", _PM2, "TLS", None),
    ("M13", "OLS1", _PM1, "OLS1", _EM1),
    ("M14", "OLS1", _PM1, "OLS1", _EM2),
    ("M15", "OLS1", _PM1, "OLS1", _EM3),
    ("M16", "OLS1", _PM1, "TLS", None),
    ("M17", "OLS2", _PM1, "OLS1", _EM1),
    ("M18", "OLS2", _PM1, "OLS1", _EM2),
    ("M19", "OLS2", _PM1, "OLS1", _EM3),
    ("M20", "OLS2", _PM1, "TLS", None),
    ("M21", "TLS", _PM1, "OLS1", _EM1),
    ("M22", "TLS", _PM1, "OLS1", _EM2),
    ("M23", "TLS", _PM1, "OLS1", _EM3),
    ("M24", "TLS", _PM1, "TLS", None),
)

CLS_TABLE: dict[str, MethodSpec] = {
    name: MethodSpec(name, Family.CLS, pm_solver, pm, em_solver, em)
    for name, pm_solver, pm, em_solver, em in CLS_ROWS
}

_SPECS: dict[str, MethodSpec] = {}
for _solver in ("OLS1", "TLS"):
    for _em in ExactModel:
        _n = f"{_solver}({_em})"
        _SPECS[_n] = MethodSpec(_n, Family.EMLS, em_solver=_solver, em=_em)
for _pm in (PredictionModel.PM1, PredictionModel.PM2):
    for _solver in ("OLS1", "OLS2", "TLS"):
        _n = f"{_solver}({_pm})"
        _SPECS[_n] = MethodSpec(_n, Family.PMLS, pm_solver=_solver, pm=_pm)
_SPECS.update(CLS_TABLE)

METHOD_NAMES: tuple[str, ...] = tuple(_SPECS)


def method_spec(name: str) -> MethodSpec:
    """The ``MethodSpec`` of a method name.

    Raises:
        ValueError: unknown name (the message lists the valid ones).
    """
    try:
        return _SPECS[name]
    except KeyError:
        raise ValueError(
            f"unknown method {name!r}; expected one of {', '.join(METHOD_NAMES)}"
        ) from None


def family_of(name: str) -> Family:
    """ "EMLS" | "PMLS" | "CLS" for a method name."""
    return method_spec(name).family


@dataclass(frozen=True)
class MethodEstimate(JsonRecord):
    """One method on one data set.

    Attributes:
        name, family: see ``METHOD_NAMES``.
        L1, L2: link lengths (m); NaN for PMLS or when the solve failed.
        condition_number: the method's (NaN where the patent prints "-").
        extra: ``a`` (m), ``b`` (rad), ``mu1``, ``cn_EM1``..``cn_EM3``, ``failed`` (1.0).
    """

    name: str
    family: Family
    L1: float
    L2: float
    condition_number: float
    extra: dict[str, float] = field(default_factory=dict)
    failed: bool = False


_NAN = math.nan
_T = TypeVar("_T")


class _Evaluator:
    """Caches the factors and PM fits shared between methods on one data set.

    One QR of the base columns B = [sin Ψ, κ cos Ψ, κ, 1, Ψ, Ψ cos Ψ, cos Ψ] serves the EM
    factor (its first three columns), the PM factor ([κ, 1, Ψ]) and the Ψm half of every CLS
    data set: with κp = (Ψm − b)/a, the rows [sin Ψm, κp cos Ψm, κp] are B times a 7 x 3
    matrix of 1, 1/a and −b/a, so their factor is R_B times that matrix. Only the κm half
    (Ψp = a κm + b, new angles for each PM fit) is factored afresh; the two halves' factors are
    stacked and reduced (same column algebra as one QR of the 2p rows, see ``calib.lsq.base``).

    A resample that repeats rows is given as its distinct rows, each row of every factored
    matrix scaled by ``weights`` (the square root of its multiplicity m): m copies of a row r
    add m rᵀr to the Gram matrix, as the one row √m r does, so every factor, and every
    least-squares and TLS result computed from it, is that of the repeated rows up to
    rounding. ``n`` is then the resample's size (the number of rows it stands for).
    """

    def __init__(
        self,
        kappa: np.ndarray,
        psi: np.ndarray,
        *,
        n: int | None = None,
        weights: np.ndarray | None = None,
        base: np.ndarray | None = None,
    ) -> None:
        self.kappa, self.psi, self.weights = kappa, psi, weights
        self.rows = kappa.size
        self.n = self.rows if n is None else n
        self.kappa_max = float(np.max(np.abs(kappa)))
        self._base = base
        self._pm_factor: np.ndarray | None = None
        self._pm_fits: dict[tuple[str, PredictionModel], LeastSquares] = {}
        self._cls_factors: dict[tuple[str, PredictionModel], tuple[np.ndarray, int]] = {}

    def base_factor(self) -> np.ndarray:
        """7 x 7 R of B = [sin Ψ, κ cos Ψ, κ, 1, Ψ, Ψ cos Ψ, cos Ψ]."""
        if self._base is None:
            self._base = triangular_factor_by_rows(self.rows, 7, self._base_rows)
        return self._base

    def _base_rows(self, start: int, stop: int, out: np.ndarray) -> None:
        w = None if self.weights is None else self.weights[start:stop]
        _fill_base_rows(self.kappa[start:stop], self.psi[start:stop], out, w)

    def em_factor(self) -> np.ndarray:
        # the R of a leading block of columns is the leading block of R
        return self.base_factor()[:3, :3]

    def pm_fit(self, solver: str, pm: PredictionModel) -> LeastSquares:
        key = (solver, pm)
        if key not in self._pm_fits:
            if self._pm_factor is None:
                self._pm_factor = triangular_factor(self.base_factor()[:5, [2, 3, 4]])
            M = PREDICTION_MODELS[pm].select(self._pm_factor)
            self._pm_fits[key] = _SOLVERS[solver]().fit_factor(M, self.n)
        return self._pm_fits[key]

    def cls_factor(self, solver: str, pm: PredictionModel) -> tuple[np.ndarray, int]:
        key = (solver, pm)
        if key not in self._cls_factors:
            a, b = _line(self.pm_fit(solver, pm), pm)
            if not (math.isfinite(a) and a != 0.0 and math.isfinite(b)):
                raise SolverError(f"{solver}({pm}): slope a = {a} cannot predict curvature")
            # κm half: [sin Ψp, κm cos Ψp, κm] with Ψp = a κm + b
            first = predicted_rows_factor(self.kappa, a, b, self.weights, kappa_max=self.kappa_max)
            # Ψm half: B columns [sin Ψ, Ψ cos Ψ, cos Ψ, Ψ, 1] times T
            T = np.array(
                [
                    [1.0, 0.0, 0.0],
                    [0.0, 1 / a, 0.0],
                    [0.0, -b / a, 0.0],
                    [0.0, 0.0, 1 / a],
                    [0.0, 0.0, -b / a],
                ]
            )
            second = self.base_factor()[:, [0, 5, 6, 4, 3]] @ T
            factor = triangular_factor(np.vstack([first, second]))
            self._cls_factors[key] = (factor, 2 * self.n)
        return self._cls_factors[key]


def _fill_base_rows(
    kappa: np.ndarray, psi: np.ndarray, out: np.ndarray, weights: np.ndarray | None = None
) -> None:
    """Write the base rows [sin Ψ, κ cos Ψ, κ, 1, Ψ, Ψ cos Ψ, cos Ψ] (each scaled by its
    weight, if given) into ``out`` (p x 7)."""
    np.cos(psi, out=out[:, 6])
    np.sin(psi, out=out[:, 0])
    np.multiply(kappa, out[:, 6], out=out[:, 1])
    out[:, 2] = kappa
    out[:, 3] = 1.0
    out[:, 4] = psi
    np.multiply(psi, out[:, 6], out=out[:, 5])
    if weights is not None:
        out *= weights[:, None]


_CHUNK = 256  # rows per stored base factor of ``ResampledData``


class ResampledData:
    """One (κ, Ψ) data set prepared for evaluating the methods on many resamples of its rows.

    A resample is given by the multiplicity of each row (``counts``), as a bootstrap draws
    them. The data enter the methods twice: through the 7 x 7 base factor (EMLS, PMLS, and
    the Ψm half of CLS) and through the κm half of each CLS data set, whose angles depend on
    the resample's PM fits. For the first, the base factor of every chunk of 256 consecutive
    rows is computed once here; a resample's base factor is then the factor of the stacked
    chunk factors of the chunks it repeats uniformly (each scaled by √m), plus the weighted
    rows of the few chunks whose multiplicity changes inside them (a block bootstrap draws
    long runs of consecutive rows, so these are few). For the second, the CLS rows are built
    only for the rows the resample contains, each scaled by √m (see ``_Evaluator``). Results
    equal ``evaluate_methods`` on the repeated rows up to rounding.
    """

    def __init__(self, kappa: ArrayLike, psi: ArrayLike) -> None:
        self.kappa, self.psi = check_excitation(kappa, psi)
        self.size = self.kappa.size

        def fill(start: int, stop: int, out: np.ndarray) -> None:
            _fill_base_rows(self.kappa[start:stop], self.psi[start:stop], out)

        self._chunk_factors = block_factors(self.size, 7, _CHUNK, fill)

    def evaluate(
        self, counts: ArrayLike, names: Iterable[str] | None = None
    ) -> dict[str, MethodEstimate]:
        """The methods on the resample that holds row i ``counts[i]`` times.

        Args:
            counts: non-negative integer multiplicity of each row, shape (size,).
            names: methods (default all of ``METHOD_NAMES``), in the order returned.

        Returns:
            As ``evaluate_methods`` on the resample's rows.

        Raises:
            InsufficientDataError: the resample has fewer than 3 rows or no excitation.
            ValueError: ``counts`` of the wrong shape or negative; an unknown method name.
        """
        c = np.asarray(counts)
        if c.shape != (self.size,) or not np.issubdtype(c.dtype, np.integer) or c.min() < 0:
            raise ValueError(
                f"counts must be {self.size} non-negative integers; got {c.dtype} {c.shape}"
            )
        rows = np.flatnonzero(c)
        k, p = self.kappa[rows], self.psi[rows]
        n = int(c.sum())
        check_variation(k, p, n)
        weights = np.sqrt(c[rows].astype(np.float64))
        ev = _Evaluator(k, p, n=n, weights=weights, base=self._base_factor(c))
        return _evaluate_all(ev, names)

    def _base_factor(self, counts: np.ndarray) -> np.ndarray:
        n_chunks = self._chunk_factors.shape[0]
        per_chunk = np.zeros(n_chunks * _CHUNK, dtype=counts.dtype)
        per_chunk[: self.size] = counts
        per_chunk = per_chunk.reshape(n_chunks, _CHUNK)
        first = per_chunk[:, 0]
        uniform = np.all(per_chunk == first[:, None], axis=1)
        whole = np.flatnonzero(uniform & (first > 0))
        stacked = (
            self._chunk_factors[whole] * np.sqrt(first[whole].astype(np.float64))[:, None, None]
        )
        mixed = np.flatnonzero(~uniform)
        idx = (mixed[:, None] * _CHUNK + np.arange(_CHUNK)).ravel()
        idx = idx[idx < self.size]
        idx = idx[counts[idx] > 0]
        rows = np.empty((idx.size, 7))
        weights = np.sqrt(counts[idx].astype(np.float64))
        _fill_base_rows(self.kappa[idx], self.psi[idx], rows, weights)
        return triangular_factor(np.vstack([stacked.reshape(-1, 7), rows]))


def _line(fit: LeastSquares, pm: PredictionModel) -> tuple[float, float]:
    beta = fit.beta_
    return float(beta[0]), float(beta[1]) if pm is PredictionModel.PM2 else 0.0


def _em_step(
    factor: np.ndarray, n: int, solver: str, em: ExactModel | None
) -> tuple[float, float, float, dict[str, float]]:
    """(L1, L2, condition number, extra) of an EM fit from the factor of D."""
    if em is not None:
        fit = _SOLVERS[solver]().fit_factor(EXACT_MODELS[em].select(factor), n)
        L1, L2 = lengths_from_beta(em, fit.beta_)
        return L1, L2, fit.condition_number_, {}
    fits = {m: TLS().fit_factor(EXACT_MODELS[m].select(factor), n) for m in ExactModel}
    L1, L2 = lengths_from_beta(ExactModel.EM1, fits[ExactModel.EM1].beta_)
    extra = {f"cn_{m}": f.condition_number_ for m, f in fits.items()}
    return L1, L2, fits[ExactModel.EM1].condition_number_, extra


def _evaluate_one(ev: _Evaluator, spec: MethodSpec) -> MethodEstimate:
    fam = spec.family
    if spec.family is Family.EMLS:
        em_solver = _required(spec.em_solver, spec)
        L1, L2, cn, extra = _em_step(ev.em_factor(), ev.n, em_solver, spec.em)
        return MethodEstimate(spec.name, fam, L1, L2, cn, extra)
    pm_solver, pm = _required(spec.pm_solver, spec), _required(spec.pm, spec)
    fit = ev.pm_fit(pm_solver, pm)
    a, b = _line(fit, pm)
    pm_extra = {"a": a, "b": b} if pm is PredictionModel.PM2 else {"a": a}
    if spec.family is Family.PMLS:
        cn = fit.condition_number_
        if pm is PredictionModel.PM1 and pm_solver != "TLS":
            pm_extra["mu1"] = cn
            cn = _NAN
        return MethodEstimate(spec.name, fam, _NAN, _NAN, cn, pm_extra)
    factor, n = ev.cls_factor(pm_solver, pm)
    L1, L2, cn, extra = _em_step(factor, n, _required(spec.em_solver, spec), spec.em)
    return MethodEstimate(spec.name, fam, L1, L2, cn, {**pm_extra, **extra})


def _required(step: _T | None, spec: MethodSpec) -> _T:
    """A step of ``spec`` its family requires (the tables above always set it)."""
    if step is None:
        raise AssertionError(f"{spec.name}: the {spec.family} method lacks a step")
    return step


def evaluate_methods(
    kappa: ArrayLike, psi: ArrayLike, names: Iterable[str] | None = None
) -> dict[str, MethodEstimate]:
    """Run the patent's methods on one data set.

    Args:
        kappa: path curvature at the front wheel, 1/m, shape (p,).
        psi: joint angle, rad, shape (p,).
        names: methods to run (default all of ``METHOD_NAMES``), in the order returned.

    Returns:
        name -> ``MethodEstimate``. A method whose solve fails numerically (e.g. a singular TLS
        problem) gets NaN values and ``failed`` True.

    Raises:
        InsufficientDataError: fewer than 3 samples, non-finite data, or no excitation.
        ValueError: an unknown method name.
    """
    k, p = check_excitation(kappa, psi)
    return _evaluate_all(_Evaluator(k, p), names)


def _evaluate_all(ev: _Evaluator, names: Iterable[str] | None) -> dict[str, MethodEstimate]:
    specs = [method_spec(n) for n in (METHOD_NAMES if names is None else names)]
    out: dict[str, MethodEstimate] = {}
    for spec in specs:
        try:
            out[spec.name] = _evaluate_one(ev, spec)
        except SolverError:
            out[spec.name] = MethodEstimate(spec.name, spec.family, _NAN, _NAN, _NAN, failed=True)
    return out
