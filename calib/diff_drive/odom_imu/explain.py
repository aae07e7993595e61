"""After selection: the named effects that do not earn their place beside the others taken out
(backward elimination under the engine's rules: an effect goes, or gives way to a simpler one it
contains, when the model without it is as good held out and by the BIC), the residual the gain
law leaves modelled from the log's own signals (:func:`calib.discovery.describe`, kept by the
engine's rules), and the gain law of the model that ends discovery re-estimated and
re-reported (:mod:`calib.diff_drive.odom_imu.law`), for the final model and for each confound's
alternative."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from calib.diff_drive.odom_imu.described import described_hook, entry, library, space
from calib.diff_drive.odom_imu.fitter import GainFitter, GainPayload
from calib.diff_drive.odom_imu.law import GainLaw, gain_law
from calib.diff_drive.odom_imu.windows import FOLD_S, WINDOW_S
from calib.discovery import (
    BIC_MARGIN,
    MIN_HELDOUT_GAIN,
    CandidateFailedError,
    Description,
    EffectKind,
    EffectSpec,
    ModelFit,
    Selection,
    describe,
    heldout_gain,
)

__all__ = ["Explained", "explain"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Explained:
    """The model discovery ends with (``final``: the selection's, with the described effect when
    it was accepted), the description tried (accepted or not), the final law and each
    alternative's (label -> law)."""

    final: ModelFit
    description: Description | None
    law: GainLaw | None
    alternatives: dict[str, GainLaw]
    dropped: tuple[str, ...] = ()
    """Named effects the rest of the final model made redundant (removed, or replaced by a
    simpler catalogue effect), as notes."""


def _describe(
    fitter: GainFitter, current: ModelFit, t: Array, v: Array, omega: Array, explained: bool
) -> Description | None:
    pay: GainPayload = current.payload
    ent = entry(t, fitter.w, fitter.use, fitter.sigma)
    sp = space(pay.residual, fitter.use, fitter.folds, ent, pay.jac)
    block = max(4, round(FOLD_S / WINDOW_S))
    try:
        return describe(
            fitter,
            current,
            sp,
            library(t, v, omega),
            block=block,
            hook=described_hook(t, fitter.w),
            explained=explained,
        )
    except (ValueError, np.linalg.LinAlgError):
        return None


def _covers(e: EffectSpec) -> set[str]:
    return set(getattr(e.model, "covers", ()))


def _without(
    fitter: GainFitter, current: ModelFit, catalogue: Sequence[EffectSpec]
) -> tuple[ModelFit, str] | None:
    """The first named effect of ``current`` that does not earn its place beside the others:
    removed, or replaced by the simplest catalogue effect (or two) fitting part of what it fits,
    when the model without it is as good on held-out data (``current`` removes less than
    ``MIN_HELDOUT_GAIN`` of its excess) and by the BIC (``current`` not lower by
    ``BIC_MARGIN``)."""
    named = [e for e in current.effects if str(e.kind) != str(EffectKind.DESCRIBED)]
    for e in named:
        inner = [s for s in catalogue if _covers(s) and _covers(s) < _covers(e)]
        # one simpler effect, or two that split what it fits between them
        subs: list[tuple[EffectSpec, ...]] = [(s,) for s in inner]
        subs += [
            (a, b)
            for i, a in enumerate(inner)
            for b in inner[i + 1 :]
            if not _covers(a) & _covers(b) and _covers(a) | _covers(b) < _covers(e)
        ]
        subs.sort(key=lambda sub: sum(len(x.params) for x in sub))
        for sub in [(), *subs]:
            effects = (*sub, *(x for x in current.effects if x is not e))
            try:
                fit = fitter(effects)
            except CandidateFailedError:
                continue
            if fit is None:
                continue
            if (
                heldout_gain(fit, current) < MIN_HELDOUT_GAIN
                and current.bic - fit.bic > -BIC_MARGIN
            ):
                how = "dropped" if not sub else "replaced by " + " + ".join(x.key for x in sub)
                return fit, f"{e.key} {how}: the rest of the model explains what it took"
    return None


def _pruned(
    fitter: GainFitter, fit: ModelFit, catalogue: Sequence[EffectSpec]
) -> tuple[ModelFit, tuple[str, ...]]:
    """``fit`` with the named effects that do not earn their place taken out
    (:func:`_without`, repeated): forward selection adds the ICR model, which holds a constant
    gain, where the log's physics is a constant gain and a growth the ICR model lacks, and the
    growth added next makes its slip terms redundant."""
    current, notes = fit, []
    for _ in range(len(current.effects)):
        step = _without(fitter, current, catalogue)
        if step is None:
            break
        current, why = step
        notes.append(why)
    return current, tuple(notes)


def _simpler(
    fitter: GainFitter, d: Description, catalogue: Sequence[EffectSpec]
) -> tuple[Description, tuple[str, ...]]:
    """``d`` with the named effects it made redundant taken out (:func:`_pruned`)."""
    current, notes = _pruned(fitter, d.fit, catalogue)
    if current is d.fit:
        return d, ()
    pars = current.effect_parameters.get(d.spec.key, {})
    terms = tuple(
        replace(t, coefficient=pars.get(t.coefficient.name, t.coefficient)) for t in d.terms
    )
    return replace(d, fit=current, terms=terms), notes


def explain(
    fitter: GainFitter,
    sel: Selection,
    t: Array,
    v: Array,
    omega: Array,
    constant_explains: bool,
    catalogue: Sequence[EffectSpec] = (),
) -> Explained:
    """Describe what ``sel``'s final model leaves and re-report the law (module docstring);
    ``t``, ``v``, ``omega``: the samples the windows were cut from; ``constant_explains``: the
    constant-gain model already explains the log (a description must then bring more);
    ``catalogue``: the effects a named one may be replaced by once a description is kept."""
    selected, dropped = _pruned(fitter, sel.final, catalogue)
    law0 = gain_law(fitter, selected) if selected.effects else None
    explained = law0.explains if law0 is not None else constant_explains
    d = _describe(fitter, selected, t, v, omega, explained)
    if d is not None and d.accepted:
        d, more = _simpler(fitter, d, catalogue)
        dropped += more
    final = d.fit if d is not None and d.accepted else selected
    law = law0 if final is selected else gain_law(fitter, final)
    alts = {c.alternative: gain_law(fitter, c.alternative_fit) for c in sel.confounds}
    return Explained(final, d, law, alts, dropped)
