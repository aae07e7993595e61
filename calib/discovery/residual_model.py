"""The residual model: what the catalogue leaves out, modelled from the robot's own signals,
fitted jointly with the robot's parameters, and kept only when it improves the held-out fit.

1. *Screen*: every library term (:mod:`calib.discovery.library`) enters the model through each
   of the robot's *entries* (:class:`Entry`: the yaw rate, the speed, a joint's torque, the
   joint-angle reading: where an added quantity changes the residuals, in the residuals' noise
   units per unit coefficient). The current fit's residual is regressed on these columns by
   ensembled sparse regression with the threshold chosen on the held-out folds
   (:func:`calib.discovery.sparse.select_terms`).
2. *Model*: the kept terms become one effect of kind ``described`` (:func:`described_spec`,
   its hook :class:`DescribedTerms` giving the residual offsets of any coefficients), which the
   robot's fitter fits jointly with its parameters and the catalogue effects already accepted:
   the robot's parameters are re-estimated under it.
3. *Prune and judge*: terms whose coefficient is not significant are dropped and the rest
   refitted; the description is accepted when the held-out sum of squares falls by at least
   ``MIN_HELDOUT_GAIN`` of what the noise floor leaves to gain and the BIC by more than
   ``BIC_MARGIN`` (the engine's own selection rules: a described term earns its place as a
   catalogue effect does), by ``EXPLAINED_GAIN`` when the model already explains the log.

A described effect is not a catalogue name: it says which signals the residual follows and by
how much (:attr:`DescribedTerm.text`), in the units of the physics it changes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from calib.discovery.base import EffectKind, EffectParam, EffectSpec, Fitter, ModelFit
from calib.discovery.library import Term
from calib.discovery.selection import BIC_MARGIN, MIN_HELDOUT_GAIN, heldout_gain
from calib.discovery.sparse import TermSelection, select_terms
from calib.results import Estimate, json_safe
from calib.stats import Z95

__all__ = [
    "DESCRIBED_ID",
    "MAX_TERMS",
    "DescribedTerm",
    "DescribedTerms",
    "Description",
    "Entry",
    "HookFactory",
    "ResidualSpace",
    "describe",
    "described_spec",
]

FloatArray = NDArray[np.float64]

DESCRIBED_ID = "described"
MAX_TERMS = 6
"""At most this many terms in one description (the most often selected ones)."""
MAX_PRUNE = 4
EXPLAINED_GAIN = 0.3
"""The held-out gain a description must bring when the model it is added to already explains
the log (the residual at its noise floor): small structure is then the nominal model's own
approximation, not physics worth a name; a concealed cause that a parameter absorbed (a spring
taken into gravity) still shows by more."""
OWN_SHARE = 0.2
"""A term whose column the robot's own parameters reproduce but for less than this share of its
norm only mimics a parameter (a kinematic term proportional to the curvature is a change of the
link lengths): it is left out of the screen."""


@dataclass(frozen=True)
class Entry:
    """Where an added quantity enters the robot's model: ``name`` ("yaw rate"), the ``unit``
    of what a term adds there ("rad/s"), ``channel`` (the residual channel it changes most, for
    reports), and ``column(term)``: the model prediction's change per unit coefficient of
    ``term``, in the residuals' layout and noise units (the residual, recorded minus model,
    falls by it; None where the term cannot enter here)."""

    name: str
    unit: str
    channel: str
    column: Callable[[Term], FloatArray | None]


@dataclass(frozen=True)
class ResidualSpace:
    """A fit's residuals as the robot's fitter stacks them (noise units), with each element's
    held-out fold (-1: in no fold), and the entries a term may enter through."""

    residual: FloatArray
    fold: NDArray[np.intp]
    entries: Sequence[Entry]
    nuisance: FloatArray | None = None
    """Columns (n, p) of the robot's own parameters' effect on the residuals (the fit's
    Jacobian, noise units): the screen looks for what the terms add beyond them, so that a term
    that only mimics a parameter is not taken for physics."""


@dataclass(frozen=True)
class DescribedTerms:
    """The hook of a described effect: the residual offsets its coefficients make
    (``columns`` (n, k) in the robot's residual layout, one per parameter of the spec, in
    order). A robot's fitter subtracts :meth:`offsets` from its residuals."""

    names: tuple[str, ...]
    columns: FloatArray = field(repr=False)

    def offsets(self, values: Mapping[str, float]) -> FloatArray:
        c = np.array([values[n] for n in self.names], dtype=float)
        out: FloatArray = self.columns @ c
        return out


