"""Model-mismatch discovery along the measured path: no commands needed, only link 1's path and
the recorded joint angle.

1. The nominal model (transient kinematics, L1, L2) is fitted jointly (``path_effects``) and
   judged (``calib.adequacy.assess`` of the joint-angle residual, held out by block
   cross-validation).
2. Effects of :func:`calib.tractor_trailer.path_effects.catalogue` (joint-angle offset, gain,
   backlash, clock offset and drift, a cubic nonlinearity, and any registered with
   ``path_effects.register_effect``) are selected forward by ``calib.adequacy.select_effects``
   (held-out gain, BIC, intervals excluding the null). Each effect's hook says how it changes
   the model; nothing here branches on an effect's id.
3. The link lengths are fitted on consecutive pieces of the log (with the accepted effects
   undone) and tested for a change mid-log (``calib.adequacy.parameter_change``); a change
   splits the log and each side is estimated.
4. The recommended estimate with the accepted effects: the nominal path fit on the corrected
   joint angle, its covariance inflated by what fitting the effects costs (the joint fit's
   marginal minus its conditional covariance of L1, L2); explanations the log cannot tell
   apart that move L1, L2 are spanned (``calib.adequacy.span``), and so is the nominal fit
   when the nominal model already explained the log (an effect accepted below the floor may
   stand in for other physics the catalogue only approximates).
5. The link lengths fitted on thirds of the log are tested for agreement
   (``calib.adequacy.piece_stability``); those that disagree beyond their errors are widened
   (``calib.adequacy.widen_unstable``) and not determined when that makes them wide, even
   where the residual stays at the noise floor.

What remains unexplained stays "does not explain", with where it sits.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from calib.adequacy import (
    EXPLAINS_RATIO,
    Adequacy,
    ParameterChange,
    PieceFit,
    PieceStability,
    assess,
    parameter_change,
    piece_stability,
    span,
    widen_unstable,
)
from calib.discovery import (
    Description,
    EffectSpec,
    Explanation,
    ModelFit,
    Selection,
    across,
    describe,
    select_effects,
)
from calib.errors import CalibError
from calib.results import CalibrationResult, Estimate, json_safe
from calib.tractor_trailer.derived import derived_sum, link_sum
from calib.tractor_trailer.estimators.drive_path import DrivePath
from calib.tractor_trailer.estimators.identifiability import undetermined
from calib.tractor_trailer.estimators.path_transient import PathTransientFit
from calib.tractor_trailer.path_adequacy import (
    estimate_under_misfit,
    heldout_residual,
    input_std,
    psi_channel,
    psi_floor,
    unexplained_text,
)
from calib.tractor_trailer.path_described import (
    expand_described,
    joint_jacobian,
    path_entries,
    path_library,
    path_residual_space,
)
from calib.tractor_trailer.path_effects import (
    GAIN_TOLERANCE,
    JointPathModel,
    JointSolution,
    PathEffectModel,
    Tolerance,
    Undone,
    effect_by_key,
)
from calib.tractor_trailer.path_effects import (
    catalogue as path_catalogue,
)

__all__ = [
    "GAIN_TOLERANCE",
    "MIN_DURATION_S",
    "PathDiscovery",
    "adopt_effects",
    "discover_along_path",
    "judge_path_fit",
    "nominal_label",
    "recommended",
    "with_effects",
]

MIN_DURATION_S = 20.0
"""Shorter logs are not searched (too few relaxation lengths to tell effects apart)."""
Z95 = 1.959963984540054
NOMINAL = "transient path"


def nominal_label(effects: Sequence[EffectSpec]) -> str:
    """The model's name for people: ``transient path + sensor_offset(psi) + ...``."""
    return " + ".join([NOMINAL, *(e.key for e in effects)])


