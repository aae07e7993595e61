"""Does the arm model explain its log? The shared adequacy check (:mod:`calib.adequacy`) on the
arm's torque residuals, the parameters fitted on separate time pieces (a payload picked up
mid-log is a parameter change: located, the log split, an estimate per piece), and the
recommended estimate under a misfit or a confound.

Channels: one per joint torque (``tau1``..), at the logged stamps: the in-sample residual of the
whole-log fit and the held-out residual of the fit on the first 60 % (the identification's own
split), its noise floor from the torque's own high-frequency content
(:func:`calib.manipulator.discovery.noise_timescale`) and quantisation, located along time and
each joint's ``q`` and ``qd``. What the model's inputs carry into the prediction (the encoder's
noise through the derivatives, the Coulomb term's shape at reversals:
:meth:`~calib.manipulator.discovery.ArmFitter.input_noise`) is added to the floor.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from calib.adequacy import (
    Adequacy,
    ParameterChange,
    PieceFit,
    ResidualChannel,
    assess,
    parameter_change,
    piece_stability,
    span,
    under_misfit,
    widen_unstable,
)
from calib.adequacy.intervals import Z95
from calib.discovery import EffectSpec
from calib.manipulator.discovery import ArmFit, ArmFitter, noise_timescale
from calib.manipulator.units import effort_unit
from calib.results import Estimate

__all__ = [
    "ArmAdequacy",
    "Split",
    "arm_channels",
    "assess_arm",
    "effect_spread",
    "find_change",
    "piece_fits",
    "pooled_dispersion",
    "scaled_by_pieces",
    "spanned",
    "stabilised",
    "unit_scales",
    "widened",
    "with_shifts",
]

Array = NDArray[np.float64]

PIECE_S = 2.0
"""Shortest piece (s) the parameters are fitted on when looking for a change."""
MAX_PIECES = 8
SPLIT_EXCESS = 0.5
"""A change is reported only when fitting each side on its own removes at least half of the
whole-log fit's excess over the noise floor: on a log the model does not explain, pieces differ
because the misfit projects differently onto each piece's motion, and a split fixes little."""
MIN_RELATIVE_CHANGE = 0.05
"""A change is reported only when some parameter moves by at least this fraction of its
value: piece-wise fits of a model that holds still differ by a fraction of a percent (the
filter's bias follows the motion) by more than their model-conditional standard errors."""


STABLE_REL_TOL = 0.25
"""A parameter that differs between pieces stays determined while its widened 95 % half-width
is within this fraction of max(|value|, its unit's scale)."""
UNIT_SCALE = 0.05
"""A parameter's scale (for values near zero): this fraction of the largest |value| among the
parameters of its unit (a first moment near 0 is judged against the arm's first moments)."""


@dataclass(frozen=True)
class ArmAdequacy:
    """The verdict with the fits it judged: ``whole`` (in-sample, all of the log) and ``train``
    (on the first 60 %, its residual on the rest held out)."""

    adequacy: Adequacy
    whole: ArmFit
    train: ArmFit


@dataclass(frozen=True)
class Split:
    """The log split at a parameter change: each side's estimates (``t0_s``-``t1_s``)."""

    change: ParameterChange
    pieces: tuple[tuple[float, float, Mapping[str, Estimate]], ...]

    def to_dict(self) -> dict[str, object]:
        return {
            "change": self.change.to_dict(),
            "pieces": [
                {"t0_s": a, "t1_s": b, "estimate": {k: e.to_dict() for k, e in est.items()}}
                for a, b, est in self.pieces
            ],
        }


def arm_channels(fitter: ArmFitter, whole: ArmFit, train: ArmFit) -> list[ResidualChannel]:
    """One residual channel per joint torque (see the module docstring)."""
    sig = fitter.sig
    t = whole.t_s
    cov: dict[str, Array] = {}
    for j, name in enumerate(fitter.model.joint_names):
        cov[f"q{j + 1} ({name}, rad)"] = np.interp(t, sig.t_s, sig.q[:, j])
        cov[f"qd{j + 1} ({name}, rad/s)"] = np.interp(t, sig.t_s, sig.qd[:, j])
    out = []
    ts = noise_timescale(sig.cutoff_hz)
    carried = fitter.input_noise(whole)
    kinds = getattr(fitter.model, "joint_kinds", None)
    units = [effort_unit(k) for k in kinds()] if callable(kinds) else ["N·m"] * fitter.n
    for j in range(fitter.n):
        held = np.where(train.train, np.nan, train.residual[:, j])
        out.append(
            ResidualChannel(
                f"tau{j + 1}",
                units[j],
                t,
                whole.residual[:, j],
                heldout=held,
                measured=fitter.tau_st[:, j],
                input_std=float(carried[j]),
                timescale_s=ts,
                covariates=cov,
            )
        )
    return out


def model_label(fitter: ArmFitter, effects: Sequence[EffectSpec]) -> str:
    """The judged model in words: the rigid body, the baseline terms, the effects."""
    body = "rigid body (nominal)" if fitter.nominal is not None else "rigid body"
    parts = [body, *(str(t) for t in fitter.baseline), *(e.key for e in effects)]
    return " + ".join(parts)


