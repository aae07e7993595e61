"""Forward selection of effects, one engine for every robot: which physics, added to the
nominal model, explains the log better on held-out data, and which explanations the log cannot
tell apart.

The robot supplies a fitter (:class:`~calib.discovery.base.Fitter`: given a set of effects, it
fits its parameters and theirs and returns a :class:`~calib.discovery.base.ModelFit`). Each
round fits every remaining candidate added to the current model and accepts, among the
candidates that pass every rule, the best ranked one (lowest BIC unless the robot ranks
otherwise, :attr:`Checks.rank`). A candidate passes when

- *significant*: every parameter lies at least ``SelectionRules.min_z`` standard errors from
  the value at which the effect does nothing;
- *material*: the held-out sum of squares falls by at least ``min_heldout_gain`` of what the
  noise floor leaves to gain (or the robot's own test, :attr:`Checks.material`: a fall on one of
  the channels the effect acts on, say);
- *strong evidence*: the BIC falls by more than ``bic_margin``;
- *interior* (with ``require_interior``): no effect parameter sits on a bound of its fit;

and, when the robot supplies :attr:`Checks.stable`, the ranked passing candidates are checked in
turn for being *constant* (the same value on separate parts of the log: a physical effect has
one value, a catalogue effect that only mimics something else drifts); the first constant one
is accepted. When no candidate passes a round only because the strongest ones drift and
``pairs`` is set, pairs are tried (an effect can look inconstant while another one it interacts
with is missing), accepted under the same rules at twice the BIC margin and recorded as two
consecutive rounds.

Among the accepted round's passing candidates, another that fits within ``bic_margin`` but moves
a robot parameter by more than twice their combined standard error is a *confound*: the log
cannot tell the two explanations apart and they imply different parameters; the robot's
estimate then spans them and the report names the pair. Selection stops when no candidate is
accepted, when the model explains the log (:attr:`Checks.explained`), or at ``max_effects``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from calib.discovery.base import CandidateFailedError, EffectSpec, Fitter, ModelFit
from calib.results import json_safe
from calib.stats import Z95

__all__ = [
    "BIC_MARGIN",
    "MIN_HELDOUT_GAIN",
    "Checks",
    "Confound",
    "Round",
    "Selection",
    "SelectionRules",
    "Tried",
    "heldout_gain",
    "select_effects",
]

BIC_MARGIN = 10.0
MIN_HELDOUT_GAIN = 0.1

Spec = EffectSpec[Any]


@dataclass(frozen=True)
class SelectionRules:
    """Thresholds of the rules (module docstring)."""

    max_effects: int = 2
    bic_margin: float = BIC_MARGIN
    min_heldout_gain: float = MIN_HELDOUT_GAIN
    min_z: float = Z95
    require_interior: bool = False
    pairs: bool = False
    pair_seeds: int = 2


@dataclass(frozen=True)
class Checks:
    """A robot's own tests, where the engine's defaults do not fit it.

    ``material(candidate, current, added)``: the candidate's fit improves on the current one
    materially (default: :func:`heldout_gain` at least ``min_heldout_gain``); ``rank(fit)``:
    lower is better among passing candidates (default: the BIC change); ``stable(fit, spec)``:
    (is ``spec`` constant in ``fit``, what the check saw, JSON-safe); ``explained(fit)``:
    stop once it says the model explains the log."""

    material: Callable[[ModelFit, ModelFit, tuple[Spec, ...]], bool] | None = None
    rank: Callable[[ModelFit], float] | None = None
    stable: Callable[[ModelFit, Spec], tuple[bool, Any]] | None = None
    explained: Callable[[ModelFit], bool] | None = None


@dataclass(frozen=True)
class Tried:
    """One candidate of one round: its key, BIC change against the round's base, held-out
    gain (fraction of the base's held-out excess over the floor removed), whether its intervals
    exclude the null, whether it was material, constant (None: not checked) and accepted;
    ``detail``: what the constancy check saw; ``fit``: the candidate's fit."""

    round: int
    key: str
    delta_bic: float
    heldout_gain: float
    excludes_null: bool
    accepted: bool
    material: bool = True
    stable: bool | None = None
    detail: Any = None
    fit: ModelFit | None = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "round": self.round,
                "key": self.key,
                "delta_bic": self.delta_bic,
                "heldout_gain": self.heldout_gain,
                "excludes_null": self.excludes_null,
                "material": self.material,
                "stable": self.stable,
                "accepted": self.accepted,
            }
        )