@dataclass
class PathDiscovery:
    """What discovery along the path found.

    ``selection``: the forward selection (None when not run); ``nominal``: the nominal model's
    adequacy; ``adequacy``: the final model's (``before`` = nominal); ``change``: a mid-log
    change of the link lengths; ``piece_fits``: the link lengths on consecutive pieces;
    ``split``: per side of the change, (t0, t1, the path fit's estimate); ``thirds``: L1, L2,
    L1 + L2 fitted on thirds of the log; ``stability``: per link length, how well its fits on
    pieces of the log agree (``calib.adequacy.piece_stability``: unstable ones are widened in
    the recommended estimate); ``estimate``: the recommended estimate with the accepted
    effects (None: the nominal fit stands); ``status``: "ok" or "not_run"; ``reason``: why
    not run."""

    status: str
    reason: str = ""
    selection: Selection | None = None
    nominal: Adequacy | None = None
    adequacy: Adequacy | None = None
    change: ParameterChange | None = None
    piece_fits: list[PieceFit] = field(default_factory=list)
    split: list[tuple[float, float, CalibrationResult, Adequacy | None]] = field(
        default_factory=list
    )
    thirds: dict[str, list[float]] = field(default_factory=dict)
    stability: dict[str, PieceStability] = field(default_factory=dict)
    estimate: CalibrationResult | None = None
    solution: JointSolution | None = None
    corrected: tuple[np.ndarray, np.ndarray] | None = None
    notes: list[str] = field(default_factory=list)
    alternatives: list[tuple[str, Any]] = field(default_factory=list)
    assumptions: list[tuple[str, str]] = field(default_factory=list)
    """What the link lengths' intervals take as given that the log does not check (an effect
    held at its null within its tolerance): a short clause, and the same with what the log
    says of it and the lengths if it were left free."""
    context: Any = field(default=None, repr=False)
    description: Description | None = None
    """The residual model of what the selected effects leave (accepted or not)."""

    @property
    def accepted(self) -> tuple[EffectSpec, ...]:
        """The effects of the final model (the described one when it was kept)."""
        base = self.selection.accepted if self.selection is not None else ()
        d = self.description
        return d.fit.effects if d is not None and d.accepted else base

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"engine": "path", "status": self.status, "reason": self.reason}
        if self.selection is not None:
            out |= self.selection.to_dict()
        out["nominal_adequacy"] = (
            None
            if self.nominal is None
            else {"verdict": self.nominal.verdict, "summary": self.nominal.summary}
        )
        out["change"] = None if self.change is None else self.change.to_dict()
        out["pieces"] = [
            {"t0_s": p.t0_s, "t1_s": p.t1_s, "values": dict(p.values), "std": dict(p.std)}
            for p in self.piece_fits
        ]
        out["split"] = [
            {
                "t0_s": a,
                "t1_s": b,
                "estimate": est.to_dict(),
                "adequacy": None if ad is None else ad.to_dict(),
            }
            for a, b, est, ad in self.split
        ]
        out["description"] = None if self.description is None else self.description.to_dict()
        out["alternatives"] = [k for k, _ in self.alternatives]
        out["thirds"] = self.thirds
        out["stability"] = {k: v.to_dict() for k, v in self.stability.items()}
        out["notes"] = list(self.notes)
        out["assumptions"] = [detail for _short, detail in self.assumptions]
        safe: dict[str, Any] = json_safe(out)
        return safe

    def report(self) -> list[str]:
        """A few lines for people."""
        if self.status != "ok":
            return [f"Discovery along the path: not run ({self.reason})"]
        lines = ["Discovery along the measured path (joint-angle effects, no commands needed):"]
        if self.selection is not None:
            acc = self.selection.final
            if acc.effects:
                for key, pars in acc.effect_parameters.items():
                    txt = ", ".join(
                        f"{n} = {e.value:.4g} {e.unit} [{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]"
                        for n, e in pars.items()
                    )
                    lines.append(f"  named: {key}: {txt}")
            else:
                lines.append("  no catalogued effect improves the held-out fit")
            for c in self.selection.confounds:
                lines.append(f"  confound: {c.note}")
        d = self.description
        if d is not None:
            head = "described" if d.accepted else "the residual follows (not kept)"
            lines.append(f"  {head}: {d.text}")
        if self.change is not None:
            lines.append(f"  change mid-log: {self.change.note}")
            for a, b, est, _ in self.split:
                vals = ", ".join(e.report() for e in est.parameters.values())
                lines.append(f"    {a:.1f}-{b:.1f} s: {vals}")
        if self.adequacy is not None and self.adequacy.unexplained:
            lines.append(f"  unexplained: {self.adequacy.unexplained}")
        for st in self.stability.values():
            if st.unstable:
                lines.append(
                    f"  unstable: {st.name} differs between {st.pieces} pieces of the "
                    f"log beyond their errors (chi2 {st.chi2:.3g} on {st.dof} dof)"
                )
        lines += [f"  note: {n}" for n in self.notes]
        lines += [f"  assumes: {detail}" for _short, detail in self.assumptions]
        return lines