def assess_arm(
    fitter: ArmFitter,
    effects: Sequence[EffectSpec] = (),
    *,
    before: Adequacy | None = None,
    changes: Sequence[ParameterChange] = (),
    unexplained: str | None = None,
    notes: Sequence[str] = (),
) -> ArmAdequacy | None:
    """Judge the baseline plus ``effects``; None when a fit fails."""
    whole = fitter.fit_arm(tuple(effects))
    train = fitter.fit_arm(tuple(effects), 0, fitter.cut)
    if whole is None or train is None:
        return None
    adq = assess(
        arm_channels(fitter, whole, train),
        model=model_label(fitter, effects),
        before=before,
        changes=changes,
        unexplained=unexplained,
        notes=notes,
    )
    return ArmAdequacy(adq, whole, train)


def piece_fits(fitter: ArmFitter, duration_s: float | None = None) -> list[PieceFit]:
    """The baseline fitted on consecutive pieces of at least ``PIECE_S`` (4 to 8 pieces)."""
    t = fitter.sig.t_s
    dur = float(t[-1] - t[0]) if duration_s is None else duration_s
    k = int(min(MAX_PIECES, max(4, dur // PIECE_S)))
    edges = np.linspace(0, fitter.N, k + 1).round().astype(int)
    out = []
    for a, b in itertools.pairwise(edges):
        f = fitter.fit_arm((), int(a), int(b))
        if f is None:
            continue
        est = f.estimates()
        out.append(
            PieceFit(
                float(t[a]),
                float(t[b - 1]),
                {n: e.value for n, e in est.items()},
                {n: e.std if e.identifiable else math.nan for n, e in est.items()},
            )
        )
    return out


def find_change(fitter: ArmFitter, pieces: Sequence[PieceFit]) -> Split | None:
    """A change of the rigid-body parameters between pieces (the parameters determined on every
    piece), and the log split there with an estimate per side; None when none is found."""
    if not pieces:
        return None
    names = [
        n
        for n in pieces[0].values
        if all(math.isfinite(p.std.get(n, math.nan)) and p.std.get(n, 0.0) > 0 for p in pieces)
        and not n.startswith(("Fc", "Fv", "Fcs", "tau0"))
    ]
    if not names:
        return None
    change = parameter_change(pieces, names)
    if change is None or not any(
        abs(change.after[n] - change.before[n])
        >= MIN_RELATIVE_CHANGE * max(abs(change.before[n]), abs(change.after[n]))
        for n in change.parameters
    ):
        return None
    t = fitter.sig.t_s
    k = int(np.searchsorted(t, change.t_s))
    whole = fitter.fit_arm(())
    sides = []
    z2 = []
    for a, b in ((0, k), (k, fitter.N)):
        f = fitter.fit_arm((), a, b)
        if f is None:
            return None
        sides.append((float(t[a]), float(t[b - 1]), f.estimates()))
        z2.append((f.residual[f.train] / fitter.floors[None, :]) ** 2)
    if whole is None:
        return None
    excess_whole = float(np.mean((whole.residual / fitter.floors[None, :]) ** 2)) - 1.0
    excess_split = float(np.mean(np.concatenate(z2))) - 1.0
    if not excess_split <= SPLIT_EXCESS * excess_whole:
        return None  # the pieces differ, but one set per side explains little more: a misfit
    return Split(change, tuple(sides))


def widened(
    estimates: Mapping[str, Estimate], adequacy: Adequacy, pieces: Sequence[PieceFit] = ()
) -> dict[str, Estimate]:
    """Every estimate as a model that does not explain the log allows (unchanged while it
    explains): widened by the misfit factor and the spread over the pieces, not determined."""
    out = {}
    for name, e in estimates.items():
        vals = [p.values[name] for p in pieces if name in p.values]
        out[name] = under_misfit(e, adequacy, pieces=vals)
    return out


def spanned(
    estimates: Mapping[str, Estimate],
    alternatives: Sequence[tuple[str, Mapping[str, Estimate]]],
    label: str,
) -> dict[str, Estimate]:
    """Each estimate spanning the same parameter under the ``alternatives`` (label, estimates):
    the log cannot tell those explanations apart."""
    out = {}
    for name, e in estimates.items():
        others = [(lab, alt[name]) for lab, alt in alternatives if name in alt]
        if not others:
            out[name] = e
            continue
        out[name] = span([e, *(o for _, o in others)], [label, *(lab for lab, _ in others)])
    return out


def with_shifts(
    estimates: Mapping[str, Estimate], shifts: Mapping[str, float]
) -> dict[str, Estimate]:
    """Each estimate with its processing shift (:meth:`ArmFitter.processing_shifts`,
    :func:`calib.manipulator.identify.cutoff_shifts`) added to its standard error in
    quadrature: the interval includes what the log cannot settle about the friction's shape at
    reversals, the noise in the regressor and the filter's cut-off."""
    out = dict(estimates)
    for name, e in estimates.items():
        d = shifts.get(name, 0.0)
        if not (d > 0 and math.isfinite(d) and math.isfinite(e.std)):
            continue
        std = math.hypot(e.std, d)
        half = Z95 * std
        note = (
            f"interval includes {d:.2g} {e.unit} the estimate moves by under the friction's "
            "shape at reversals and the encoder's noise"
        )
        out[name] = Estimate(
            e.name,
            e.value,
            std,
            (e.value - half, e.value + half),
            e.identifiable,
            e.unit,
            (e.note + "; " if e.note else "") + note,
        )
    return out


def effect_spread(
    fitter: ArmFitter, accepted: Sequence[EffectSpec], catalogue: Sequence[EffectSpec]
) -> dict[str, float]:
    """Per parameter, what the log cannot exclude about the catalogue's other effects: the
    final model (baseline + ``accepted``) refitted on the whole log with each further effect of
    ``catalogue`` in turn (extensions only: not an alternative to a term the model holds, not
    a payload), and the largest of sqrt(the variance that effect's fit adds + the shift of the
    estimate squared). A correct model moves by about its error (the effect fits near
    zero); a small delay or an elastic joint the residual cannot show moves the rigid body by
    more, and the interval then includes it."""
    base = fitter.fit_arm(tuple(accepted))
    if base is None:
        return {}
    ref = base.estimates()
    taken = {e.key for e in accepted}
    # an alternative to a term the model holds is a different model, not an extension: the
    # log chooses between the two (discovery), it does not leave both open
    out: dict[str, float] = {}
    for e in fitter.extensions(catalogue):
        if e.key in taken:
            continue
        f = fitter.fit_arm((*accepted, e))
        if f is None:
            continue
        for name, est in f.estimates().items():
            r = ref.get(name)
            if r is None or not (r.identifiable and est.identifiable):
                continue
            extra = math.sqrt(max(0.0, est.std**2 - r.std**2) + (est.value - r.value) ** 2)
            if math.isfinite(extra):
                out[name] = max(out.get(name, 0.0), extra)
    return out


def unit_scales(estimates: Mapping[str, Estimate]) -> dict[str, float]:
    """Per parameter, ``UNIT_SCALE`` of the largest |value| among the parameters that share its
    unit: the size below which a relative rule would be unfair to a value near zero."""
    top: dict[str, float] = {}
    for e in estimates.values():
        if math.isfinite(e.value):
            top[e.unit] = max(top.get(e.unit, 0.0), abs(e.value))
    return {n: UNIT_SCALE * top.get(e.unit, 0.0) for n, e in estimates.items()}


def pooled_dispersion(pieces: Sequence[PieceFit], names: Sequence[str]) -> tuple[float, int]:
    """The pieces' scatter about their weighted means in units of their own standard errors,
    pooled over ``names``: (sqrt(sum chi^2 / sum dof), sum dof); (1, 0) with fewer than two
    pieces. Above one, the model-conditional errors are too small by about that factor for
    every parameter alike (a Birge ratio over all parameters of the log)."""
    stab = piece_stability(pieces, list(names)) if len(pieces) >= 2 else {}
    chi2 = sum(st.chi2 for st in stab.values())
    dof = sum(st.dof for st in stab.values())
    return (math.sqrt(chi2 / dof) if dof else 1.0), dof


def scaled_by_pieces(
    estimates: Mapping[str, Estimate], pieces: Sequence[PieceFit]
) -> dict[str, Estimate]:
    """Every determined estimate's standard error scaled by :func:`pooled_dispersion` when it
    is above one (unchanged otherwise): the errors the log's own pieces show."""
    names = [n for n, e in estimates.items() if e.identifiable]
    k, dof = pooled_dispersion(pieces, names)
    if k <= 1.0:
        return dict(estimates)
    out = dict(estimates)
    for n in names:
        e = estimates[n]
        std = e.std * k
        half = Z95 * std
        out[n] = Estimate(
            e.name,
            e.value,
            std,
            (e.value - half, e.value + half),
            True,
            e.unit,
            (e.note + "; " if e.note else "") + f"standard error x{k:.2g}: the "
            f"scatter of the estimates over pieces of the log ({dof} dof)",
        )
    return out


def stabilised(
    estimates: Mapping[str, Estimate], pieces: Sequence[PieceFit]
) -> dict[str, Estimate]:
    """The specification test by pieces (:func:`calib.adequacy.piece_stability`): each
    parameter whose piece estimates scatter beyond their errors gets its interval widened by the
    overdispersion and the spread, and stays determined only while that interval is narrow
    (``STABLE_REL_TOL`` of max(|value|, :func:`unit_scales`))."""
    if len(pieces) < 2:
        return dict(estimates)
    stab = piece_stability(pieces, [n for n in estimates if estimates[n].identifiable])
    return widen_unstable(estimates, stab, rel_tol=STABLE_REL_TOL, scale=unit_scales(estimates))
