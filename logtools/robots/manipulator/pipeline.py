"""Serial-arm analysis of one log: joints and model from the log, identification, discovery
and the refit with the discovered terms.

Imported on first analysis (not by the plugin declaration in ``__init__``): it pulls in
:mod:`calib.manipulator` (scipy; pinocchio for URDF models), which resolving a log's signals
never needs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from calib.adequacy import NOT_EXPLAINED, Adequacy
from calib.discovery import DiscoveryReport
from calib.errors import CalibError
from calib.manipulator.adequacy import (
    assess_arm,
    effect_spread,
    find_change,
    piece_fits,
    scaled_by_pieces,
    spanned,
    stabilised,
    widened,
    with_shifts,
)
from calib.manipulator.design import Term
from calib.manipulator.discovery import ArmDiscovery, ArmFitter, arm_catalogue, run_discovery
from calib.manipulator.explain import arm_discovery_report, described_alternative
from calib.manipulator.identify import (
    ArmIdentification,
    IdentifyConfig,
    cutoff_shifts,
    identify_arm,
)
from calib.manipulator.model import ArmModel
from calib.manipulator.planar import Planar2Link, Planar2Params
from calib.manipulator.units import EffortScale, effort_scale, effort_unit
from calib.results import AnalysisResult, CalibrationResult, Estimate
from logtools.errors import LogcalInputError
from logtools.loaded import LoadedLog
from logtools.robots.base import Progress
from logtools.robots.manipulator.effort import effort_choice
from logtools.robots.manipulator.options import ManipulatorOptions
from logtools.safe_text import printable
from logtools.stages import Stages

if TYPE_CHECKING:
    from logtools.analysis_config import AnalysisConfig

__all__ = ["analyze_manipulator"]

_MAX_DRAW = 400
_DEFAULT_TERMS = (Term.COULOMB, Term.VISCOUS)


def _joints(loaded: LoadedLog) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    frame = loaded.frame
    n = 0
    while f"q{n + 1}" in frame.columns:
        n += 1
    missing = [f"tau{j + 1}" for j in range(n) if f"tau{j + 1}" not in frame.columns]
    if n == 0 or missing:
        raise LogcalInputError(
            f"{loaded.path}: /joint_states field 'effort' (tau1..tau{max(n, 1)}) is missing "
            f"({', '.join(missing) or 'no q1'}); expected joint positions and torques per joint"
        )
    raw = _logged_samples(loaded, n)
    if raw is not None:
        return (*raw, n)
    t = (frame["t_ns"].to_numpy() - frame["t_ns"][0]) / 1e9
    q = np.column_stack([frame[f"q{j + 1}"].to_numpy() for j in range(n)]).astype(float)
    tau = np.column_stack([frame[f"tau{j + 1}"].to_numpy() for j in range(n)]).astype(float)
    ok = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(tau), axis=1)
    return t[ok], q[ok], tau[ok], n


def _logged_samples(loaded: LoadedLog, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The joints' samples at their own stamps (the resolved signals before alignment), when
    every ``q``/``tau`` signal was logged with the others (one message per sample, as
    ``/joint_states``): the aligned frame interpolates onto a uniform grid, which averages
    neighbouring torque samples, halves their high-frequency content and so the noise floor the
    residual is judged against. None when the signals do not share their stamps."""
    signals = getattr(getattr(loaded, "signals", None), "signals", None)
    names = [f"{c}{j + 1}" for c in ("q", "tau") for j in range(n)]
    if not isinstance(signals, dict) or not all(k in signals for k in names):
        return None
    stamps = [np.asarray(signals[k]["t_ns"].to_numpy()) for k in names]
    common = stamps[0]
    for s in stamps[1:]:
        common = np.intersect1d(common, s, assume_unique=True)
    if common.size < 50 or common.size < 0.9 * max(s.size for s in stamps):
        return None
    cols = []
    for k, s in zip(names, stamps, strict=True):
        v = np.asarray(signals[k]["value"].to_numpy(), dtype=float)
        cols.append(v[np.searchsorted(s, common)])
    q = np.column_stack(cols[:n])
    tau = np.column_stack(cols[n:])
    t = (common - common[0]) / 1e9
    ok = np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(tau), axis=1)
    return t[ok], q[ok], tau[ok]