@dataclass(frozen=True)
class Round:
    """One round: the model before it, its candidates, the accepted one and the candidates
    whose fit failed (key -> reason)."""

    number: int
    before: ModelFit
    tried: tuple[Tried, ...]
    accepted: Tried | None
    failed: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Confound:
    """Two explanations the log cannot tell apart that imply different robot parameters."""

    reported: str
    alternative: str
    delta_bic: float
    parameters: Mapping[str, tuple[float, float]]
    """parameter -> (value under the reported, value under the alternative)."""
    alternative_fit: ModelFit = field(compare=False, repr=False)

    @property
    def note(self) -> str:
        moved = ", ".join(f"{k} {a:.4g} vs {b:.4g}" for k, (a, b) in self.parameters.items())
        return (
            f"{self.reported} and {self.alternative} fit this log equally well "
            f"(BIC {self.delta_bic:+.1f}) but imply different parameters ({moved})"
        )

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "reported": self.reported,
                "alternative": self.alternative,
                "delta_bic": self.delta_bic,
                "parameters": {k: list(v) for k, v in self.parameters.items()},
                "note": self.note,
            }
        )


@dataclass(frozen=True)
class Selection:
    """What forward selection found: ``base`` (nominal), ``final`` (with the accepted
    effects), each round's candidates (``tried``; ``rounds`` with the model before each), and
    the confounds of the accepted effects."""

    base: ModelFit
    final: ModelFit
    tried: tuple[Tried, ...]
    confounds: tuple[Confound, ...]
    rounds: tuple[Round, ...] = ()

    @property
    def accepted(self) -> tuple[Spec, ...]:
        return self.final.effects

    def to_dict(self) -> dict[str, Any]:
        return json_safe(
            {
                "model": self.final.label,
                "accepted": list(self.final.keys),
                "effects": {
                    key: {n: e.to_dict() for n, e in pars.items()}
                    for key, pars in self.final.effect_parameters.items()
                },
                "heldout_sse_before": self.base.heldout_sse,
                "heldout_sse_after": self.final.heldout_sse,
                "tried": [t.to_dict() for t in self.tried],
                "confounds": [c.to_dict() for c in self.confounds],
            }
        )


def heldout_gain(base: ModelFit, cand: ModelFit) -> float:
    """Fraction of the base's held-out excess (over one unit per sample: residuals are in units
    of the noise floor) that ``cand`` removes; in-sample when nothing was held out."""
    b, c = base.heldout_sse, cand.heldout_sse
    n = base.n_heldout if base.n_heldout is not None else base.n
    if not (math.isfinite(b) and math.isfinite(c)):
        b, c, n = base.sse, cand.sse, base.n
    excess = b - n if math.isfinite(b) else math.nan
    if not excess > 0:
        return (b - c) / b if b > 0 else 0.0
    return (b - c) / excess


def _moves(a: ModelFit, b: ModelFit) -> dict[str, tuple[float, float]]:
    moved = {}
    for name, ea in a.parameters.items():
        eb = b.parameters.get(name)
        if eb is None:
            continue
        s = math.hypot(ea.std, eb.std)
        if math.isfinite(s) and abs(ea.value - eb.value) > 2.0 * s:
            moved[name] = (ea.value, eb.value)
    return moved


@dataclass
class _Scored:
    spec: Spec
    fit: ModelFit
    delta_bic: float
    gain: float
    significant: bool
    material: bool
    passes: bool
    stable: bool | None = None
    detail: Any = None