# ---------------------------------------------------------------------------- fitting
class _Fitter:
    """The ``select_effects`` fitter: joint fit + block cross-validation, cached by effects."""

    def __init__(self, model: JointPathModel, x_nominal: np.ndarray, floor: float) -> None:
        self.model = model
        self.floor = floor
        self.cache: dict[tuple[str, ...], ModelFit | None] = {}
        self.x: dict[tuple[str, ...], np.ndarray] = {(): x_nominal}

    def _start(self, effects: tuple[EffectSpec, ...]) -> np.ndarray:
        """The solution of the longest fitted beginning of this set (the parent model: this
        set without its last effect) and the other effects' inits."""
        keys = tuple(e.key for e in effects)
        done = next(n for n in range(len(keys), -1, -1) if keys[:n] in self.x)
        xp = self.x[keys[:done]]
        vals = list(xp[2 : 2 + done]) + [e.params[0].init for e in effects[done:]]
        return np.concatenate([xp[:2], vals, xp[2 + done :]])

    def __call__(self, specs: tuple[EffectSpec, ...]) -> ModelFit | None:
        keys = tuple(e.key for e in specs)
        if keys in self.cache:
            return self.cache[keys]
        # a described effect enters the joint fit as one added column per term
        effects = tuple(x for e in specs for x in expand_described(e, self.floor))
        try:
            sol = self.model.fit(effects, self._start(effects))
        except (CalibError, ValueError, FloatingPointError, np.linalg.LinAlgError):
            self.cache[keys] = None
            return None
        for i, e in enumerate(effects):
            q = e.params[0]
            if min(sol.x[2 + i] - q.lower, q.upper - sol.x[2 + i]) < 1e-3 * (q.upper - q.lower):
                # on a bound: not an explanation the fit resolved (its solution still starts
                # the sets that extend it), and its held-out folds are not needed
                self.x[tuple(e.key for e in effects)] = sol.x
                self.cache[keys] = None
                return None
        try:
            held = heldout_residual(self.model, effects, sol.x)
        except (CalibError, ValueError, FloatingPointError, np.linalg.LinAlgError):
            self.cache[keys] = None
            return None
        self.x[tuple(e.key for e in effects)] = sol.x
        f2 = self.floor**2
        cov = sol.cov
        params = {
            "L1": _est("L1", sol.x[0], cov[0, 0], "m"),
            "L2": _est("L2", sol.x[1], cov[1, 1], "m"),
        }
        eff: dict[str, dict[str, Estimate]] = {}
        flat = iter(enumerate(effects))
        for spec in specs:
            for p in spec.params:
                i, e = next(flat)
                q = e.params[0]
                eff.setdefault(spec.key, {})[p.name] = _est(
                    q.name, sol.x[2 + i], cov[2 + i, 2 + i], q.unit
                )
        ok = np.isfinite(held)
        fit = ModelFit(
            specs,
            params,
            eff,
            float(np.sum(sol.residual**2) / f2),
            float(np.sum(held[ok] ** 2) / f2 * held.size / ok.sum())
            if ok.sum() >= 10
            else math.nan,
            int(sol.residual.size),
            2 + len(effects) + self.model.n_pieces,
            payload=(sol, held),
        )
        self.cache[keys] = fit
        return fit


def _est(name: str, value: float, var: float, unit: str) -> Estimate:
    sd = math.sqrt(var) if var >= 0 and math.isfinite(var) else math.nan
    half = Z95 * sd
    return Estimate(name, float(value), sd, (value - half, value + half), math.isfinite(sd), unit)


def _path_fit(
    path: DrivePath, t: np.ndarray, psi: np.ndarray, gaps: Sequence[tuple[float, float]], **kw: Any
) -> PathTransientFit | None:
    try:
        return PathTransientFit(**kw).fit(path, t, psi, gaps=list(gaps))
    except (CalibError, ValueError, FloatingPointError, np.linalg.LinAlgError):
        return None


def _pieces(
    path: DrivePath,
    t: np.ndarray,
    psi: np.ndarray,
    gaps: Sequence[tuple[float, float]],
    n_pieces: int,
    *,
    fit_psi_offset: bool = False,
    checks: bool = False,
) -> list[tuple[float, float, PathTransientFit]]:
    """The path fit on ``n_pieces`` consecutive pieces of the log (informative ones only).
    ``checks``: with the path's resolution and integrated rate noise in each piece's
    covariance, as the recommended fit has them (for the pieces' agreement, which must not
    take what those leave out for instability)."""
    edges = np.linspace(t[0], t[-1], n_pieces + 1)
    out = []
    for a, b in itertools.pairwise(edges):
        m = (t >= a) & (t <= b)
        if m.sum() < 30:
            continue
        f = _path_fit(
            path,
            t[m],
            psi[m],
            gaps,
            resolution_check=checks,
            rate_noise_check=checks,
            fit_psi_offset=fit_psi_offset,
        )
        if f is not None and f.sound_ and _informative(f):
            out.append((float(a), float(b), f))
    return out


def _informative(f: PathTransientFit) -> bool:
    """A piece that determines L1 + L2 (by the estimator's own rule) and bounds L2 within half
    its value: a stretch driven straight or at rest determines neither and is left out."""
    total = link_sum(f.result_)
    sd2 = math.sqrt(max(f.cov_[1, 1], 0.0))
    return bool(total is not None and total.identifiable and sd2 < 0.5 * abs(f.L2_))


def _piece_fit(a: float, b: float, f: PathTransientFit) -> PieceFit:
    c = f.cov_
    return PieceFit(
        a,
        b,
        {"L1+L2": f.L1_ + f.L2_, "L2": f.L2_, "L1": f.L1_},
        {
            "L1+L2": math.sqrt(max(c[0, 0] + c[1, 1] + 2 * c[0, 1], 0.0)),
            "L2": math.sqrt(max(c[1, 1], 0.0)),
            "L1": math.sqrt(max(c[0, 0], 0.0)),
        },
    )


STABILITY_NAMES = ("L1", "L2", "L1+L2")


def _thirds(
    fits: Sequence[tuple[float, float, PathTransientFit]],
) -> tuple[dict[str, list[float]], dict[str, PieceStability]]:
    """L1, L2, L1 + L2 on thirds of the log, and whether each agrees across them."""
    values = {
        "L1": [f.L1_ for *_, f in fits],
        "L2": [f.L2_ for *_, f in fits],
        "L1+L2": [f.L1_ + f.L2_ for *_, f in fits],
    }
    return values, piece_stability([_piece_fit(a, b, f) for a, b, f in fits], STABILITY_NAMES)