def _joint_names(loaded: LoadedLog, meta: dict[str, str], n: int) -> tuple[str, ...] | None:
    frame = loaded.log.topics.get("/joint_states")
    if frame is not None and f"name.{n - 1}" in frame.columns and len(frame):
        names = tuple(str(frame[f"name.{j}"][0]) for j in range(n))
        if all(names):
            return names
    if meta.get("joints"):
        names = tuple(s.strip() for s in meta["joints"].split(","))
        if len(names) == n:
            return names
    return None


def _meta_float(meta: dict[str, str], key: str, default: float) -> float:
    try:
        return float(meta[key])
    except (KeyError, ValueError):
        return default


def _model(
    loaded: LoadedLog, config: AnalysisConfig, meta: dict[str, str], n: int
) -> tuple[ArmModel, str]:
    """The arm's model: the URDF the user gave (``--urdf``, settings, or the channel map's
    ``[robot] urdf``), else the planar model a simulated log declares. A log is data, never
    instructions: a URDF the log's own metadata names is never opened (it is only quoted in the
    message asking for ``--urdf``)."""
    robot_cfg = loaded.robot_config if hasattr(loaded, "robot_config") else None
    urdf = config.options(ManipulatorOptions).urdf or (
        robot_cfg.text("urdf") if robot_cfg is not None else None
    )
    names = _joint_names(loaded, meta, n)
    if urdf:
        from calib.manipulator.serial import load_serial_arm

        try:
            return load_serial_arm(str(urdf), names, n), f"URDF {urdf}"
        except CalibError as err:
            raise LogcalInputError(f"{loaded.path}: {err}") from err
    if meta.get("model") == "planar2" and n == 2:
        nominal = {
            k[len("nominal.") :]: float(v) for k, v in meta.items() if k.startswith("nominal.")
        }
        p = Planar2Params(
            l1=_meta_float(meta, "l1", 0.5),
            l2=_meta_float(meta, "l2", 0.5),
            g=_meta_float(meta, "g", 9.8),
            **{k: v for k, v in nominal.items() if k in ("m1", "m2", "r1", "r2", "I1", "I2")},
            payload=nominal.get("payload", 0.0),
        )
        return Planar2Link(p, names or ("joint1", "joint2")), "planar 2-link arm (metadata)"
    named = meta.get("urdf")
    hint = (
        (
            f" (the log's metadata names {printable(named)!r}; logcal never opens a file a log "
            "names: give it yourself if it is the right model)"
        )
        if named
        else ""
    )
    raise LogcalInputError(
        f"{loaded.path}: an arm log with {n} joints needs its model: give --urdf PATH_OR_NAME "
        "(a URDF file or an example-robot-data name such as panda), a settings file's urdf, "
        f"or the channel map's [robot] urdf{hint}"
    )


def _declared(meta: dict[str, str]) -> tuple[Term, ...] | None:
    if "model_terms" not in meta:
        return None
    out = []
    for s in meta["model_terms"].split(","):
        s = s.strip()
        if s:
            try:
                out.append(Term(s))
            except ValueError as err:
                raise LogcalInputError(
                    f"'logcal' metadata model_terms: {s!r} is not one of "
                    f"{', '.join(str(t) for t in Term)}"
                ) from err
    return tuple(out)


def _effort_units(
    model: ArmModel, ident: ArmIdentification, would: dict[str, float] | None = None
) -> EffortScale | None:
    """The logged effort against what the model's nominal masses need (``calib.manipulator.
    units``), on the filtered signals the identification used; ``would``: the factors of the
    URDF's transmissions, for the note when the effort was taken as logged."""
    sig = ident.sig
    return effort_scale(model, sig.q, sig.qd, sig.qdd, sig.tau_f, would)


