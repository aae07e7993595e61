"""The patent's linear models of the two-link robot (KR 10-1481896, Tables 1 and 2).

Exact models (EM, linear in β, from sin Ψ − κ (L2 + L1 cos Ψ) = 0), built from the columns
D = [sin Ψ, κ cos Ψ, κ]:

| model | β             | y        | η1      | η2        |
|-------|---------------|----------|---------|-----------|
| EM1   | [L1, L2]      | sin Ψ    | κ cos Ψ | κ         |
| EM2   | [1/L1, L2/L1] | κ cos Ψ  | sin Ψ   | −κ        |
| EM3   | [1/L2, L1/L2] | κ        | sin Ψ   | −κ cos Ψ  |

Prediction models (PM) on the columns P = [κ, 1, Ψ]: PM2 Ψ = a κ + b, PM1 Ψ = a κ.

Each model is a column selection (with signs) of D or P, so a square factor of D (or P) serves
all models at once (see ``calib.lsq.base``). κ in 1/m, Ψ in rad, lengths in m.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from calib.errors import InsufficientDataError

__all__ = [
    "EXACT_MODELS",
    "PREDICTION_MODELS",
    "ExactModel",
    "ModelColumns",
    "PredictionModel",
    "check_excitation",
    "check_variation",
    "em_columns",
    "em_design",
    "lengths_from_beta",
    "pm_columns",
    "pm_design",
]

FloatArray = NDArray[np.float64]


class ExactModel(StrEnum):
    """The three linear exact models of patent Table 1."""

    EM1 = "EM1"
    EM2 = "EM2"
    EM3 = "EM3"


class PredictionModel(StrEnum):
    """The two prediction models of patent Table 2."""

    PM1 = "PM1"
    PM2 = "PM2"


@dataclass(frozen=True)
class ModelColumns:
    """A linear model as signed columns of a base matrix: A = base[:, cols] * signs, y = base[:, y].

    Attributes:
        columns: indices of the regressor columns in the base matrix.
        signs: sign applied to each regressor column.
        y: index of the output column.
    """

    columns: tuple[int, ...]
    signs: tuple[float, ...]
    y: int

    def select(self, base: FloatArray) -> FloatArray:
        """[A y] from the base matrix (or from a square factor of it: same column algebra)."""
        cols = [*self.columns, self.y]
        scale = np.array([*self.signs, 1.0])
        return base[:, cols] * scale


# D = [sin Ψ, κ cos Ψ, κ]
EXACT_MODELS: dict[ExactModel, ModelColumns] = {
    ExactModel.EM1: ModelColumns((1, 2), (1.0, 1.0), 0),
    ExactModel.EM2: ModelColumns((0, 2), (1.0, -1.0), 1),
    ExactModel.EM3: ModelColumns((0, 1), (1.0, -1.0), 2),
}
# P = [κ, 1, Ψ]
PREDICTION_MODELS: dict[PredictionModel, ModelColumns] = {
    PredictionModel.PM2: ModelColumns((0, 1), (1.0, 1.0), 2),
    PredictionModel.PM1: ModelColumns((0,), (1.0,), 2),
}


def check_excitation(kappa: ArrayLike, psi: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Validate (κ, Ψ) for the link-length models; return them as float arrays.

    Raises:
        InsufficientDataError: shapes differ, fewer than 3 samples, non-finite values, or κ or Ψ
            do not vary (a single steady state cannot separate the unknowns).
    """
    k = np.asarray(kappa, dtype=float).ravel()
    p = np.asarray(psi, dtype=float).ravel()
    if k.shape != p.shape:
        raise InsufficientDataError(
            f"kappa ({k.size} samples) and psi ({p.size} samples) must have the same length"
        )
    if k.size < 3:
        raise _too_few(k.size)
    if not (np.all(np.isfinite(k)) and np.all(np.isfinite(p))):
        raise InsufficientDataError("kappa and psi must be finite (NaN or inf found)")
    check_variation(k, p, k.size)
    return k, p


def _too_few(n: int) -> InsufficientDataError:
    return InsufficientDataError(
        f"{n} (kappa, psi) samples: need at least 3 for two unknowns plus a residual"
    )


def check_variation(kappa: FloatArray, psi: FloatArray, n_samples: int) -> None:
    """The sample-count and excitation checks of ``check_excitation`` on finite (κ, Ψ) that may
    stand for more samples than they hold (the distinct rows of a resample, ``n_samples`` in
    all): what varies is the same with or without the repeats.

    Raises:
        InsufficientDataError: fewer than 3 samples, or κ or Ψ do not vary.
    """
    if n_samples < 3 or kappa.size == 0:
        raise _too_few(n_samples)
    for name, x in (("kappa", kappa), ("psi", psi)):
        scale = max(float(np.max(np.abs(x))), 1e-300)
        if np.ptp(x) <= 1e-9 * scale or scale <= 1e-12:
            raise InsufficientDataError(
                f"{name} does not vary (range {np.ptp(x):.3g}): the log has no curvature "
                "excitation; need turns of at least two different curvatures"
            )


def em_columns(kappa: ArrayLike, psi: ArrayLike, out: FloatArray | None = None) -> FloatArray:
    """Base matrix D = [sin Ψ, κ cos Ψ, κ] (p x 3) of the exact models (written into ``out``,
    shape (p, 3), when given)."""
    k = np.asarray(kappa, dtype=float)
    p = np.asarray(psi, dtype=float)
    k, p = np.broadcast_arrays(k, p)
    if out is None:
        out = np.empty((*p.shape, 3))
    np.sin(p, out=out[..., 0])
    np.cos(p, out=out[..., 1])
    out[..., 1] *= k
    out[..., 2] = k
    return out


def pm_columns(kappa: ArrayLike, psi: ArrayLike) -> FloatArray:
    """Base matrix P = [κ, 1, Ψ] (p x 3) of the prediction models."""
    k = np.asarray(kappa, dtype=float)
    return np.column_stack([k, np.ones_like(k), np.asarray(psi, dtype=float)])


def em_design(
    model: ExactModel | str, kappa: ArrayLike, psi: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """(A, y) of exact model ``model`` for data (κ 1/m, Ψ rad)."""
    c = EXACT_MODELS[ExactModel(model)].select(em_columns(kappa, psi))
    return c[:, :-1], c[:, -1]


def pm_design(
    model: PredictionModel | str, kappa: ArrayLike, psi: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """(A, y) of prediction model ``model`` for data (κ 1/m, Ψ rad)."""
    c = PREDICTION_MODELS[PredictionModel(model)].select(pm_columns(kappa, psi))
    return c[:, :-1], c[:, -1]


def lengths_from_beta(model: ExactModel | str, beta: ArrayLike) -> tuple[float, float]:
    """Link lengths (L1, L2) in m from an exact model's β (NaN where β gives no length)."""
    b = np.asarray(beta, dtype=float)
    m = ExactModel(model)
    if m is ExactModel.EM1:
        return float(b[0]), float(b[1])
    if b[0] == 0.0:
        return float("nan"), float("nan")
    if m is ExactModel.EM2:
        return float(1.0 / b[0]), float(b[1] / b[0])
    return float(b[1] / b[0]), float(1.0 / b[0])