class _Engine:
    """One selection's state: the fitter, rules, checks and what was tried."""

    def __init__(self, fit: Fitter, rules: SelectionRules, checks: Checks) -> None:
        self.fit, self.rules, self.checks = fit, rules, checks

    def fit_or_reason(self, effects: tuple[Spec, ...]) -> ModelFit | str | None:
        try:
            return self.fit(effects)
        except CandidateFailedError as err:
            return err.reason

    def significant(self, fit: ModelFit, specs: Sequence[Spec]) -> bool:
        for spec in specs:
            pars = fit.effect_parameters.get(spec.key, {})
            for p in spec.params:
                e = pars.get(p.name)
                if e is None or not math.isfinite(e.std) or e.std <= 0:
                    return False
                if abs(e.value - p.null) < self.rules.min_z * e.std:
                    return False
        return True

    def material(self, cand: ModelFit, current: ModelFit, added: tuple[Spec, ...]) -> bool:
        if self.checks.material is not None:
            return self.checks.material(cand, current, added)
        return heldout_gain(current, cand) >= self.rules.min_heldout_gain

    def score(
        self, spec: Spec, cand: ModelFit, current: ModelFit, added: tuple[Spec, ...], scale: float
    ) -> _Scored:
        dbic = cand.bic - current.bic
        sig = self.significant(cand, added)
        mat = self.material(cand, current, added)
        interior = not (self.rules.require_interior and cand.at_bound)
        ok = sig and mat and interior and dbic < -scale * self.rules.bic_margin
        return _Scored(spec, cand, dbic, heldout_gain(current, cand), sig, mat, ok)

    def rank_key(self, s: _Scored) -> tuple[float, float]:
        r = self.checks.rank(s.fit) if self.checks.rank is not None else s.delta_bic
        return (r, s.delta_bic)

    def first_stable(self, passing: Sequence[_Scored], specs: Sequence[Spec]) -> _Scored | None:
        """The best ranked passing candidate that is constant (each of ``specs``, the added
        effects, where the robot checks it)."""
        for s in sorted(passing, key=self.rank_key):
            if self.checks.stable is None:
                return s
            ok, detail = True, list[Any]()
            for spec in specs or (s.spec,):
                good, what = self.checks.stable(s.fit, spec)
                ok, detail = ok and good, [*detail, what]
                if not ok:
                    break
            s.stable, s.detail = ok, detail[0] if len(detail) == 1 else detail
            if ok:
                return s
        return None


def _tried(rnd: int, s: _Scored, accepted: bool) -> Tried:
    return Tried(
        rnd,
        s.spec.key,
        s.delta_bic,
        s.gain,
        s.significant,
        accepted,
        s.material,
        s.stable,
        s.detail,
        s.fit,
    )


def _confounds(best: _Scored, good: Sequence[_Scored], margin: float) -> list[Confound]:
    out = []
    for s in good:
        if s.spec.key == best.spec.key:
            continue
        if s.fit.bic - best.fit.bic < margin:
            moved = _moves(best.fit, s.fit)
            if moved:
                out.append(
                    Confound(best.spec.key, s.spec.key, s.fit.bic - best.fit.bic, moved, s.fit)
                )
    return out


def _round(
    eng: _Engine, current: ModelFit, catalogue: Sequence[Spec], progress: Callable[[str], None]
) -> tuple[list[_Scored], dict[str, str]]:
    """Every candidate not yet in ``current`` fitted and scored."""
    taken = set(current.keys)
    scored: list[_Scored] = []
    failed: dict[str, str] = {}
    for spec in catalogue:
        if spec.key in taken:
            continue
        progress(f"trying {spec.key}")
        cand = eng.fit_or_reason((*current.effects, spec))
        if isinstance(cand, str):
            failed[spec.key] = cand
        elif cand is not None:
            scored.append(eng.score(spec, cand, current, (spec,), 1.0))
    return scored, failed


