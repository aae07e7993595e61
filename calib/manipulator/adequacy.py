"""Does the arm model explain its log? The shared adequacy check (:mod:`calib.adequacy`) on the
arm's torque residuals, the parameters fitted on separate time pieces (a payload picked up
mid-log is a parameter change: located, the log split, an estimate per piece), and the
recommended estimate under a misfit or a confound.

Channels: one per joint torque (``tau1``..), at the logged stamps: the in-sample residual of the
whole-log fit and the held-out residual of the fit on the first 60 % (the identification's own
split), its noise floor from the torque's own high-frequency content
(:func:`calib.manipulator.discovery.noise_timescale`) and quantisation, located along time and
each joint's ``q`` and ``qd``.
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
    EffectSpec,
    ParameterChange,
    PieceFit,
    ResidualChannel,
    assess,
    parameter_change,
    span,
    under_misfit,
)
from calib.manipulator.discovery import ArmFit, ArmFitter, noise_timescale
from calib.results import Estimate

__all__ = [
    "ArmAdequacy",
    "Split",
    "arm_channels",
    "assess_arm",
    "find_change",
    "piece_fits",
    "spanned",
    "widened",
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
    for j in range(fitter.n):
        held = np.where(train.train, np.nan, train.residual[:, j])
        out.append(ResidualChannel(
            f"tau{j + 1}", "N·m", t, whole.residual[:, j], heldout=held,
            measured=fitter.tau_st[:, j], timescale_s=ts, covariates=cov,
        ))
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
    adq = assess(arm_channels(fitter, whole, train), model=model_label(fitter, effects),
                 before=before, changes=changes, unexplained=unexplained, notes=notes)
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
        out.append(PieceFit(float(t[a]), float(t[b - 1]),
                            {n: e.value for n, e in est.items()},
                            {n: e.std if e.identifiable else math.nan for n, e in est.items()}))
    return out


def find_change(fitter: ArmFitter, pieces: Sequence[PieceFit]) -> Split | None:
    """A change of the rigid-body parameters between pieces (the parameters determined on every
    piece), and the log split there with an estimate per side; None when none is found."""
    if not pieces:
        return None
    names = [n for n in pieces[0].values
             if all(math.isfinite(p.std.get(n, math.nan)) and p.std.get(n, 0.0) > 0
                    for p in pieces) and not n.startswith(("Fc", "Fv", "Fcs", "tau0"))]
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
