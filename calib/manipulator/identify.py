"""Identify an arm from a joint log: the pipeline from arrays to estimates with intervals,
excitation quality, held-out torque prediction and parameter trajectories.

The log is split in time: the first ``train_fraction`` (60 %) identifies, the rest is predicted
(torque from the classic form with the filtered acceleration, interpolated onto the log's own
time stamps and compared there with the torque as logged). The reported estimate is then
refitted on the whole log. Methods: momentum-integral batch WLS (the recommended one: no
acceleration), acceleration-regressor batch WLS, and the paper's estimator and RLS over the
momentum windows (their intervals are the batch OLS interval on the same rows, since a recursive
estimator ends at that solution).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from calib.errors import InsufficientDataError
from calib.manipulator.design import Design, Term, make_design
from calib.manipulator.estimators import WLSResult, batch_wls, paper_estimator, rls
from calib.manipulator.feasibility import Feasibility, check_feasibility
from calib.manipulator.model import ArmModel
from calib.manipulator.rows import Regressors, compute_regressors
from calib.manipulator.signals import JointSignals, prepare_signals
from calib.results import CalibrationResult, Estimate, as_matrix

__all__ = [
    "ArmIdentification",
    "Holdout",
    "IdentifyConfig",
    "at_stamps",
    "cutoff_shifts",
    "fit_holdout",
    "identify_arm",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class IdentifyConfig:
    """Choices of the identification (defaults are the documented ones)."""

    terms: tuple[Term, ...] = (Term.COULOMB, Term.VISCOUS)
    cutoff_hz: float = 10.0
    window_s: float = 0.1
    train_fraction: float = 0.6
    max_rate_hz: float = 250.0
    fixed_rigid: Array | None = None
    """Fix the rigid body at these (full) parameters and fit only the terms (nominal baseline)."""


@dataclass(frozen=True)
class Holdout:
    """Held-out torque prediction at the logged stamps: per-joint RMS of the error and of the
    torque (N*m), the pooled ratio (error RMS / torque RMS over all joints), and the arrays for
    plotting."""

    rms: Array
    torque_rms: Array
    ratio: float
    t_s: Array
    measured: Array
    predicted: Array

    @property
    def pooled_rms(self) -> float:
        return float(np.sqrt(np.mean(self.rms**2)))


@dataclass(frozen=True)
class ArmIdentification:
    """Everything the identification found (see the module docstring)."""

    design: Design
    sig: JointSignals
    methods: list[CalibrationResult]
    recommended: CalibrationResult
    wls: WLSResult
    condition_number: float
    holdout: Holdout
    feasibility: Feasibility
    trajectory_t: Array
    trajectory: dict[str, Array]
    notes: list[str] = field(default_factory=list)


def _estimates(
    design: Design, theta: Array, std: Array, ident: Array, note: str = ""
) -> dict[str, Estimate]:
    out: dict[str, Estimate] = {}
    for k, (name, unit) in enumerate(zip(design.names, design.units, strict=True)):
        ok = bool(ident[k]) and np.isfinite(std[k]) and np.isfinite(theta[k])
        s = float(std[k]) if ok else float("nan")
        v = float(theta[k]) if np.isfinite(theta[k]) else float("nan")
        why = note if ok else "regressor column nearly a combination of the others on this log"
        out[name] = Estimate(
            name,
            v,
            s,
            (v - 1.96 * s, v + 1.96 * s) if ok else (float("nan"), float("nan")),
            identifiable=ok,
            unit=unit,
            note=why,
        )
    return out


def _result(
    method: str,
    design: Design,
    theta: Array,
    w: WLSResult,
    verdict: str,
    note: str = "",
    details: dict[str, object] | None = None,
) -> CalibrationResult:
    est = _estimates(design, theta, w.std, w.identifiable, note)
    # the HAC covariance over the parameters this log determines (NaN rows where it does not,
    # as their standard errors are)
    ok = np.array([e.identifiable for e in est.values()], dtype=bool)
    return CalibrationResult(
        method=method,
        parameters=est,
        verdict=verdict,
        covariance=as_matrix(np.where(np.outer(ok, ok), w.cov, np.nan)),
        converged=bool(np.all(np.isfinite(theta[w.identifiable]))),
        details=details or {},
    )


def fit_holdout(reg: Regressors, config: IdentifyConfig) -> tuple[WLSResult, Holdout]:
    """Momentum WLS on the first ``train_fraction`` of ``reg``, torque predicted on the rest."""
    N = len(reg.sig)
    cut = round(config.train_fraction * N)
    if cut < 20 or N - cut < 20:
        raise InsufficientDataError(f"{N} samples are too few to split 60/40")
    X, u, _ = reg.momentum_windows(0, cut, config.window_s)
    if X.shape[-1] == 0:  # a nominal model with nothing left to fit
        e = np.zeros(0)
        w = WLSResult(e, np.zeros((0, 0)), e, e.astype(bool), e, np.ones(u.shape[1]), 0, 1.0, u)
    else:
        w = batch_wls(X, u)
    t_s, meas, pred = at_stamps(reg.sig, reg.predict(w.theta, cut, N), cut)
    err = pred - meas
    rms = np.sqrt(np.mean(err**2, axis=0))
    trms = np.sqrt(np.mean(meas**2, axis=0))
    ratio = float(np.sqrt(np.sum(err**2)) / max(np.sqrt(np.sum(meas**2)), 1e-300))
    return w, Holdout(rms, trms, ratio, t_s, meas, pred)


def at_stamps(sig: JointSignals, pred: Array, start: int) -> tuple[Array, Array, Array]:
    """(stamps, logged torque, predicted torque) on the logged samples inside the grid samples
    ``[start, start + len(pred))`` that ``pred`` covers: the prediction is interpolated onto the
    log's own stamps (module :mod:`calib.manipulator.signals`); without raw samples, the grid's."""
    grid = sig.t_s[start : start + len(pred)]
    if sig.raw_t_s is None or sig.raw_tau is None:
        return grid, sig.tau[start : start + len(pred)], pred
    inside = (sig.raw_t_s >= grid[0]) & (sig.raw_t_s <= grid[-1])
    t = sig.raw_t_s[inside]
    at = np.stack([np.interp(t, grid, pred[:, j]) for j in range(pred.shape[1])], axis=1)
    return t, sig.raw_tau[inside], at


CUTOFF_FACTORS = (0.5, 2.0)
"""The cut-offs :func:`cutoff_shifts` refits at, as factors of the chosen one."""


def cutoff_shifts(
    design: Design,
    t_s: Array,
    q: Array,
    tau: Array,
    config: IdentifyConfig,
    reference: Array,
    *,
    qd: Array | None = None,
) -> Array:
    """Per base parameter, how far the momentum-WLS estimate moves from ``reference`` when the
    signals are filtered at half and twice the cut-off (root sum of squares; 0 where a refit
    fails). The filter is applied to torque and motion alike, which keeps linear terms
    consistent but not the nonlinear ones (a Coulomb step filtered is not the Coulomb term of
    the filtered velocity), so the estimate depends on the cut-off by more than its
    model-conditional interval: that dependence is a systematic uncertainty of the estimate."""
    sq = np.zeros(len(design.names))
    for factor in CUTOFF_FACTORS:
        try:
            sig = prepare_signals(
                t_s,
                q,
                tau,
                cutoff_hz=factor * config.cutoff_hz,
                max_rate_hz=config.max_rate_hz,
                qd=qd,
            )
            X, u, _ = compute_regressors(design, sig).momentum_windows(0, len(sig), config.window_s)
            th = batch_wls(X, u).theta
        except (InsufficientDataError, np.linalg.LinAlgError, ValueError):
            continue
        d = np.where(np.isfinite(th) & np.isfinite(reference), th - reference, 0.0)
        sq += d**2
    out: Array = np.sqrt(sq)
    return out


def identify_arm(
    model: ArmModel,
    t_s: Array,
    q: Array,
    tau: Array,
    config: IdentifyConfig | None = None,
    *,
    qd: Array | None = None,
    progress: Callable[[str], None] | None = None,
) -> ArmIdentification:
    """Identify ``model``'s base parameters from a joint log.

    Args:
        model: the arm (planar 2-link or a URDF arm).
        t_s: (N,) times (s). q: (N, n) positions. tau: (N, n) torques (N*m; N for prismatic).
        config: choices; default :class:`IdentifyConfig`.
        qd: use this velocity instead of differentiating q (simulation studies).
        progress: called with a short message per step.

    Raises:
        InsufficientDataError: too little data for the windows or the split.
    """
    cfg = config or IdentifyConfig()
    say = progress or (lambda _m: None)
    lo_hi = model.limits() if hasattr(model, "limits") else None
    design = make_design(
        model,
        cfg.terms,
        rigid=cfg.fixed_rigid is None,
        fixed_rigid=cfg.fixed_rigid,
        q_range=lo_hi,
    )
    say("filtering joint signals")
    sig = prepare_signals(t_s, q, tau, cutoff_hz=cfg.cutoff_hz, max_rate_hz=cfg.max_rate_hz, qd=qd)
    say(f"regressors ({len(sig)} samples, {len(design.base)} base parameters)")
    reg = compute_regressors(design, sig)
    N = len(sig)
    _, holdout = fit_holdout(reg, cfg)
    X, u, t_end = reg.momentum_windows(0, N, cfg.window_s)
    wls = batch_wls(X, u)
    Xa, ya = reg.classic_rows(0, N)
    wls_a = batch_wls(Xa, ya)
    ols = batch_wls(X, u, weights=np.ones(X.shape[1]))
    say("recursive estimators")
    # recursive estimators in scaled columns (unit RMS per column): with tens of parameters of
    # very different magnitudes, P0 = 1000 I in raw units loses positive definiteness
    col = np.sqrt(np.mean(X.reshape(-1, X.shape[-1]) ** 2, axis=0))
    col[col == 0] = 1.0
    traj_rls = rls(X / col, u)[0] / col
    traj_paper = paper_estimator(X / col, u) / col
    feas = check_feasibility(design, wls.theta, wls.std, sig.q)
    feas_txt = (
        "physically feasible" if feas.feasible else "NOT feasible: " + "; ".join(feas.problems)
    )
    n_id = int(wls.identifiable.sum())
    verdict = (
        f"{n_id} of {len(wls.theta)} base parameters determined by this log "
        f"(condition number {wls.condition_number:.3g}); {feas_txt}; held-out torque error "
        f"{100 * holdout.ratio:.1f} % of the torque RMS."
    )
    ols_note = "interval of the batch OLS on the same momentum windows"
    methods = [
        _result(
            "momentum-WLS",
            design,
            wls.theta,
            wls,
            verdict,
            details={"newey_west_lag": wls.lag, "window_s": cfg.window_s},
        ),
        _result(
            "acceleration-WLS",
            design,
            wls_a.theta,
            wls_a,
            f"classic regressor with q'' from a {cfg.cutoff_hz:g} Hz zero-phase filter "
            f"(condition number {wls_a.condition_number:.3g})",
            details={"newey_west_lag": wls_a.lag, "condition_number": wls_a.condition_number},
        ),
        _result(
            "paper-constrained",
            design,
            traj_paper[-1],
            ols,
            "JKROS 2012 minimum-change estimator over the momentum windows",
            ols_note,
        ),
        _result(
            "RLS",
            design,
            traj_rls[-1],
            ols,
            "recursive least squares (P0 = 1000 I) over the momentum windows",
            ols_note,
        ),
    ]
    notes = []
    if not feas.feasible:
        notes.append(
            "identified parameters are not physically feasible: " + "; ".join(feas.problems)
        )
    traj = {"momentum-RLS": traj_rls, "paper-constrained": traj_paper}
    return ArmIdentification(
        design,
        sig,
        methods,
        methods[0],
        wls,
        wls.condition_number,
        holdout,
        feas,
        t_end,
        traj,
        notes,
    )