def _truth_base(ident: ArmIdentification, truth: dict[str, float]) -> dict[str, float]:
    d = ident.design
    full = d.names_full
    if d.rigid and all(n in truth for n in full):
        base = d.to_base(np.array([truth[n] for n in full]))
        return dict(zip(d.names, base.tolist(), strict=True))
    return {}


def analyze_manipulator(
    loaded: LoadedLog, config: AnalysisConfig, progress: Progress
) -> AnalysisResult:
    """Analyse one arm log (the plugin's ``analyze``)."""
    meta = dict(loaded.log.metadata.get("logcal", {}))
    t, q, tau, n = _joints(loaded)
    model, model_source = _model(loaded, config, meta, n)
    effort = effort_choice(loaded, config, model)  # --effort: joint side, or actuator side
    tau = tau * effort.scaling.factors(model.joint_names)[None, :]
    stages = Stages(config.debug)
    declared = _declared(meta)
    terms = _DEFAULT_TERMS
    cutoff = _cutoff(config.options(ManipulatorOptions).cutoff_hz)
    cfg = IdentifyConfig(terms=terms, cutoff_hz=cutoff)
    ident = stages.run(
        "identification", lambda: identify_arm(model, t, q, tau, cfg, progress=progress)
    )
    judged: _Judged | None = None
    if ident is not None:
        judged = stages.run(
            "model adequacy",
            lambda: _judge(
                model, ident, meta, declared, cfg, stages, config.discovery, progress, (t, q, tau)
            ),
        )
    else:
        stages.skip("model adequacy", "identification did not run")
        stages.skip("discovery", "identification did not run")
    sections: dict[str, Any] = {
        "joints": list(model.joint_names),
        "joint_units": _joint_units(model, n),
        "model": {"source": model_source},
        "effort_scaling": effort.scaling.to_dict(),
    }
    artifacts: dict[str, Any] = {}
    unit_notes: list[str] = list(effort.notes)
    methods: list[Any] = []
    estimate = None
    truth_base: dict[str, float] = {}
    if ident is not None:
        methods, estimate = ident.methods, ident.recommended
        if judged is not None:
            estimate = judged.estimate
        sections |= _identification_sections(model, ident, model_source)
        if judged is not None:
            sections |= judged.sections
        units = stages.run("effort units", lambda: _effort_units(model, ident, effort.would))
        if units is not None:
            sections["effort_scale"] = units.to_dict()
            if units.note:
                unit_notes.append(units.note)
        truth_base = _truth_base(ident, loaded.truth)
        if truth_base:
            sections["truth_base"] = truth_base
        artifacts = _draw_artifacts(model, ident)
    return AnalysisResult(
        robot="manipulator",
        segments=[],
        methods=methods,
        estimate=estimate,
        discovery=None if judged is None else judged.discovery,
        adequacy=None if judged is None else judged.adequacy,
        truth=dict(loaded.truth),
        source={"path": loaded.path},
        warnings=[str(p) for p in loaded.problems] + unit_notes,
        stages=stages.status,
        sections=sections,
        artifacts=artifacts,
    )


def _joint_units(model: ArmModel, n: int) -> dict[str, str]:
    """Each joint's effort unit (N·m for a revolute joint, N for a prismatic one)."""
    kinds = getattr(model, "joint_kinds", None)
    return dict(
        zip(
            model.joint_names,
            [effort_unit(k) for k in kinds()] if callable(kinds) else ["N·m"] * n,
            strict=True,
        )
    )


def _identification_sections(
    model: ArmModel, ident: ArmIdentification, model_source: str
) -> dict[str, Any]:
    """The identification's JSON sections: excitation, held-out torque error, feasibility and
    the model identified."""
    h = ident.holdout
    names = model.joint_names
    return {
        "excitation": {
            "condition_number": ident.condition_number,
            "condition_number_acceleration": ident.methods[1].details.get("condition_number"),
            "n_base_parameters": len(ident.design.base),
            "n_determined": int(ident.wls.identifiable.sum()),
        },
        "torque_rms_holdout": dict(zip(names, h.rms.tolist(), strict=True)),
        "torque_rms_holdout_ratio": h.ratio,
        "torque_rms": dict(zip(names, h.torque_rms.tolist(), strict=True)),
        "feasibility": ident.feasibility.to_dict(),
        "model": {
            "source": model_source,
            "terms": [str(x) for x in ident.design.terms],
            "cutoff_hz": ident.sig.cutoff_hz,
            "rate_hz": ident.sig.rate_hz,
            "notes": list(getattr(model, "notes", ())) + ident.notes,
        },
    }


