"""Model-mismatch discovery for the tractor-trailer.

Run the calibrated model on the recorded inputs, locate where it misses the recorded outputs,
name the physics that was left out from a catalogue of effects (greedy forward selection on
held-out blocks and BIC), fit it, and describe any structure that remains with a sparse
regression of the residual. ``discover`` is the entry point; frames in, result out.

Pipeline: ``data`` (arrays, 10 Hz fitting grid, noise levels, held-out blocks; the command
through its own samples) -> ``model`` (baseline + effects run on the recorded command and
speed) -> ``selection`` (greedy forward selection, rules in its docstring) -> ``confirm``
(each effect's 95 % interval must exclude its null value and removing it must worsen the
held-out RMS; equivalent explanations: one physical cause preferred to two within 10 BIC,
the other listed in ``alternatives``) -> the final joint fit (``joint_fit``: L1, L2 with
intervals and covariance from the model with the accepted effects) -> ``diagnostics``
(regions, bins, whiteness, cross-correlations) -> ``sparse`` (STLSQ on what is left).

Default baseline: the transient kinematics (``DEFAULT_BASELINE``); it named the effects of
more logs than the steady-state relation in bench/discovery_confusion_study.py and the
bundled field runs (12 of 12 against 11 of 12 with the hitch transient set aside).

Every step runs guarded: a log discovery cannot work on gives ``status`` "not_run" and the
reason, a step that fails is recorded in ``failures`` (``status`` "partial"); ``discover``
does not raise on data.

Delay or clock? ``actuator_delay`` moves the yaw rate and the joint angle together against the
command; ``clock_offset(odom)`` moves only the yaw rate (and speed), ``clock_offset(hitch)``
only the joint angle, the other output still lining up with the command. The same clock
offset on every measured topic moves both, exactly as a dead time would but for speed
changes within it: the dead time (one cause) is reported and the two offsets listed as its
alternative unless BIC separates them by more than 10. A command topic stamped late looks
exactly like an actuator delay and is reported as one.

Confounds of the link lengths (``confounds``): where the log does not tell two explanations
apart and they imply different L1, L2 or different corrections of the joint-angle sensor
(the dead time says the joint angle is on time, the two clock offsets that it is late; a
joint-angle gain that L1 + L2 absorb at small angles), the result lists both with the link
lengths each implies, and ``sensor_effects_for_fit(result)`` tells a fit of L1, L2 along the
measured path what it may take in and what it must span
(``calib.tractor_trailer.discovery.confounds``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal, TypeVar

import numpy as np
import polars as pl

from calib.discovery import Selection, Tried
from calib.discovery.sparse import SparseResidualModel, fit_sparse_residual
from calib.errors import CalibError
from calib.results import Estimate
from calib.tractor_trailer.discovery.confirm import (
    EQUIVALENCE_MARGIN,
    Confirmed,
    confirm_effects,
    effect_values,
)
from calib.tractor_trailer.discovery.confounds import (
    SensorEffectsForFit,
    SpanChoice,
    find_confounds,
    sensor_effects_for_fit,
)
from calib.tractor_trailer.discovery.data import DiscoveryData, prepare_data
from calib.tractor_trailer.discovery.diagnostics import (
    UNITS,
    MismatchRegion,
    binned_stats,
    command_types,
    cross_correlations,
    find_regions,
    ljung_box,
)
from calib.tractor_trailer.discovery.effects import Effect, catalogue
from calib.tractor_trailer.discovery.fit import (
    CommandFit,
    fit_model,
    holdout_rms,
    neff_factors,
    param_std,
)
from calib.tractor_trailer.discovery.model import BASE_PARAMS, ModelSpec, predict
from calib.tractor_trailer.discovery.result import (
    AlternativeExplanation,
    DiscoveryResult,
    EffectFit,
    ExplanationFit,
    JointFit,
    LengthConfound,
    SensorCorrections,
    StepFailure,
)
from calib.tractor_trailer.discovery.selection import (
    CommandRules,
    accepted_effects,
    select_effects,
    trial_record,
)
from calib.tractor_trailer.discovery.signals import INPUT_UNITS, delayed, input_signals
from calib.tractor_trailer.discovery.windows import (
    DEFAULT_MAX_SPAN_S,
    DataWindows,
    choose_windows,
    restrict,
)
from calib.tractor_trailer.results import Segment

__all__ = [
    "DEFAULT_BASELINE",
    "AlternativeExplanation",
    "CommandRules",
    "DiscoveryResult",
    "Effect",
    "EffectFit",
    "ExplanationFit",
    "JointFit",
    "LengthConfound",
    "MismatchRegion",
    "SensorCorrections",
    "SensorEffectsForFit",
    "SpanChoice",
    "SparseResidualModel",
    "StepFailure",
    "catalogue",
    "discover",
    "sensor_effects_for_fit",
]

# The baseline discovery compares against unless told otherwise: the transient kinematics named
# the effect in more logs than the steady-state relation (bench/discovery_confusion_study.py).
DEFAULT_BASELINE: Literal["steady", "transient"] = "transient"
LB_P_STRUCTURE = 1e-3
MIN_SPARSE_R2 = 0.2


def _effect_fit(
    effect: Effect, conf: Confirmed, data: DiscoveryData, alternatives: Sequence[str]
) -> EffectFit:
    """Parameters of ``effect`` in the final joint fit, with Fisher 95 % intervals (a time
    shift's include the time resolution / sqrt(12): the grid's period, or the command's where
    it jumps; ``DiscoveryData.time_resolution_s``), and its evidence."""
    final, cov = conf.final, conf.cov
    ev = conf.evidence[effect.key]
    estimates: dict[str, Estimate] = {}
    for p in effect.params:
        name = f"{effect.key}.{p.name}"
        v = float(final.theta[final.names.index(name)])
        sd = param_std(final, cov, name, p.time_shift, data.time_resolution_s)
        estimates[p.name] = Estimate(
            p.name,
            v,
            sd,
            (v - 1.96 * sd, v + 1.96 * sd),
            unit=p.unit,
            note="Gauss-Newton Fisher interval of the final joint fit",
        )
    pars = {k: e.value for k, e in estimates.items()}
    return EffectFit(
        id=effect.id,
        target=effect.target,
        estimates=estimates,
        channels=tuple(c for c in effect.channels if c in ev.rms_without),
        rms_before=dict(ev.rms_without),
        rms_after=dict(ev.rms_with),
        delta_bic=ev.delta_bic,
        explanation=effect.explanation(pars),
        alternatives=tuple(alternatives),
        kind=str(effect.spec.kind),
    )


def _round_candidates(sel: Selection | None) -> dict[str, list[str]]:
    """Per accepted effect, the candidates of its round that were material, significant
    (every parameter >= 3 standard errors from its null) and within ``EQUIVALENCE_MARGIN`` BIC
    units of it: the ones to try in its place at the end."""
    out: dict[str, list[str]] = {}
    for r in sel.rounds if sel is not None else ():
        acc = r.accepted
        if acc is None:
            continue
        out[acc.key] = [
            t.key
            for t in r.tried
            if t is not acc
            and t.key != acc.key
            and t.material
            and t.delta_bic <= acc.delta_bic + EQUIVALENCE_MARGIN
            and _significant(t, 3.0)
        ]
    return out


def _significant(t: Tried, min_z: float) -> bool:
    """Every parameter of the tried effect at least ``min_z`` standard errors from its null."""
    fit = t.fit
    spec = next((s for s in fit.effects if s.key == t.key), None) if fit is not None else None
    if fit is None or spec is None:
        return False
    return all(z >= min_z for z in fit.z_scores(spec).values())


def _joint_fit(conf: Confirmed, data: DiscoveryData, baseline: str) -> JointFit:
    final, cov = conf.final, conf.cov
    vals = {n: float(final.theta[i]) for i, n in enumerate(("L1", "L2"))}
    sd = {n: math.sqrt(max(float(cov[i, i]), 0.0)) for i, n in enumerate(("L1", "L2"))}
    sd = {n: (v if v > 0 and math.isfinite(v) else math.nan) for n, v in sd.items()}
    c2 = cov[:2, :2]
    return JointFit(
        baseline=baseline,
        effects=tuple(e.key for e in conf.effects),
        parameters=vals,
        std=sd,
        ci95={n: (vals[n] - 1.96 * sd[n], vals[n] + 1.96 * sd[n]) for n in vals},
        covariance=(
            (float(c2[0, 0]), float(c2[0, 1])),
            (float(c2[1, 0]), float(c2[1, 1])),
        ),
        effect_parameters=effect_values(final),
        n_samples=int(final.mask.sum()),
        fit_rate_hz=1.0 / float(np.median(np.diff(data.tc_s))),
    )


def _full_rate_residuals(data: DiscoveryData, before: CommandFit, after: CommandFit) -> dict:
    out: dict[str, np.ndarray] = {"t_ns": data.t_ns}
    for tag, f in (("before", before), ("after", after)):
        pred = predict(f.spec, f.theta, data, full_rate=True)
        for c in data.channels:
            out[f"{c}_{tag}"] = data.outputs[c][: pred[c].size] - pred[c]
    return out


def _diagnostics(
    data: DiscoveryData,
    base: CommandFit,
    final: CommandFit,
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
        "noise_std_fit": dict(data.sigma_d),
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
    data: DiscoveryData, final: CommandFit, inputs: dict[str, np.ndarray]
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


def _start_lengths(L1: float, L2: float) -> list[float]:
    """The calibrated link lengths as a starting point, inside the fit's bounds (1.0 m and
    2.0 m where they are not finite)."""
    lo1, lo2 = BASE_PARAMS[0], BASE_PARAMS[1]
    a = float(L1) if math.isfinite(L1) else 1.0
    b = float(L2) if math.isfinite(L2) and lo2.lower < L2 else 2.0
    return [min(max(a, lo1.lower + 0.01), lo1.upper - 0.01), min(b, lo2.upper - 0.01)]


def _reason(err: BaseException) -> str:
    text = str(err) or type(err).__name__
    return text if isinstance(err, CalibError) else f"{type(err).__name__}: {text}"


T = TypeVar("T")


def _step(name: str, failures: list[StepFailure], fn: Callable[[], T], default: T) -> T:
    """``fn()``, or ``default`` with the failure recorded: discovery reports what it could."""
    try:
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            return fn()
    except Exception as err:  # a failing step must not take the rest of the result with it
        failures.append(StepFailure(name, _reason(err)))
        return default


def _windows_of(frame: pl.DataFrame, max_span_s: float | None) -> DataWindows | None:
    """The windows of a frame longer than ``max_span_s`` (None: all of it)."""
    if "t_ns" not in frame.columns or frame.height < 2:
        return None
    t = frame.get_column("t_ns")
    lo, hi = t.min(), t.max()
    if not isinstance(lo, int) or not isinstance(hi, int):
        return None
    return choose_windows((hi - lo) / 1e9, max_span_s)


def discover(
    frame: pl.DataFrame,
    L1: float,
    L2: float,
    *,
    baseline: Literal["steady", "transient"] = DEFAULT_BASELINE,
    segments: list[Segment] | None = None,
    rng: np.random.Generator | None = None,
    rules: CommandRules | None = None,
    signals: Mapping[str, pl.DataFrame] | None = None,
    max_span_s: float | None = DEFAULT_MAX_SPAN_S,
) -> DiscoveryResult:
    """Locate, name and fit what the tractor-trailer model leaves out of a recording.

    Args:
        frame: aligned frame with ``t_ns`` and kappa_cmd (1/m), v (m/s), omega (rad/s) or
            kappa (1/m), psi (rad); other columns are ignored.
        L1, L2: calibrated link lengths (m), the starting point (they are refitted jointly
            with every candidate effect; L1 may be zero or negative).
        baseline: "transient" (default: the trailer's transient off-axle kinematics, which
            diagnoses best in bench/discovery_confusion_study.py) or "steady" (the patent's
            steady-state hitch relation).
        segments: command segments (times in s from the first row) for per-segment and
            per-command-type diagnostics.
        rng: unused; the procedure is deterministic (kept for a uniform estimator signature).
        rules: acceptance thresholds (defaults in ``CommandRules``).
        signals: optional raw logical signals (name -> ``t_ns``, ``value`` frames, as
            ``logtools``' ``ResolvedSignals.signals``): the command is then taken at its own
            samples (not as the aligned frame holds it) and each output's noise is measured on
            its own samples. Recommended whenever the topics have different rates.
        max_span_s: a log longer than this (s) is looked at through windows spread evenly
            over it, ``max_span_s`` in all (``calib.tractor_trailer.discovery.windows`` says why);
            None or 0
            looks at all of it. The result's ``windows`` says what was used.

    Never raises on short or odd data: a log discovery cannot work on gives ``status``
    "not_run" with the ``reason``; a step that fails is recorded in ``failures`` (``status``
    "partial") and the rest is reported.

    Raises:
        CalibError: ``baseline`` is neither "steady" nor "transient" (a usage error).
    """
    del rng
    if baseline not in ("steady", "transient"):
        raise CalibError(f"discovery: baseline must be 'steady' or 'transient', got {baseline!r}")
    rules = rules or CommandRules()
    failures: list[StepFailure] = []
    windows = _windows_of(frame, max_span_s)
    if windows is not None:
        frame, signals, segments = restrict(frame, signals, segments, windows)
    data = _step("prepare", failures, lambda: prepare_data(frame, signals), None)
    if data is None:
        return DiscoveryResult.not_run(baseline, failures)
    base_spec = ModelSpec(baseline)
    theta0 = _start_lengths(L1, L2)
    pool = catalogue(baseline, data.channels)
    base_train = _step(
        "baseline fit",
        failures,
        lambda: fit_model(base_spec, data, theta0, data.train_mask()),
        None,
    )
    if base_train is None:
        return DiscoveryResult.not_run(baseline, failures)
    selected = _step(
        "selection",
        failures,
        lambda: select_effects(data, base_spec, theta0, pool, rules),
        None,
    )
    sel, factors = selected if selected is not None else (None, neff_factors(base_train))
    acc_effects = accepted_effects(sel) if sel is not None else []
    train = sel.final.payload if sel is not None and acc_effects else base_train
    conf = _step(
        "confirmation",
        failures,
        lambda: confirm_effects(
            data, base_spec, acc_effects, train, pool, factors, rules, _round_candidates(sel)
        ),
        None,
    )
    if conf is None:  # fall back on the baseline alone: nothing confirmed, nothing reported
        conf = _step(
            "baseline joint fit",
            failures,
            lambda: confirm_effects(data, base_spec, [], base_train, pool, factors, rules),
            None,
        )
    alternatives = list(conf.alternatives) if conf is not None else []
    effects: list[EffectFit] = []
    joint = None
    confounds: list[LengthConfound] = []
    if conf is not None:
        effects = [
            _effect_fit(e, conf, data, [a.label for a in alternatives if e.key in a.reported])
            for e in conf.effects
        ]
        joint = _step("joint fit", failures, lambda: _joint_fit(conf, data, baseline), None)
        confounds = _step(
            "confounds", failures, lambda: find_confounds(data, base_spec, conf, pool), []
        )
    final_train = conf.train if conf is not None else base_train
    base = _step(
        "baseline full fit",
        failures,
        lambda: fit_model(base_spec, data, base_train.theta, data.valid, fine=True),
        base_train,
    )
    final = conf.final if conf is not None else base
    inputs = input_signals(data)
    types = command_types(data.tc_s, segments)
    regions: list[MismatchRegion] = _step(
        "regions", failures, lambda: find_regions(data, base.residuals, inputs, types), []
    )
    diag: dict[str, Any] = _step(
        "diagnostics",
        failures,
        lambda: _diagnostics(data, base, final, inputs, types, segments),
        {},
    )
    no_model: tuple[SparseResidualModel | None, list[dict[str, Any]]] = (None, [])
    residual_model, tried = _step(
        "residual model", failures, lambda: _sparse(data, final, inputs), no_model
    )
    diag["sparse_candidates"] = tried
    diag["neff_factor"] = factors
    no_dict: dict[str, float] = {}
    diag["neff_factor_final"] = _step("neff", failures, lambda: neff_factors(final), no_dict)
    diag["selection"] = [trial_record(r, data) for r in (sel.rounds if sel is not None else ())]
    if conf is not None:
        diag["confirmation"] = {
            "dropped": conf.dropped,
            "swaps": conf.swaps,
            "evidence": {
                k: {
                    "rms_without": ev.rms_without,
                    "rms_with": ev.rms_with,
                    "delta_bic": ev.delta_bic,
                    "ci95_excludes_null": ev.ci_excludes_null,
                    "improves_holdout": ev.improves_holdout,
                }
                for k, ev in conf.evidence.items()
            },
        }
    hold_base = holdout_rms(base_spec, base_train.theta, data, data.test_mask())
    rms_final = _step(
        "held-out RMS",
        failures,
        lambda: holdout_rms(final_train.spec, final_train.theta, data, data.test_mask()),
        no_dict,
    )
    no_res: dict[str, np.ndarray] = {}
    residuals = _step(
        "residuals", failures, lambda: _full_rate_residuals(data, base, final), no_res
    )
    return DiscoveryResult(
        baseline=baseline,
        regions=regions,
        effects=effects,
        rms_baseline=hold_base,
        residual_model=residual_model,
        diagnostics=diag,
        residuals=residuals,
        rms_final=rms_final,
        link_lengths={"L1": float(final.theta[0]), "L2": float(final.theta[1])},
        joint_fit=joint,
        alternatives=alternatives,
        confounds=confounds,
        status="partial" if failures else "ok",
        reason="; ".join(f"{f.step}: {f.reason}" for f in failures) or None,
        failures=failures,
        windows=windows,
    )