def _moves(a: ModelFit, b: ModelFit) -> bool:
    """``b`` moves L1 or L2 by more than twice their combined standard error from ``a``."""
    for name in ("L1", "L2"):
        ea, eb = a.parameters[name], b.parameters[name]
        sd = math.hypot(ea.std, eb.std)
        if not math.isfinite(sd) or abs(ea.value - eb.value) > 2.0 * sd:
            return True
    return False


def _psd(a: np.ndarray) -> np.ndarray:
    w, v = np.linalg.eigh(0.5 * (a + a.T))
    return np.asarray((v * np.clip(w, 0.0, None)) @ v.T)


# ---------------------------------------------------------------------------- discovery
def discover_along_path(
    path: DrivePath,
    t_psi: np.ndarray,
    psi: np.ndarray,
    gaps: Sequence[tuple[float, float]],
    nominal_fit: PathTransientFit,
    *,
    segments: Sequence[tuple[str, float, float]] = (),
    catalogue: Sequence[EffectSpec[PathEffectModel]] | None = None,
    max_effects: int = 2,
    gain_tolerance: float | None = None,
    check_change: bool = True,
    progress: Callable[[str], None] | None = None,
) -> PathDiscovery:
    """Discovery along ``path`` for the joint angle ``psi`` at ``t_psi`` (see the module
    docstring); ``nominal_fit`` is the recommended path fit (its start point, noise and
    quantum are reused). ``catalogue``: the effects tried (default: the built-in and the
    registered ones). An effect whose hook is ``tolerated`` (the joint angle's gain) and that
    the log cannot bound within its tolerance (95 %) is a confound of the link lengths, which
    span it; ``gain_tolerance`` replaces those tolerances."""
    effects = tuple(path_catalogue() if catalogue is None else catalogue)
    say = progress or (lambda _s: None)
    t = np.asarray(t_psi, dtype=float)
    dur = float(np.nanmax(t) - np.nanmin(t)) if t.size else 0.0
    if dur < MIN_DURATION_S:
        return PathDiscovery(
            "not_run",
            f"the log is {dur:.3g} s long; discovery along the path needs {MIN_DURATION_S:g} s",
        )
    model = JointPathModel(path, t, np.asarray(psi, dtype=float), gaps)
    quantum = float(getattr(nominal_fit, "quantum_", 0.0))
    in_std = input_std(nominal_fit)
    x0 = np.concatenate(
        [
            [nominal_fit._x_raw[0], nominal_fit._x_raw[1]],
            nominal_fit.psi0_ if model.n_pieces == nominal_fit.n_pieces_ else model.psi0_guess,
        ]
    )
    say("path discovery: nominal model")
    first = model.fit((), x0)
    floor = psi_floor(model, first.residual, quantum=quantum, input_std_rad=in_std)
    fitter = _Fitter(model, first.x, max(floor.std, 1e-9))
    base = fitter(())
    if base is None:
        return PathDiscovery("not_run", "the nominal joint fit failed")

    def channel(fit: ModelFit) -> Any:
        sol, held = fit.payload
        return psi_channel(
            model, sol, held, quantum=quantum, input_std_rad=in_std, segments=segments
        )

    nominal = assess([channel(base)], model=NOMINAL)
    n_pieces = 6 if dur < 120.0 else 8
    ctx = _Context(path, gaps, model, fitter, channel, nominal, segments)
    limit = EXPLAINS_RATIO**2

    def explained(f: ModelFit) -> bool:
        return bool(math.isfinite(f.heldout_sse) and f.heldout_sse / f.n <= limit)

    def stop(f: ModelFit) -> bool:
        # the catalogue is tried at least once: an effect can bias L1, L2 before it lifts the
        # residual above EXPLAINS_RATIO x the floor (backlash, a clock drift)
        return bool(f.effects) and explained(f)

    selection = select_effects(
        fitter,
        effects,
        max_effects=max_effects,
        explained=stop,
        progress=lambda s: say(f"path discovery: {s}"),
    )
    if selection is None:  # pragma: no cover - the base fit succeeded above
        return PathDiscovery("not_run", "the nominal joint fit failed")
    dropped = ""
    if selection.accepted and explained(base) and not _moves(base, selection.final):
        # the nominal model explained the log and the effects do not move the link lengths:
        # one explanation fewer (not reported)
        dropped = (
            f"{selection.final.label} lowers the held-out residual slightly, but the "
            "nominal model already explains the log and the link lengths do not move "
            "with it: not reported"
        )
        selection = Selection(
            base, base, tuple(replace(t, accepted=False) for t in selection.tried), ()
        )
    final_sol, _ = selection.final.payload
    out = PathDiscovery("ok", selection=selection, nominal=nominal, solution=final_sol, context=ctx)
    if dropped:
        out.notes.append(dropped)
    t_c, psi_c = model.corrected(final_sol) if selection.accepted else (model.t, model.p)
    out.corrected = (t_c, psi_c)
    if check_change:
        # a change of the link lengths, on the data with the named effects undone; or, when
        # the effects leave the log unexplained, on the recorded angle with a fitted offset
        # (an effect fitted over a change can mimic neither side)
        say("path discovery: link lengths on pieces of the log")
        pieces = [_piece_fit(a, b, f) for a, b, f in _pieces(path, t_c, psi_c, gaps, n_pieces)]
        out.piece_fits = pieces
        change = parameter_change(pieces, ("L1+L2", "L2"))
        if change is None and selection.accepted and not explained(selection.final):
            raw = [
                _piece_fit(a, b, f)
                for a, b, f in _pieces(path, model.t, model.p, gaps, n_pieces, fit_psi_offset=True)
            ]
            change = parameter_change(raw, ("L1+L2", "L2"))
            pieces = raw if change is not None else pieces
        if change is not None:
            return _split(ctx, change, pieces, progress)
    out.thirds, out.stability = _thirds(_pieces(path, t_c, psi_c, gaps, 3, checks=True))
    for e in effects:
        if e.model is not None and e.model.tolerated is not None and e not in selection.accepted:
            tol = (
                e.model.tolerated
                if gain_tolerance is None
                else replace(e.model.tolerated, within=gain_tolerance)
            )
            out.alternatives += _tolerated_alternatives(
                ctx, selection, e, tol, out.notes, out.assumptions
            )
    for c in selection.confounds:
        if {"L1", "L2"} & set(c.parameters):
            out.alternatives.append((c.alternative, c.alternative_fit.parameters))
    plain_ok = bool(nominal_fit.sound_ and nominal_fit.misfit_ <= EXPLAINS_RATIO)
    if selection.accepted and (explained(base) or plain_ok):
        # the nominal model already explained the log (by the joint fit's held-out residual,
        # or the path fit's own misfit), yet the effects move the link lengths: physics below
        # the noise floor that the catalogue only approximates (a slip, play narrower than the
        # noise) can be taken for them, and so can a far-off geometry that carries less of the
        # path's noise into the modelled angle (L1 near -L2 with a joint-angle offset of the
        # angle's own size); the log does not say which is right, and the estimate spans both
        plain = nominal_fit.result_.parameters if nominal_fit.sound_ else base.parameters
        out.alternatives.append((NOMINAL, plain))
        out.notes.append(
            f"{selection.final.label} lowers the held-out residual and moves the link lengths, "
            "but the nominal model already explains the log: the intervals span both "
            f"(nominal L1 {plain['L1'].value:.3g} m, L2 {plain['L2'].value:.3g} m)"
        )
    say("path discovery: residual model")
    out.description = _describe_residual(ctx, selection.final, explained(selection.final))
    d = out.description
    final = d.fit if d is not None and d.accepted else selection.final
    adequacy = assess(
        [channel(final)],
        model=nominal_label(final.effects),
        before=nominal if final.effects else None,
    )
    if not adequacy.explains:
        adequacy = adequacy.with_(unexplained=unexplained_text(adequacy))
    out.adequacy = adequacy
    if final.effects:
        final_sol, _ = final.payload
        out.solution = final_sol
        out.estimate = _with_effects(ctx, final.effects, final_sol, out.notes)
    return out


