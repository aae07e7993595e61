"""Forward selection of effects, shared by every robot: which physics, added to the nominal
model, explains the log better on held-out data, and which explanations the log cannot tell
apart.

The robot supplies a fitter: given a set of effects, it fits its parameters and theirs and
returns a :class:`ModelFit` (in-sample and held-out residual sums over the noise floor, its
parameters and the effects' with standard errors). An effect is accepted when

- its parameters' 95 % intervals exclude the value at which it does nothing,
- the held-out sum of squares falls by at least ``MIN_HELDOUT_GAIN`` of what the noise floor
  leaves to gain, and
- the BIC falls by more than ``BIC_MARGIN``.

Among the accepted round's candidates, another that fits within ``BIC_MARGIN`` but moves a robot
parameter by more than twice their combined standard error is a *confound*: the log cannot tell
the two explanations apart and they imply different parameters; the robot's estimate then spans
them (:func:`calib.adequacy.intervals.span`) and the report names the pair. Selection stops when
no candidate is accepted, when the model explains the log, or at ``max_effects``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from calib.adequacy.effects import EffectSpec
from calib.adequacy.intervals import Z95
from calib.results import Estimate, json_safe

__all__ = [
    "BIC_MARGIN",
    "Confound",
    "Fitter",
    "ModelFit",
    "Selection",
    "Tried",
    "select_effects",
]

BIC_MARGIN = 10.0
MIN_HELDOUT_GAIN = 0.1


@dataclass(frozen=True)
class ModelFit:
    """The nominal model plus ``effects``, fitted.

    ``parameters``: the robot's parameters; ``effect_parameters``: by effect key, its
    parameters; ``sse``: in-sample sum of squared residuals over the noise floor (so channels in
    different units add); ``heldout_sse``: the same on held-out samples (math.nan: none);
    ``n``: samples; ``k``: fitted parameters; ``n_heldout``: held-out samples (default ``n``);
    ``n_eff``: the effective number of independent samples when the residuals are correlated
    (a 500 Hz torque, overlapping windows; default ``n``): the BIC then counts evidence at that
    rate, so that correlated samples do not make every candidate clear its margin;
    ``payload``: whatever the robot needs again (residual channels, its estimator object)."""

    effects: tuple[EffectSpec, ...]
    parameters: Mapping[str, Estimate]
    effect_parameters: Mapping[str, Mapping[str, Estimate]]
    sse: float
    heldout_sse: float
    n: int
    k: int
    payload: Any = field(default=None, compare=False, repr=False)
    n_heldout: int | None = None
    n_eff: float | None = None

    @property
    def keys(self) -> tuple[str, ...]:
        return tuple(e.key for e in self.effects)

    @property
    def label(self) -> str:
        return " + ".join(self.keys) if self.effects else "nominal"

    @property
    def bic(self) -> float:
        """BIC at the effective sample size: n_eff ln(sse / n) + k ln(n_eff)."""
        if self.n <= 0 or not self.sse > 0:
            return math.inf if self.n <= 0 else -math.inf
        m = min(float(self.n), self.n_eff) if self.n_eff and self.n_eff > 0 else float(self.n)
        return m * math.log(self.sse / self.n) + self.k * math.log(m)


Fitter = Callable[[tuple[EffectSpec, ...]], ModelFit | None]
"""Fit the robot's model with these effects; None when that fit fails (it is then skipped)."""


@dataclass(frozen=True)
class Tried:
    """One candidate of one round: its key, BIC change against the round's base, held-out
    gain (fraction of the base's held-out excess over the floor removed), whether its intervals
    exclude the null, and accepted or not."""

    round: int
    key: str
    delta_bic: float
    heldout_gain: float
    excludes_null: bool
    accepted: bool


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
    effects), each round's candidates, and the confounds of the accepted effects."""

    base: ModelFit
    final: ModelFit
    tried: tuple[Tried, ...]
    confounds: tuple[Confound, ...]

    @property
    def accepted(self) -> tuple[EffectSpec, ...]:
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
                "tried": [t.__dict__ for t in self.tried],
                "confounds": [c.to_dict() for c in self.confounds],
            }
        )


def _excludes_null(fit: ModelFit, spec: EffectSpec) -> bool:
    pars = fit.effect_parameters.get(spec.key, {})
    for p in spec.params:
        e = pars.get(p.name)
        if e is None or not math.isfinite(e.std) or e.std <= 0:
            return False
        if abs(e.value - p.null) <= Z95 * e.std:
            return False
    return True


def _gain(base: ModelFit, cand: ModelFit) -> float:
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


def select_effects(
    fit: Fitter,
    catalogue: Sequence[EffectSpec],
    *,
    max_effects: int = 2,
    explained: Callable[[ModelFit], bool] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Selection | None:
    """Forward selection over ``catalogue`` (see the module docstring); None when the nominal
    fit itself fails. ``explained(fit)``: stop once it says the model explains the log."""
    base = fit(())
    if base is None:
        return None
    current, tried, confounds = base, [], []
    for rnd in range(1, max_effects + 1):
        if explained is not None and explained(current):
            break
        taken = set(current.keys)
        results: list[tuple[EffectSpec, ModelFit]] = []
        for spec in catalogue:
            if spec.key in taken:
                continue
            if progress is not None:
                progress(f"trying {spec.key}")
            cand = fit((*current.effects, spec))
            if cand is not None:
                results.append((spec, cand))
        scored = []
        for spec, cand in results:
            dbic = cand.bic - current.bic
            gain = _gain(current, cand)
            excl = _excludes_null(cand, spec)
            ok = excl and gain >= MIN_HELDOUT_GAIN and dbic < -BIC_MARGIN
            scored.append((spec, cand, dbic, gain, excl, ok))
        good = [s for s in scored if s[5]]
        best = min(good, key=lambda s: s[2]) if good else None
        for spec, _, dbic, gain, excl, _ok in scored:
            tried.append(
                Tried(rnd, spec.key, dbic, gain, excl, best is not None and spec.key == best[0].key)
            )
        if best is None:
            break
        for spec, cand, *_ in good:
            if spec.key == best[0].key:
                continue
            if cand.bic - best[1].bic < BIC_MARGIN:
                moved = _moves(best[1], cand)
                if moved:
                    confounds.append(
                        Confound(best[0].key, spec.key, cand.bic - best[1].bic, moved, cand)
                    )
        current = best[1]
    return Selection(base, current, tuple(tried), tuple(confounds))