def _pair_round(
    eng: _Engine,
    current: ModelFit,
    scored: Sequence[_Scored],
    catalogue: Sequence[Spec],
) -> tuple[_Scored, _Scored, list[_Scored]] | None:
    """Two effects at once (module docstring): the (at most ``pair_seeds``) strongest
    candidates that passed all but constancy, each paired with every other candidate; the pair
    ranked best whose both effects are constant. Returns (the first effect's and the second's
    scores, both holding the pair's fit, and every pair tried), or None."""
    seeds = sorted(
        (s for s in scored if s.stable is False and s.passes),
        key=eng.rank_key,
    )[: eng.rules.pair_seeds]
    taken = set(current.keys)
    found: list[tuple[_Scored, _Scored]] = []
    pairs: list[_Scored] = []
    for seed in seeds:
        for spec in catalogue:
            if spec.key in taken or spec.key == seed.spec.key:
                continue
            added = (seed.spec, spec)
            cand = eng.fit_or_reason((*current.effects, *added))
            if cand is None or isinstance(cand, str):
                continue
            second = eng.score(spec, cand, current, added, 2.0)
            pairs.append(second)
            if second.passes:
                first = replace(second, spec=seed.spec)
                found.append((first, second))
    for first, second in sorted(found, key=lambda fs: eng.rank_key(fs[1])):
        ok = eng.first_stable([first], (first.spec,))
        ok2 = eng.first_stable([second], (second.spec,)) if ok is not None else None
        if ok is not None and ok2 is not None:
            return first, second, pairs
    return None


def select_effects(
    fit: Fitter,
    catalogue: Sequence[Spec],
    *,
    max_effects: int | None = None,
    explained: Callable[[ModelFit], bool] | None = None,
    progress: Callable[[str], None] | None = None,
    rules: SelectionRules | None = None,
    checks: Checks | None = None,
) -> Selection | None:
    """Forward selection over ``catalogue`` (see the module docstring); None when the nominal
    fit itself fails. ``max_effects`` and ``explained`` override ``rules.max_effects`` and
    ``checks.explained``."""
    rules = rules or SelectionRules()
    if max_effects is not None:
        rules = replace(rules, max_effects=max_effects)
    checks = checks or Checks()
    if explained is not None:
        checks = replace(checks, explained=explained)
    eng = _Engine(fit, rules, checks)
    say = progress if progress is not None else (lambda _msg: None)
    base = eng.fit_or_reason(())
    if base is None or isinstance(base, str):
        return None
    current = base
    tried: list[Tried] = []
    confounds: list[Confound] = []
    rounds: list[Round] = []
    while len(current.effects) < rules.max_effects:
        if checks.explained is not None and checks.explained(current):
            break
        if all(spec.key in current.keys for spec in catalogue):
            break
        number = len(rounds) + 1
        scored, failed = _round(eng, current, catalogue, say)
        passing = [s for s in scored if s.passes]
        best = eng.first_stable(passing, ())
        if best is None and rules.pairs and len(current.effects) + 2 <= rules.max_effects:
            pair = _pair_round(eng, current, scored, catalogue)
            if pair is not None:
                first, second, pairs = pair
                one = tuple(_tried(number, s, False) for s in scored)
                two = tuple(_tried(number + 1, s, s is second) for s in pairs)
                head = _tried(number, first, True)
                rounds += [
                    Round(number, current, one, head, failed),
                    Round(number + 1, current, two, _tried(number + 1, second, True)),
                ]
                tried += [*one, *two]
                current = second.fit
                continue
        these = tuple(_tried(number, s, s is best) for s in scored)
        tried += these
        rounds.append(
            Round(
                number, current, these, None if best is None else these[scored.index(best)], failed
            )
        )
        if best is None:
            break
        confounds += _confounds(best, passing, rules.bic_margin)
        current = best.fit
    return Selection(base, current, tuple(tried), tuple(confounds), tuple(rounds))