@dataclass(frozen=True)
class DescribedTerm:
    """One term of a described effect: the entry it acts through, the library term, and its
    coefficient (in the entry's unit per the term's unit)."""

    entry: str
    term: Term
    coefficient: Estimate
    channel: str = ""

    @property
    def text(self) -> str:
        c = self.coefficient
        unit = c.unit
        return (
            f"{self.entry} + {c.value:.4g} {unit} x {self.term.name} ({self.term.words}; 95 %: "
            f"{c.ci95[0]:.3g} to {c.ci95[1]:.3g})"
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "entry": self.entry,
                "channel": self.channel,
                "term": self.term.name,
                "family": str(self.term.family),
                "words": self.term.words,
                "coefficient": self.coefficient.to_dict(),
                "text": self.text,
            }
        )


@dataclass(frozen=True)
class Description:
    """What the residual model found: the described ``spec`` fitted in ``fit`` (the robot's
    parameters re-estimated under it), its ``terms``, the held-out gain and BIC change against
    ``before`` (the model it was added to), ``accepted`` by the engine's rules, and what the
    screen saw (``screened``, the number of candidate columns)."""

    spec: EffectSpec[Any]
    fit: ModelFit
    before: ModelFit
    terms: tuple[DescribedTerm, ...]
    heldout_gain: float
    delta_bic: float
    accepted: bool
    screened: TermSelection
    candidates: int

    @property
    def text(self) -> str:
        return "; ".join(t.text for t in self.terms)

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "accepted": self.accepted,
                "terms": [t.to_dict() for t in self.terms],
                "heldout_gain": self.heldout_gain,
                "delta_bic": self.delta_bic,
                "candidates": self.candidates,
                "threshold": self.screened.threshold,
                "text": self.text,
            }
        )


@dataclass(frozen=True)
class _Column:
    entry: Entry
    term: Term
    values: FloatArray


def _columns(space: ResidualSpace, library: Sequence[Term]) -> list[_Column]:
    out = []
    n = space.residual.size
    for entry in space.entries:
        for term in library:
            c = entry.column(term)
            if c is None or c.size != n or not np.all(np.isfinite(c)) or float(np.std(c)) <= 0:
                continue
            out.append(_Column(entry, term, np.asarray(c, dtype=float)))
    return out


def _beyond(x: FloatArray, nuisance: FloatArray | None) -> FloatArray:
    """The columns of ``x`` with what ``nuisance`` spans projected out (least squares)."""
    if nuisance is None or nuisance.size == 0:
        return x
    n = np.where(np.isfinite(nuisance), nuisance, 0.0)
    coef, *_ = np.linalg.lstsq(n, x, rcond=None)
    out: FloatArray = x - n @ coef
    return out


def _param_name(col: _Column) -> str:
    return f"{col.entry.name}: {col.term.name}"


def _coef_unit(col: _Column) -> str:
    u = col.term.unit
    if u in ("", "1"):
        return col.entry.unit
    return f"{col.entry.unit} per ({u})" if "·" in u or "/" in u else f"{col.entry.unit} per {u}"


HookFactory = Callable[[Sequence[tuple[str, Entry, Term]]], Any]
"""Builds a robot's own hook for a described effect from its (parameter name, entry, term)
triples, where the robot's fitter needs more than residual offsets (the diff drive turns the
terms into wheel increments, so that the data can be corrected by them)."""


def described_spec(
    cols: Sequence[_Column],
    init: Sequence[float],
    channels: str,
    hook: HookFactory | None = None,
) -> EffectSpec[Any]:
    """One described effect holding ``cols`` (their coefficients its parameters, null 0); its
    hook :class:`DescribedTerms`, or what ``hook`` makes of the terms."""
    names = tuple(_param_name(c) for c in cols)
    params = tuple(
        EffectParam(n, _coef_unit(c), 0.0, -1e12, 1e12, float(v))
        for n, c, v in zip(names, cols, init, strict=True)
    )
    words = "; ".join(f"{c.entry.name} follows {c.term.words}" for c in cols)
    return EffectSpec(
        DESCRIBED_ID,
        channels,
        EffectKind.DESCRIBED,
        params,
        f"not a catalogued effect: {words}",
        model=(
            hook([(n, c.entry, c.term) for n, c in zip(names, cols, strict=True)])
            if hook is not None
            else DescribedTerms(names, np.column_stack([c.values for c in cols]))
        ),
    )


def _significant(fit: ModelFit, spec: EffectSpec[Any]) -> list[bool]:
    pars = fit.effect_parameters.get(spec.key, {})
    out = []
    for p in spec.params:
        e = pars.get(p.name)
        out.append(
            e is not None and math.isfinite(e.std) and e.std > 0 and abs(e.value) > Z95 * e.std
        )
    return out


