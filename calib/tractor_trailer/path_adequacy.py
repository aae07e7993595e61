"""Adequacy of the tractor-trailer's path fit: its joint-angle residual as a
:class:`calib.adequacy.ResidualChannel` (with a held-out residual from block cross-validation,
the noise the path carries in, the encoder's quantum, speed / curvature / angle covariates and
the command segments), and the recommended estimate's intervals under a misfit.

Held-out residual: the log's time span is cut into ``FOLDS x BLOCKS_PER_FOLD`` consecutive
blocks, block j belonging to fold j mod ``FOLDS``; each fold is fitted without its samples
(the simulation still runs through them along the measured path) and predicted, so every
sample is held out once.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from calib.adequacy import Adequacy, NoiseFloor, ResidualChannel, noise_floor, under_misfit
from calib.discovery import EffectSpec
from calib.results import CalibrationResult
from calib.tractor_trailer.derived import derived_sum, link_sum
from calib.tractor_trailer.estimators.path_transient import PathTransientFit
from calib.tractor_trailer.path_effects import JointPathModel, JointSolution

__all__ = [
    "BLOCKS_PER_FOLD",
    "DISCRETISATION_RAD",
    "FOLDS",
    "covariates",
    "estimate_under_misfit",
    "heldout_residual",
    "input_std",
    "psi_channel",
    "psi_floor",
    "unexplained_text",
]

FOLDS = 5
BLOCKS_PER_FOLD = 4
INITIAL_SAMPLES = 3
DISCRETISATION_RAD = 1e-3
"""What stamp jitter and the path's discretisation leave in the residual of a clean log (the
same 1 mrad the path fit's expected RMS never goes below)."""


def input_std(fit: PathTransientFit | None) -> float:
    """Noise the measured path carries into the modelled joint angle (rad): the pose noise the
    fit knows of, and the path's discretisation."""
    direct = float(getattr(fit, "_direct_var", 0.0) or 0.0) if fit is not None else 0.0
    return math.sqrt(max(direct, 0.0) + DISCRETISATION_RAD**2)


def heldout_residual(
    model: JointPathModel,
    effects: tuple[EffectSpec, ...],
    x: np.ndarray,
    *,
    folds: int = FOLDS,
    blocks_per_fold: int = BLOCKS_PER_FOLD,
) -> np.ndarray:
    """Each sample's residual when its fold was left out of the fit (started from ``x``)."""
    t = model.t
    out = np.full(t.size, np.nan)
    edges = np.linspace(t[0], t[-1], folds * blocks_per_fold + 1)
    block = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, edges.size - 2)
    fold = block % folds
    # each piece's first samples are never held out: they set its initial angle, a nuisance
    # the held-out blocks after them are predicted from (not fitted to)
    rank = np.arange(t.size) - model.first_idx[model.piece]
    start = rank < INITIAL_SAMPLES
    for k in range(folds):
        held = (fold == k) & ~start
        if not held.any() or held.all():
            continue
        sol = model.fit(effects, x, held_out=held, max_nfev=30)
        # a piece without a fitted sample has no initial angle: nothing to predict it from
        trained = np.bincount(model.piece[~held], minlength=model.n_pieces) >= 3
        use = held & trained[model.piece]
        out[use] = sol.residual[use]
    return out


def covariates(model: JointPathModel) -> dict[str, np.ndarray]:
    """Speed, |curvature| of link 1's path and the joint angle at the joint-angle samples."""
    t = model.t
    dt = 0.05
    s0, th0 = model.path.at(t - dt)
    s1, th1 = model.path.at(t + dt)
    ds = s1 - s0
    speed = np.abs(ds) / (2 * dt)
    with np.errstate(divide="ignore", invalid="ignore"):
        curv = np.where(np.abs(ds) > 1e-3, np.abs((th1 - th0) / ds), np.nan)
    return {"speed (m/s)": speed, "|curvature| (1/m)": curv, "psi (rad)": model.p}


def psi_floor(
    model: JointPathModel, residual: np.ndarray, *, quantum: float, input_std_rad: float
) -> NoiseFloor:
    """The joint angle's noise floor from the residual's own high-frequency content."""
    return noise_floor(
        model.t, residual, measured=model.p, quantum=quantum, input_std=input_std_rad
    )


def psi_channel(
    model: JointPathModel,
    sol: JointSolution,
    heldout: np.ndarray | None,
    *,
    quantum: float,
    input_std_rad: float,
    segments: Sequence[tuple[str, float, float]] = (),
) -> ResidualChannel:
    """The joint-angle residual channel of one joint fit."""
    return ResidualChannel(
        "psi",
        "rad",
        model.t,
        sol.residual,
        heldout=heldout,
        measured=model.p,
        quantum=quantum,
        input_std=input_std_rad,
        covariates=covariates(model),
        segments=tuple(segments),
    )


def unexplained_text(adequacy: Adequacy) -> str | None:
    """What no catalogued effect explains, in words (None when the model explains)."""
    if adequacy.explains or not adequacy.channels:
        return None
    worst = max(adequacy.channels, key=lambda c: c.judged_ratio)
    where = [loc.label for loc in adequacy.located[:3]]
    return (
        f"the joint angle's residual stays {worst.judged_ratio:.2g}x its noise floor with "
        f"{adequacy.model}" + (f", concentrated at {'; '.join(where)}" if where else "")
    )


def estimate_under_misfit(
    estimate: CalibrationResult,
    adequacy: Adequacy,
    pieces: Mapping[str, Sequence[float]] | None = None,
) -> CalibrationResult:
    """``estimate`` (a path fit) as a misfit allows: L1, L2 and L1 + L2 through
    :func:`calib.adequacy.under_misfit` (widened by the misfit factor and the spread over
    ``pieces``, not determined), the verdict saying why. Unchanged while the model explains."""
    from dataclasses import replace

    if adequacy.explains or not adequacy.channels:
        return estimate
    pieces = pieces or {}
    params = {
        k: under_misfit(e, adequacy, pieces=pieces.get(k, ()))
        for k, e in estimate.parameters.items()
    }
    total = link_sum(estimate)
    if total is not None:
        total = under_misfit(total, adequacy, pieces=pieces.get("L1+L2", ()))
    worst = max(adequacy.channels, key=lambda c: c.judged_ratio)
    fitted = ", ".join(f"{k} = {e.value:.3f} m" for k, e in estimate.parameters.items())
    where = ", ".join(loc.label for loc in adequacy.located[:2])
    verdict = (
        f"Not determined: the model ({adequacy.model}) does not explain this log (the joint "
        f"angle's residual is {worst.judged_ratio:.2g}x its noise floor"
        + (f"; {where}" if where else "")
        + "), so an interval conditional on that model "
        f"means nothing. The fit says {fitted}"
        + (f", L1 + L2 = {total.value:.3f} m" if total is not None else "")
        + f"; the intervals shown are widened x{adequacy.misfit_factor:.2g}"
        + (" and by the spread over parts of the log" if pieces else "")
        + ", not a calibrated 95 %."
    )
    return replace(
        estimate,
        parameters=params,
        derived=derived_sum(total, estimate.derived),
        verdict=verdict,
        details={
            **estimate.details,
            "adequacy_verdict": adequacy.verdict,
            "misfit_factor": adequacy.misfit_factor,
        },
    )