def _describe_residual(ctx: _Context, current: ModelFit, explained: bool) -> Description | None:
    """The residual model of what ``current`` leaves in the joint angle
    (``calib.discovery.residual_model``), through the path's reading and kinematics."""
    sol, _ = current.payload
    model, floor = ctx.model, ctx.fitter.floor
    library = path_library(model, sol.true_psi)
    if not library:
        return None
    ents = path_entries(model, sol.x, sol.true_psi, floor, library)
    jac = joint_jacobian(model, sol.x, sol.effects)
    space = path_residual_space(model, sol.residual, floor, ents, jac)
    block = max(20, model.t.size // 100)
    return describe(ctx.fitter, current, space, library, block=block, explained=explained)


@dataclass
class _Context:
    """What a later refit needs again (not serialised)."""

    path: DrivePath
    gaps: Sequence[tuple[float, float]]
    model: JointPathModel
    fitter: _Fitter
    channel: Callable[[ModelFit], Any]
    nominal: Adequacy
    segments: Sequence[tuple[str, float, float]]


def _split(
    ctx: _Context,
    change: ParameterChange,
    pieces: list[PieceFit],
    progress: Callable[[str], None] | None,
) -> PathDiscovery:
    """A log whose link lengths change: each side estimated (with its own discovery when it is
    long enough), the whole log judged "does not explain"."""
    model = ctx.model
    out = PathDiscovery("ok", nominal=ctx.nominal, change=change, piece_fits=pieces, context=ctx)
    out.adequacy = assess(
        [ctx.channel(ctx.fitter(()))],  # type: ignore[arg-type]
        model=NOMINAL,
        changes=[change],
    )
    for a, b in ((float(model.t[0]), change.t_s), (change.t_s, float(model.t[-1]))):
        m = (model.t >= a) & (model.t <= b)
        f = _path_fit(ctx.path, model.t[m], model.p[m], ctx.gaps)
        if f is None:
            out.notes.append(f"the part {a:.1f}-{b:.1f} s could not be fitted on its own")
            continue
        side = discover_along_path(
            ctx.path,
            model.t[m],
            model.p[m],
            ctx.gaps,
            f,
            segments=ctx.segments,
            check_change=False,
            max_effects=1,
            progress=progress,
        )
        est = recommended(f.result_, side)
        out.split.append((a, b, est, side.adequacy))
    return out


def _tolerated_alternatives(
    ctx: _Context,
    selection: Selection,
    spec: EffectSpec[PathEffectModel],
    tol: Tolerance,
    notes: list[str],
    assumptions: list[tuple[str, str]],
) -> list[tuple[str, Any]]:
    """The link lengths under the values of ``spec`` (e.g. the joint-angle gain) within
    ``tol.within`` of its null that the log cannot exclude (refits with the effect at each end
    of that range undone from the readings, by its hook); none when the log itself bounds the
    effect within the tolerance: the link lengths' intervals then stand, and ``assumptions``
    says that they take the effect at its null, with the lengths were it left free."""
    alt = ctx.fitter((*selection.accepted, spec))
    if alt is None or spec.model is None:
        return []
    par = spec.params[0]
    g = alt.effect_parameters[spec.key][par.name]
    half = Z95 * g.std if math.isfinite(g.std) else math.inf
    tolerance, null = tol.within, par.null
    if null - tolerance <= g.value - half and g.value + half <= null + tolerance:
        # the log bounds the effect within the tolerance; the intervals are those at its null
        free = "; ".join(
            f"{k} = {e.value:.4g} {e.unit} [{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]"
            for k, e in alt.parameters.items()
            if k in ("L1", "L2") and math.isfinite(e.std)
        )
        short = f"{tol.quantity} is {null:g}"
        assumptions.append(
            (
                short,
                f"{short} (the log bounds it only to "
                f"[{g.value - half:.4g}, {g.value + half:.4g}], 95 %"
                + (f"; left free: {free}" if free else "")
                + ")",
            )
        )
        return []
    lo, hi = max(null - tolerance, g.value - half), min(null + tolerance, g.value + half)
    if not lo < null < hi:
        return []
    sol, _ = selection.final.payload
    out = []
    for s in (lo, hi):
        data = spec.model.undo(Undone(ctx.model, sol, ctx.model.t, ctx.model.p, None, False), s).z
        try:
            f = ctx.model.fit(sol.effects, sol.x, data=data)
        except (CalibError, ValueError, FloatingPointError, np.linalg.LinAlgError):
            continue
        out.append(
            (
                f"{spec.key} = {s:.3g}",
                {
                    "L1": _est("L1", f.x[0], f.cov[0, 0], "m"),
                    "L2": _est("L2", f.x[1], f.cov[1, 1], "m"),
                },
            )
        )
    if out:
        notes.append(
            f"the log bounds {tol.quantity} only to [{g.value - half:.3g}, "
            f"{g.value + half:.3g}] (95 %): {tol.error} within {tolerance:.0%} cannot be told "
            "from the link lengths ("
            + "; ".join(f"{k}: L1 {a['L1'].value:.3g} m, L2 {a['L2'].value:.3g} m" for k, a in out)
            + "), so their intervals span those explanations"
        )
    return out


def _with_effects(
    ctx: _Context,
    effects: Sequence[EffectSpec],
    sol: JointSolution,
    notes: list[str],
) -> CalibrationResult | None:
    """The path fit on the joint angle with ``effects`` (fitted in ``sol``) undone, its
    covariance inflated by what fitting them costs."""
    inflation = _psd(sol.cov[:2, :2] - sol.cov_fixed)
    t_c, psi_c = ctx.model.corrected(sol, drop_holds=True)
    fit = _path_fit(ctx.path, t_c, psi_c, ctx.gaps, extra_covariance=inflation)
    if fit is None or not fit.sound_:
        notes.append(
            "the path fit on the joint angle with the named effects undone failed; "
            "the nominal fit stands"
        )
        return None
    label = " + ".join(e.key for e in effects)
    res = fit.result_
    method = f"{res.method} + {label}"
    return replace(
        res,
        method=method,
        details={
            **res.details,
            "model": method,
            "effects_included": [e.key for e in effects],
            "effects_engine": "path discovery",
            "effect_covariance_inflation": inflation.tolist(),
        },
    )


def with_effects(disc: PathDiscovery, keys: Sequence[str]) -> CalibrationResult | None:
    """The recommended estimate with the effects ``keys`` (the union of what either discovery
    engine accepted) fitted jointly along the path; None when the fit fails."""
    ctx = disc.context
    if ctx is None:
        return None
    specs = tuple(effect_by_key(k) for k in keys)
    fit = ctx.fitter(specs)
    if fit is None:
        return None
    sol, _ = fit.payload
    return _with_effects(ctx, specs, sol, disc.notes)


def _spanned(
    est: CalibrationResult, alternatives: Sequence[tuple[str, Any]], rel_tol: float = 0.1
) -> CalibrationResult:
    if not alternatives:
        return est
    params = dict(est.parameters)
    scale = 0.5 * (abs(params["L1"].value) + abs(params["L2"].value))
    labels = [est.method] + [k for k, _ in alternatives]
    for name in ("L1", "L2"):
        params[name] = span(
            [params[name]] + [a[name] for _, a in alternatives],
            labels,
            scale=scale,
            rel_tol=rel_tol,
        )
    total = link_sum(est)
    if total is not None:
        alts = [
            _est("L1 + L2", a["L1"].value + a["L2"].value, a["L1"].std ** 2 + a["L2"].std ** 2, "m")
            for _, a in alternatives
        ]
        total = span([total, *alts], labels, scale=scale, rel_tol=rel_tol)
    if all(e.identifiable for e in params.values()) and (total is None or total.identifiable):
        return replace(est, parameters=params, derived=derived_sum(total, est.derived))
    why = "; ".join(f"{k}" for k, _ in alternatives)
    loose = [k for k, e in params.items() if not e.identifiable]
    held = [k for k, e in params.items() if e.identifiable]
    agreed = "".join(
        f" {k} = {params[k].value:.3f} m [{params[k].ci95[0]:.3f}, {params[k].ci95[1]:.3f}] "
        "is determined: every explanation agrees on it."
        for k in held
    )
    verdict = (
        f"Not determined: {', '.join(loose) or 'L1 + L2'}: the log cannot tell "
        f"{'it' if len(loose) <= 1 else 'them'} from other explanations ({why}), which imply "
        f"different values; the intervals span them.{agreed} The fit alone says L1 = "
        f"{est.parameters['L1'].value:.3f} m, L2 = {est.parameters['L2'].value:.3f} m."
    )
    return replace(est, parameters=params, derived=derived_sum(total, est.derived), verdict=verdict)


def recommended(estimate: CalibrationResult, disc: PathDiscovery) -> CalibrationResult:
    """The recommended path estimate after discovery along the path: with the accepted
    effects (when their refit worked), spanning explanations the log cannot tell apart,
    widened and not determined while the model does not explain the log, not determined for
    the whole log when the link lengths change mid-log (the pieces are in the discovery)."""
    if disc.adequacy is None:
        return estimate
    est = disc.estimate or estimate
    if disc.change is not None:
        short = (
            f"the link lengths change mid-log near t = {disc.change.t_s:.1f} s; see the "
            "estimates of each part"
        )
        params = {k: undetermined(e, short) for k, e in est.parameters.items()}
        sides = "; ".join(
            f"{a:.1f}-{b:.1f} s: L1 = {e.parameters['L1'].value:.3f} m, L2 = "
            f"{e.parameters['L2'].value:.3f} m"
            for a, b, e, _ in disc.split
        )
        return replace(
            est,
            parameters=params,
            derived={k: undetermined(e, short) for k, e in est.derived.items()},
            verdict=f"Not determined for the whole log: {disc.change.note}. Each part on its "
            f"own: {sides or 'not fitted'}.",
            details={**est.details, "change": disc.change.to_dict()},
        )
    est = _spanned(est, disc.alternatives)
    est = _across_explanations(est, disc)
    est = _widened_unstable(est, disc.stability)
    if disc.assumptions and any(e.identifiable for e in est.parameters.values()):
        est = replace(
            est,
            verdict=f"{est.verdict} These intervals assume "
            + "; ".join(detail for _short, detail in disc.assumptions)
            + ".",
            assumptions=(*est.assumptions, *(short for short, _detail in disc.assumptions)),
        )
    return est


def _final_fit(disc: PathDiscovery) -> ModelFit | None:
    """The joint fit of the model discovery ends with."""
    d, sel = disc.description, disc.selection
    if d is not None and d.accepted:
        return d.fit
    return sel.final if sel is not None else None


def _explanations(disc: PathDiscovery, est: CalibrationResult) -> list[Explanation]:
    """The final model (its link lengths the estimate's), the nominal one when effects were
    added, and a residual model that was not kept (what the structure left in the residual
    does to the link lengths)."""
    final, sel = _final_fit(disc), disc.selection
    if final is None or sel is None:
        return []
    out = [Explanation("final", final, {k: est.parameters[k] for k in ("L1", "L2")})]
    if final.effects:
        out.append(Explanation("nominal", sel.base))
    d = disc.description
    if d is not None and not d.accepted:
        out.append(Explanation("described", d.fit))
    return out


def _across_explanations(est: CalibrationResult, disc: PathDiscovery) -> CalibrationResult:
    """While the final model does not explain the log: the link lengths spanning the plausible
    explanations (``calib.discovery.across``), determined where they agree; with no other
    explanation to compare, the misfit widening (``estimate_under_misfit``)."""
    adequacy = disc.adequacy
    if adequacy is None or adequacy.explains or not adequacy.channels:
        return est
    ex = _explanations(disc, est)
    spanned = across(ex, ex[0], ["L1", "L2"], misfit=adequacy.misfit_factor) if len(ex) >= 2 else {}
    used = sorted({lab for s in spanned.values() for lab in s.values if lab != "final"})
    if not used:
        return estimate_under_misfit(est, adequacy, disc.thirds)
    params = {k: spanned[k].estimate if k in spanned else e for k, e in est.parameters.items()}
    others = [e for e in ex if e.label in used]
    total = link_sum(est)
    if total is not None:
        sums = [
            _est(
                "L1 + L2",
                o.estimates["L1"].value + o.estimates["L2"].value,
                o.estimates["L1"].std ** 2 + o.estimates["L2"].std ** 2,
                "m",
            )
            for o in others
        ]
        total = span([total, *sums], ["final", *used], rel_tol=0.1, scale=0.05)
    agree = all(s.agree for s in spanned.values())
    worst = max(adequacy.channels, key=lambda c: c.judged_ratio)
    verdict = (
        f"{est.verdict} The model ({adequacy.model}) leaves the joint angle at "
        f"{worst.judged_ratio:.2g}x its noise floor; the intervals span the explanations that "
        f"fit this log ({', '.join(used)}), which "
        + ("agree" if agree else "disagree")
        + f", each widened x{adequacy.misfit_factor:.2g} for the misfit: not determined."
    )
    return replace(est, parameters=params, derived=derived_sum(total, est.derived), verdict=verdict)


def _widened_unstable(
    est: CalibrationResult,
    stability: dict[str, PieceStability],
    rel_tol: float = 0.1,
) -> CalibrationResult:
    """``est`` with the link lengths that differ between pieces of the log beyond their errors
    widened (``calib.adequacy.widen_unstable``): physics the model leaves out moves them even
    where the residual stays near the noise floor. Not determined when the widened interval is
    no longer narrow, the verdict saying why."""
    if not any(st.unstable for st in stability.values()):
        return est
    scale = 0.5 * (abs(est.parameters["L1"].value) + abs(est.parameters["L2"].value))
    sizes = dict.fromkeys(STABILITY_NAMES, scale)
    named = dict(est.parameters)
    total = link_sum(est)
    if total is not None:
        named["L1+L2"] = total
    wide = widen_unstable(named, stability, rel_tol=rel_tol, scale=sizes)
    params = {k: wide[k] for k in est.parameters}
    total = wide.get("L1+L2") if total is not None else None
    lost = [k for k, e in wide.items() if not e.identifiable and named[k].identifiable]
    moved = ", ".join(
        f"{k} ({stability[k].chi2:.3g} on {stability[k].dof} dof)"
        for k in STABILITY_NAMES
        if k in stability and stability[k].unstable
    )
    verdict = est.verdict
    if lost:
        verdict = (
            f"Not determined: fitted on separate thirds of the log the link lengths "
            f"disagree beyond their errors (chi-square {moved}), so physics the model "
            f"leaves out moves them; the intervals are widened by that disagreement. "
            f"The fit says "
            + ", ".join(f"{k} = {e.value:.3f} m" for k, e in est.parameters.items())
            + "."
        )
    return replace(
        est,
        parameters=params,
        derived=derived_sum(total, est.derived),
        verdict=verdict,
        details={**est.details, "piece_stability": {k: v.to_dict() for k, v in stability.items()}},
    )


def adopt_effects(disc: PathDiscovery, keys: Sequence[str]) -> None:
    """Make the effects ``keys`` (the union of what both discovery engines accepted) the
    final model of ``disc``: its joint fit, adequacy (against the nominal model's) and the
    recommended estimate with them. Left as it was when that fit fails."""
    ctx = disc.context
    if ctx is None or not keys:
        return
    have = {e.key: e for e in disc.accepted}
    specs = tuple(have[k] if k in have else effect_by_key(k) for k in keys)
    fit = ctx.fitter(specs)
    if fit is None:
        disc.notes.append(
            f"the joint fit with {', '.join(keys)} failed; kept {nominal_label(disc.accepted)}"
        )
        return
    sol, _ = fit.payload
    est = _with_effects(ctx, specs, sol, disc.notes)
    if est is None:
        return
    adequacy = assess([ctx.channel(fit)], model=nominal_label(specs), before=ctx.nominal)
    if not adequacy.explains:
        adequacy = adequacy.with_(unexplained=unexplained_text(adequacy))
    disc.adequacy, disc.estimate, disc.solution = adequacy, est, sol
    disc.notes.append(
        f"the recommended estimate includes {', '.join(keys)} (accepted by either discovery engine)"
    )


def judge_path_fit(
    path: DrivePath,
    t_psi: np.ndarray,
    psi: np.ndarray,
    gaps: Sequence[tuple[float, float]],
    nominal_fit: PathTransientFit,
    *,
    segments: Sequence[tuple[str, float, float]] = (),
    reason: str = "",
) -> PathDiscovery:
    """Only the nominal model's adequacy (and its fits on thirds of the log, for intervals
    under a misfit), without searching for effects: ``status`` "not_run" with ``reason``."""
    model = JointPathModel(path, np.asarray(t_psi, float), np.asarray(psi, float), gaps)
    quantum = float(getattr(nominal_fit, "quantum_", 0.0))
    in_std = input_std(nominal_fit)
    x0 = np.concatenate(
        [
            [nominal_fit._x_raw[0], nominal_fit._x_raw[1]],
            nominal_fit.psi0_ if model.n_pieces == nominal_fit.n_pieces_ else model.psi0_guess,
        ]
    )
    sol = model.fit((), x0)
    held = heldout_residual(model, (), sol.x)
    adequacy = assess(
        [psi_channel(model, sol, held, quantum=quantum, input_std_rad=in_std, segments=segments)],
        model=NOMINAL,
    )
    if not adequacy.explains:
        adequacy = adequacy.with_(unexplained=unexplained_text(adequacy))
    out = PathDiscovery("not_run", reason, nominal=adequacy, adequacy=adequacy, solution=sol)
    out.thirds, out.stability = _thirds(_pieces(path, model.t, model.p, gaps, 3, checks=True))
    return out