def _fit_kept(
    fitter: Fitter,
    current: ModelFit,
    cols: list[_Column],
    init: list[float],
    channels: str,
    hook: HookFactory | None,
) -> tuple[EffectSpec[Any], ModelFit, list[_Column]] | None:
    """Fit the described effect of ``cols`` and drop the insignificant terms until all are
    significant (at most ``MAX_PRUNE`` refits)."""
    for _ in range(MAX_PRUNE):
        spec = described_spec(cols, init, channels, hook)
        fit = fitter((*current.effects, spec))
        if fit is None:
            return None
        sig = _significant(fit, spec)
        if all(sig):
            return spec, fit, cols
        if not any(sig):
            return None
        vals = fit.effect_parameters[spec.key]
        init = [vals[p.name].value for p, s in zip(spec.params, sig, strict=True) if s]
        cols = [c for c, s in zip(cols, sig, strict=True) if s]
    return None


def describe(
    fitter: Fitter,
    current: ModelFit,
    space: ResidualSpace,
    library: Sequence[Term],
    *,
    seed: int = 0,
    block: int = 50,
    hook: HookFactory | None = None,
    explained: bool = False,
    forward: bool = False,
) -> Description | None:
    """Model the residual of ``current`` (module docstring); None when the screen keeps no term
    or the joint fit fails. The description is returned whether or not it is accepted (an
    unaccepted one still says what the residual follows). ``forward``: when the screen's whole
    set is not kept, the best kept prefix of it (in the screen's order) is (default off)."""
    cols = _columns(space, library)
    if not cols:
        return None
    raw = np.column_stack([c.values for c in cols])
    x = _beyond(raw, space.nuisance)
    own = np.linalg.norm(x, axis=0) >= OWN_SHARE * np.linalg.norm(raw, axis=0)
    cols = [c for c, k in zip(cols, own, strict=True) if k]
    if not cols:
        return None
    x = x[:, own]
    # residual (recorded - model) ~ X c: the terms add X c to the model's prediction
    sel = select_terms(x, space.residual, space.fold, block=block, seed=seed)
    if sel is None:
        return None
    order = sorted(range(len(sel.kept)), key=lambda i: -sel.inclusion[i])[:MAX_TERMS]
    kept = [cols[sel.kept[i]] for i in order]
    init = [sel.coef[i] for i in order]
    need = EXPLAINED_GAIN if explained else MIN_HELDOUT_GAIN
    found = _judged(fitter, current, kept, init, hook, need)
    if found is None:
        return None
    if forward and not found[3] and len(kept) > 1:
        # the screen's set, fitted jointly, may overfit where its terms are nearly collinear
        # with the robot's own: grown term by term instead, each step the term whose joint fit
        # is kept with the largest held-out gain
        found = _forward(fitter, current, kept, init, hook, need) or found
    spec, fit, kept, ok, gain, dbic = found
    pars = fit.effect_parameters[spec.key]
    terms = tuple(
        DescribedTerm(c.entry.name, c.term, pars[p.name], c.entry.channel)
        for c, p in zip(kept, spec.params, strict=True)
    )
    return Description(spec, fit, current, terms, gain, dbic, ok, sel, len(cols))


def _forward(
    fitter: Fitter,
    current: ModelFit,
    kept: list[_Column],
    init: list[float],
    hook: HookFactory | None,
    need: float,
) -> tuple[EffectSpec[Any], ModelFit, list[_Column], bool, float, float] | None:
    """Forward selection over the screen's terms by the joint fit: None when no single term is
    kept."""
    start = dict(zip((id(c) for c in kept), init, strict=True))
    chosen: list[_Column] = []
    best: tuple[EffectSpec[Any], ModelFit, list[_Column], bool, float, float] | None = None
    for _ in range(len(kept)):
        step = None
        for c in kept:
            if any(c is x for x in chosen):
                continue
            trial = [*chosen, c]
            got = _judged(fitter, current, trial, [start[id(x)] for x in trial], hook, need)
            if got is None or not got[3] or (best is not None and got[4] <= best[4]):
                continue
            if step is None or got[4] > step[4]:
                step = got
        if step is None:
            break
        best = step
        chosen = list(step[2])
    return best


def _judged(
    fitter: Fitter,
    current: ModelFit,
    kept: list[_Column],
    init: list[float],
    hook: HookFactory | None,
    need: float,
) -> tuple[EffectSpec[Any], ModelFit, list[_Column], bool, float, float] | None:
    """The described effect of ``kept`` fitted and pruned (:func:`_fit_kept`), with whether the
    engine's rules keep it, its held-out gain and its BIC change."""
    channels = ", ".join(dict.fromkeys(c.entry.channel for c in kept))
    done = _fit_kept(fitter, current, kept, init, channels, hook)
    if done is None:
        return None
    spec, fit, cols = done
    gain = heldout_gain(current, fit)
    dbic = fit.bic - current.bic
    return spec, fit, cols, bool(gain >= need and dbic < -BIC_MARGIN), gain, dbic
