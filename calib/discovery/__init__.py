"""Model-mismatch discovery for the tractor-trailer.

Run the calibrated model on the recorded inputs, locate where it misses the recorded outputs,
name the physics that was left out from a catalogue of effects (greedy forward selection on
held-out blocks and BIC), fit it, and describe any structure that remains with a sparse
regression of the residual. ``discover`` is the entry point; frames in, result out.

Pipeline: ``data`` (arrays, 10 Hz fitting grid, noise levels, held-out blocks) -> ``model``
(baseline + effects run on the recorded command and speed) -> ``selection`` (greedy forward
selection, rules in its docstring) -> final fit with intervals -> ``diagnostics`` (regions,
bins, whiteness, cross-correlations) -> ``sparse`` (STLSQ on what is left).

Delay or clock? ``actuator_delay`` moves the yaw rate and the joint angle together against the
command; ``clock_offset(odom)`` moves only the yaw rate (and speed), ``clock_offset(hitch)``
only the joint angle, the other output still lining up with the command. Both are candidates
and the data choose; a command topic stamped late looks exactly like an actuator delay and is
reported as one.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
import polars as pl

from calib.discovery.data import DiscoveryData, prepare_data
from calib.discovery.diagnostics import (
    UNITS,
    MismatchRegion,
    binned_stats,
    command_types,
    cross_correlations,
    find_regions,
    ljung_box,
)
from calib.discovery.effects import Effect, catalogue
from calib.discovery.fit import ModelFit, covariance, fit_model, holdout_rms, neff_factors
from calib.discovery.model import ModelSpec, predict
from calib.discovery.result import DiscoveryResult, EffectFit
from calib.discovery.selection import SelectionRules, SelectionStep, select_effects
from calib.discovery.signals import INPUT_UNITS, delayed, input_signals
from calib.discovery.sparse import SparseResidualModel, fit_sparse_residual
from calib.errors import CalibError
from calib.results import Segment

__all__ = [
    "DiscoveryResult",
    "Effect",
    "EffectFit",
    "MismatchRegion",
    "SelectionRules",
    "SparseResidualModel",
    "catalogue",
    "discover",
]

LB_P_STRUCTURE = 1e-3
MIN_SPARSE_R2 = 0.2


def _effect_fit(
    effect: Effect, step: SelectionStep, final: ModelFit, cov: np.ndarray, dt_s: float
) -> EffectFit:
    """Parameters of ``effect`` in the final fit, with Fisher 95 % intervals, and its evidence.

    Time shifts add the sampling resolution dt / sqrt(12) in quadrature to their error.
    """
    assert step.accepted is not None
    names = final.names
    pars, std, ci, units = {}, {}, {}, {}
    for p in effect.params:
        i = names.index(f"{effect.key}.{p.name}")
        v = float(final.theta[i])
        var = max(float(cov[i, i]), 0.0) + (dt_s**2 / 12.0 if p.time_shift else 0.0)
        sd = math.sqrt(var) if var > 0 else math.nan
        pars[p.name], std[p.name], units[p.name] = v, sd, p.unit
        ci[p.name] = (v - 1.96 * sd, v + 1.96 * sd)
    return EffectFit(
        id=effect.id,
        target=effect.target,
        parameters=pars,
        std=std,
        ci95=ci,
        units=units,
        channels=tuple(c for c in effect.channels if c in step.holdout_before),
        rms_before=dict(step.holdout_before),
        rms_after=dict(step.accepted.holdout),
        delta_bic=step.accepted.delta_bic,
        explanation=effect.explanation(pars),
        alternatives=tuple(
            t.effect.key
            for t in step.trials
            if t is not step.accepted
            and t.effect is not effect
            and t.material
            and t.delta_bic <= step.accepted.delta_bic + 10.0
            and all(z >= 3.0 for z in t.z.values())
        ),
    )


def _full_rate_residuals(data: DiscoveryData, before: ModelFit, after: ModelFit) -> dict:
    out: dict[str, np.ndarray] = {"t_ns": data.t_ns}
    for tag, f in (("before", before), ("after", after)):
        pred = predict(f.spec, f.theta, data, full_rate=True)
        for c in data.channels:
            out[f"{c}_{tag}"] = data.outputs[c][: pred[c].size] - pred[c]
    return out


def _diagnostics(
    data: DiscoveryData,
    base: ModelFit,
    final: ModelFit,
    inputs: dict[str, np.ndarray],
    types: list[str],
    segments: Sequence[Segment] | None,
) -> dict[str, Any]:
    valid = data.valid
    res = base.residuals
    dt = float(np.median(np.diff(data.tc_s)))
    abs_k = np.abs(inputs["kappa_cmd"])
    abs_dk = np.abs(inputs["dkappa_cmd/ds"])
    deriv_inputs = {k: v for k, v in inputs.items() if k != "v*kappa_cmd"}
    diag: dict[str, Any] = {
        "noise_std": dict(data.sigma),
        "fit_rate_hz": 1.0 / dt,
        "bins": {
            "speed": binned_stats(res, inputs["v"], mask=valid),
            "abs_kappa": binned_stats(res, abs_k, mask=valid),
            "abs_dkappa_ds": binned_stats(res, abs_dk, mask=valid),
            "command_type": binned_stats(res, types, mask=valid),
        },
        "ljung_box": {
            tag: {
                c: dict(zip(("Q", "p"), ljung_box(f.residuals[c][valid]), strict=True))
                for c in data.channels
            }
            for tag, f in (("baseline", base), ("final", final))
        },
        "cross_correlation": {
            c: cross_correlations(res[c][valid], {k: v[valid] for k, v in deriv_inputs.items()}, dt)
            for c in data.channels
        },
    }
    w = max(2, round(5.0 / dt))
    diag["windows"] = [
        {
            "start_s": float(data.tc_s[i]),
            "end_s": float(data.tc_s[min(i + w, data.n_fit) - 1]),
            **{
                c: float(np.sqrt(np.mean(res[c][i : i + w][valid[i : i + w]] ** 2)))
                for c in data.channels
            },
        }
        for i in range(0, data.n_fit, w)
        if valid[i : i + w].any()
    ]
    if segments:
        per_seg = []
        for i, seg in enumerate(segments):
            sel = valid & (data.tc_s >= seg.start_s) & (data.tc_s < seg.end_s)
            if sel.any():
                row: dict[str, Any] = {"segment": i, "command_type": str(seg.command_type)}
                row.update({c: float(np.sqrt(np.mean(res[c][sel] ** 2))) for c in data.channels})
                per_seg.append(row)
        diag["segments"] = per_seg
    return diag


def _sparse(
    data: DiscoveryData, final: ModelFit, inputs: dict[str, np.ndarray]
) -> tuple[SparseResidualModel | None, list[dict[str, Any]]]:
    """STLSQ on each output's final residual that is not white; the best one if it explains
    at least ``MIN_SPARSE_R2`` of the held-out residual variance."""
    pred = predict(final.spec, final.theta, data)
    library = dict(inputs)
    library["kappa_cmd(t-0.5s)"] = delayed(data, inputs["kappa_cmd"], 0.5)
    if "psi" in pred:  # the modelled yaw rate is left out: it is v * kappa_cmd again
        library["psi_model"] = pred["psi"]
    library["1"] = np.ones(data.n_fit)
    term_units = dict(INPUT_UNITS)
    term_units.update({"kappa_cmd(t-0.5s)": "1/m", "psi_model": "rad", "1": ""})
    tried, best = [], None
    for c in data.channels:
        r = final.residuals[c]
        _, p = ljung_box(r[data.valid])
        if p >= LB_P_STRUCTURE:
            continue
        units = {k: f"({UNITS[c]})/({u})" if u else UNITS[c] for k, u in term_units.items()}
        m = fit_sparse_residual(
            c, r, library, units, data.train_mask(), data.test_mask(), ljung_box_p=p
        )
        if m is None:
            continue
        tried.append(m.to_dict())
        if m.r2_holdout >= MIN_SPARSE_R2 and (best is None or m.r2_holdout > best.r2_holdout):
            best = m
    return best, tried


def discover(
    frame: pl.DataFrame,
    L1: float,
    L2: float,
    *,
    baseline: Literal["steady", "transient"] = "steady",
    segments: list[Segment] | None = None,
    rng: np.random.Generator | None = None,
    rules: SelectionRules | None = None,
) -> DiscoveryResult:
    """Locate, name and fit what the tractor-trailer model leaves out of a recording.

    Args:
        frame: aligned frame with ``t_ns`` and kappa_cmd (1/m), v (m/s), omega (rad/s) or
            kappa (1/m), psi (rad); other columns are ignored.
        L1, L2: calibrated link lengths (m), the starting point (they are refitted jointly
            with every candidate effect).
        baseline: "steady" (the patent's steady-state hitch relation) or "transient".
        segments: command segments (times in s from the first row) for per-segment and
            per-command-type diagnostics.
        rng: unused; the procedure is deterministic (kept for a uniform estimator signature).
        rules: acceptance thresholds (defaults in ``SelectionRules``).

    Raises:
        InsufficientDataError: missing columns or too little data.
    """
    del rng
    if baseline not in ("steady", "transient"):
        raise CalibError(f"discovery: baseline must be 'steady' or 'transient', got {baseline!r}")
    data = prepare_data(frame)
    base_spec = ModelSpec(baseline)
    steps, factors = select_effects(
        data, base_spec, [L1, L2], catalogue(baseline, data.channels), rules
    )
    accepted = [s for s in steps if s.accepted is not None]
    last_train = accepted[-1].accepted.fit if accepted else steps[0].before  # type: ignore[union-attr]
    final = fit_model(last_train.spec, data, last_train.theta, data.valid, fine=True)
    base = fit_model(base_spec, data, steps[0].before.theta, data.valid, fine=True)
    cov = covariance(final, data)
    dt_full = float(np.median(np.diff(data.t_s)))
    effects = [_effect_fit(s.accepted.effect, s, final, cov, dt_full) for s in accepted]  # type: ignore[union-attr]
    inputs = input_signals(data)
    types = command_types(data.tc_s, segments)
    regions = find_regions(data, base.residuals, inputs, types)
    diag = _diagnostics(data, base, final, inputs, types, segments)
    residual_model, tried = _sparse(data, final, inputs)
    diag["sparse_candidates"] = tried
    diag["neff_factor"] = factors
    diag["neff_factor_final"] = neff_factors(final)
    diag["selection"] = [
        {
            "holdout_before": s.holdout_before,
            "trials": [t.to_dict() for t in s.trials],
            "accepted": None if s.accepted is None else s.accepted.effect.key,
        }
        for s in steps
    ]
    return DiscoveryResult(
        baseline=baseline,
        regions=regions,
        effects=effects,
        rms_baseline=steps[0].holdout_before,
        residual_model=residual_model,
        diagnostics=diag,
        residuals=_full_rate_residuals(data, base, final),
        rms_final=holdout_rms(last_train.spec, last_train.theta, data, data.test_mask()),
        link_lengths={"L1": float(final.theta[0]), "L2": float(final.theta[1])},
    )