def _draw_artifacts(model: ArmModel, ident: ArmIdentification) -> dict[str, Any]:
    """What the views draw: the arm's points at most ``_MAX_DRAW`` times, the held-out torque
    measured and predicted, the excitation trajectories."""
    h = ident.holdout
    step = max(1, len(ident.sig) // _MAX_DRAW)
    return {
        "t_s": ident.sig.t_s[::step],
        "points": model.points(ident.sig.q[::step]),
        "holdout_t_s": h.t_s,
        "holdout_measured": h.measured,
        "holdout_predicted": h.predicted,
        "trajectory_t_s": ident.trajectory_t,
        "trajectories": ident.trajectory,
        "parameter_names": list(ident.design.names),
        "joint_names": list(model.joint_names),
    }


@dataclass(frozen=True)
class _Judged:
    """What the adequacy stage found: the verdict, discovery, the recommended estimate as the
    verdict allows, and the JSON sections (split at a parameter change, confounds)."""

    adequacy: Adequacy
    discovery: DiscoveryReport
    estimate: CalibrationResult
    sections: dict[str, Any]


def _judge(
    model: ArmModel,
    ident: ArmIdentification,
    meta: dict[str, str],
    declared: tuple[Term, ...] | None,
    cfg: IdentifyConfig,
    stages: Stages,
    discovery: bool,
    progress: Progress,
    raw: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> _Judged:
    """Adequacy of the identified model, discovery through the shared engine, a parameter
    change over time pieces, and the recommended estimate under the verdict."""
    progress("model adequacy")
    fitter = ArmFitter(model, ident.sig, cfg.terms, None, cfg)
    first = assess_arm(fitter)
    if first is None:
        raise CalibError("the identified model could not be refitted for its adequacy")
    before = first.adequacy
    pieces = piece_fits(fitter)
    split = find_change(fitter, pieces)
    disc: ArmDiscovery | None = None
    if discovery:
        nominal = None
        if meta.get("nominal") == "true" or any(k.startswith("nominal.") for k in meta):
            nominal = model.nominal
        baseline = declared if declared is not None else cfg.terms
        if nominal is None and baseline == cfg.terms:
            dfit = fitter
        else:
            dfit = ArmFitter(model, ident.sig, baseline, nominal, cfg, fitter.floors)
        disc = stages.run("discovery", lambda: run_discovery(dfit, progress=progress))
    else:
        stages.skip("discovery", "--no-discovery")
    # a payload is regrouped into the fitted body; a term the fitted model already has is there
    accepted = fitter.addable(disc.final_effects if disc else ())
    changes = (split.change,) if split is not None else ()
    final = first
    if accepted:
        again = assess_arm(fitter, accepted, before=before, changes=changes)
        if again is not None:
            final = again
        else:
            accepted = []
    notes: list[str] = []
    confounds = list(disc.selection.confounds) if disc and disc.selection else []
    notes += [f"confound: {c.note}" for c in confounds]
    unexplained = None
    if not final.adequacy.explains and split is None:
        unexplained = (
            "what the named and described effects leave is still above the noise floor"
            if accepted
            else "no catalogue effect (friction, torque offset, payload, actuation delay or lag, "
            "joint compliance), no residual model of the joints' own signals and no parameter "
            "change explains it"
        )
    adequacy = final.adequacy.with_(
        before=before if accepted else None,
        changes=changes,
        unexplained=unexplained,
        notes=tuple(notes),
        verdict=final.adequacy.verdict if not changes else NOT_EXPLAINED,
    )
    # the recommended estimate: the identification's (or the fit with the named effects), then
    # widened under a misfit, then spanning confounded explanations
    est = ident.recommended
    params: dict[str, Estimate] = dict(est.parameters)
    method = est.method
    if accepted:
        params = final.whole.estimates() | {
            e.name: e for pars in final.whole.effect_parameters.values() for e in pars.values()
        }
        method = "momentum-WLS + " + " + ".join(e.key for e in accepted)
    # what the processing cannot settle (friction shape at reversals, noise in the regressor),
    # then the parameters' stability over time pieces, then a misfit
    shifts = fitter.processing_shifts()
    if raw is not None:
        by_cut = cutoff_shifts(ident.design, *raw, cfg, ident.wls.theta)
        shifts = {
            n: float(np.hypot(shifts.get(n, 0.0), d))
            for n, d in zip(ident.design.names, by_cut.tolist(), strict=True)
        }
    if adequacy.explains and discovery:
        # the catalogue's effects the log cannot exclude, each fitted in turn
        cat = arm_catalogue(model.joint_names, cfg.terms, nominal=False)
        spread = effect_spread(fitter, accepted, cat)
        shifts = {
            n: float(np.hypot(shifts.get(n, 0.0), spread.get(n, 0.0)))
            for n in set(shifts) | set(spread)
        }
    params = with_shifts(scaled_by_pieces(params, pieces), shifts)
    if adequacy.explains:
        params = stabilised(params, pieces)
    params = widened(params, adequacy, pieces)
    sections: dict[str, Any] = {}
    alts = []
    for c in confounds:
        alt_effects = fitter.applicable(c.alternative_fit.effects)
        alt = fitter.fit_arm(tuple(alt_effects))
        if alt is not None:
            alts.append((c.alternative, widened(alt.estimates(), adequacy, pieces)))
    described = described_alternative(fitter, disc, accepted) if disc is not None else None
    if described is not None:
        alts.append((described[0], widened(described[1], adequacy, pieces)))
    if alts:
        label = " + ".join(e.key for e in accepted) or "baseline"
        params = spanned(params, alts, label)
    if confounds:
        sections["confounds"] = [c.to_dict() for c in confounds]
    if split is not None:
        sections["parameter_change"] = split.to_dict()
    verdict = _verdict(ident, adequacy)
    # the identification's covariance is of its own fit: not of one with named effects
    same_fit = not accepted and list(params) == list(est.parameters)
    estimate = replace(
        est,
        method=method,
        parameters=params,
        verdict=verdict,
        covariance=est.covariance if same_fit else None,
    )
    report = arm_discovery_report(
        disc,
        before,
        adequacy,
        est,
        estimate,
        description=None if disc is None else disc.description,
        not_run="" if discovery else "discovery not run (--no-discovery)",
    )
    return _Judged(adequacy, report, estimate, sections)


def _verdict(ident: ArmIdentification, adequacy: Adequacy) -> str:
    """The recommended estimate's verdict: what the log determines, and the adequacy in brief
    (feasibility is reported once, in the arm's own part of the report)."""
    n_id = sum(1 for e in ident.recommended.parameters.values() if e.identifiable)
    head = (
        f"{n_id} of {len(ident.recommended.parameters)} base parameters determined by the "
        f"regressor (condition number {ident.condition_number:.3g}); held-out torque error "
        f"{100 * ident.holdout.ratio:.1f} % of the torque RMS"
    )
    if adequacy.explains:
        return head + "; the model explains the log."
    return head + "; the model does not explain the log: intervals widened, not determined."


def _cutoff(value: Any) -> float:
    """The filter cut-off (``--cutoff-hz``): default 10 Hz; a positive finite number."""
    if value is None:
        return 10.0
    try:
        hz = float(value)
    except (TypeError, ValueError):
        hz = float("nan")
    if not np.isfinite(hz) or hz <= 0:
        raise LogcalInputError(f"--cutoff-hz {value!r}: expected a positive frequency in Hz")
    return hz
