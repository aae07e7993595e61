"""The arm's side of the residual model (:mod:`calib.discovery.residual_model`): what the
catalogue leaves in the joint torques, modelled from the arm's own signals and refitted jointly
with the dynamic parameters.

Signals, per joint J on the fitter's grid: its angle ``qJ`` (periodic terms and bumps: cogging,
an eccentric gear, a tight spot), velocity ``qdJ`` (signs, squares, dead zones, friction growing
below a few velocity scales: friction of other shapes), acceleration ``qddJ``, their products,
time for drift, and the play terms ``sign(qdJ) sin(qJ)``, ``sign(qdJ) cos(qJ)`` (a gravity
torque taken at an angle that lags the motor by a band, as gear play does). A term enters the
model through one joint's torque, its own (a joint's torque follows that joint's signals:
springs, bearings, gears and mounts act on their own joint; the couplings between joints are the
rigid body's, which is fitted).

The screen regresses the current fit's torque residual at the logged stamps (each joint in its
noise-floor units) on the terms' columns, beyond what the regressor of the rigid body and the
declared terms spans (the nuisance: a term the body's parameters reproduce is not physics worth
a name). A kept description is a :class:`~calib.manipulator.discovery.hooks.ColumnEffect`: each
term one column of its joint's torque, which the fitter fits with everything else, so that the
dynamic parameters are re-estimated under it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from calib.discovery import (
    Description,
    Entry,
    Family,
    ModelFit,
    ResidualSpace,
    Role,
    Signal,
    Term,
    build_library,
    describe,
)
from calib.discovery.residual_model import HookFactory
from calib.manipulator.discovery.fitter import ArmFitter
from calib.manipulator.discovery.hooks import Array, Column, ColumnEffect, FitterView
from calib.manipulator.units import effort_unit

__all__ = [
    "FOLDS",
    "MAX_SCREEN_SAMPLES",
    "DescribedColumns",
    "arm_entries",
    "arm_library",
    "arm_residual_space",
    "describe_arm",
    "described_hook",
    "physics_hint",
]

MAX_SCREEN_SAMPLES = 3000
"""The screen sees at most this many logged samples per joint (evenly spaced): the residual is
correlated over many samples, so more rows add cost, not information."""
FOLDS = 5
"""Contiguous time folds of the screen's cross-validation."""
PLAY = "play"


def _kinds(fitter: FitterView) -> list[str]:
    of = getattr(fitter.model, "joint_kinds", None)
    return list(of()) if callable(of) else ["revolute"] * fitter.n


def _joint_signals(fitter: FitterView, j: int, kind: str) -> list[Signal]:
    s, name = fitter.sig, fitter.model.joint_names[j]
    u = "m" if kind == "prismatic" else "rad"
    return [
        Signal(
            f"q{j + 1}", u, s.q[:, j], Role.ANGLE if u == "rad" else Role.POSITION, f"{name} angle"
        ),
        Signal(f"qd{j + 1}", f"{u}/s", s.qd[:, j], Role.RATE, f"{name} velocity"),
        Signal(f"qdd{j + 1}", f"{u}/s²", s.qdd[:, j], Role.STATE, f"{name} acceleration"),
    ]


def _play_terms(sig: Sequence[Signal]) -> list[Term]:
    q, qd = sig[0], sig[1]
    rms = float(np.sqrt(np.mean(qd.values**2)))
    if rms <= 0 or sig[0].role is not Role.ANGLE:
        return []
    sgn = np.tanh(qd.values / (0.05 * rms))
    return [
        Term(
            f"sign({qd.name})·{fn}({q.name})",
            "1",
            sgn * f(q.values),
            Family.PRODUCT,
            f"the sign of the {qd.words} times the {fn} of the {q.words} (a gravity "
            "torque taken at an angle that lags the motor by a band: play)",
            (q.name, qd.name),
        )
        for fn, f in (("sin", np.sin), ("cos", np.cos))
    ]


STICTION_SCALES = (0.03, 0.1, 0.3)
"""Velocity scales of the low-speed friction terms, as fractions of the joint velocity's RMS."""


def _stiction_terms(sig: Sequence[Signal]) -> list[Term]:
    qd = sig[1]
    rms = float(np.sqrt(np.mean(qd.values**2)))
    if rms <= 0:
        return []
    out = []
    for share in STICTION_SCALES:
        v = share * rms
        out.append(
            Term(
                f"sign({qd.name})·exp(-({qd.name}/{v:.3g})²)",
                "1",
                np.tanh(qd.values / (0.1 * v)) * np.exp(-((qd.values / v) ** 2)),
                Family.SIGN,
                f"friction that grows below {v:.3g} {qd.unit} of the {qd.words} (stiction, a "
                "Stribeck curve)",
                (qd.name,),
            )
        )
    return out


def arm_library(fitter: FitterView) -> list[Term]:
    """Every joint's candidate terms (module docstring), on the fitter's grid; the angle's
    words name the joint."""
    out: dict[str, Term] = {}
    t = fitter.sig.t_s
    for j, kind in enumerate(_kinds(fitter)):
        sig = _joint_signals(fitter, j, kind)
        terms = build_library(sig, t, periodic_orders=(1, 2), n_bumps=5, products=True)
        for term in [*terms, *_play_terms(sig), *_stiction_terms(sig)]:
            out.setdefault(term.name, term)
    return list(out.values())


def _stamps(fitter: FitterView, t_st: Array) -> NDArray[np.intp]:
    step = max(1, int(np.ceil(t_st.size / MAX_SCREEN_SAMPLES)))
    return np.arange(0, t_st.size, step, dtype=np.intp)


def _own(term: Term, j: int) -> bool:
    """Whether ``term`` is built from joint ``j``'s signals only (time alone: any joint)."""
    names = {f"q{j + 1}", f"qd{j + 1}", f"qdd{j + 1}"}
    return all(s in names for s in term.signals)


def arm_entries(
    fitter: FitterView, t_st: Array, rows: NDArray[np.intp], floors: Array
) -> list[Entry]:
    """One entry per joint: a term added to that joint's torque, in the residual layout
    (``rows`` of the logged stamps ``t_st``, sample-major, each joint over its floor)."""
    t_s, n = fitter.sig.t_s, fitter.n
    at = t_st[rows]
    out = []
    for j, (name, kind) in enumerate(zip(fitter.model.joint_names, _kinds(fitter), strict=True)):

        def column(term: Term, j: int = j) -> Array | None:
            if not _own(term, j):
                return None
            col = np.zeros((at.size, n))
            col[:, j] = np.interp(at, t_s, term.values) / floors[j]
            return col.ravel()

        out.append(Entry(f"{name} torque", effort_unit(kind), f"tau{j + 1}", column))
    return out


def arm_residual_space(
    fitter: FitterView,
    residual: Array,
    t_st: Array,
    floors: Array,
    nuisance_grid: Array | None,
) -> ResidualSpace:
    """The torque residual (logged stamps x joints, N·m) in noise units, every ``FOLDS``-th of
    the log one fold, with the joints' entries; ``nuisance_grid``: the regressor's classic
    columns on the grid (N, n, P), whose span the screen looks beyond."""
    rows = _stamps(fitter, t_st)
    z = residual[rows] / floors[None, :]
    fold = np.minimum((FOLDS * np.arange(rows.size)) // max(rows.size, 1), FOLDS - 1)
    nuisance = None
    if nuisance_grid is not None and nuisance_grid.shape[2]:
        t_s = fitter.sig.t_s
        at = t_st[rows]
        cols = np.empty((rows.size, fitter.n, nuisance_grid.shape[2]))
        for j in range(fitter.n):
            for k in range(nuisance_grid.shape[2]):
                cols[:, j, k] = np.interp(at, t_s, nuisance_grid[:, j, k]) / floors[j]
        nuisance = cols.reshape(rows.size * fitter.n, -1)
    return ResidualSpace(
        z.ravel(),
        np.repeat(fold.astype(np.intp), fitter.n),
        arm_entries(fitter, t_st, rows, floors),
        nuisance,
    )


@dataclass(frozen=True)
class DescribedColumns(ColumnEffect):
    """The hook of a described effect on an arm: each term one column of its joint's torque
    (a torque the model adds, integrated over the momentum windows as friction is)."""

    terms: tuple[tuple[int, Array], ...] = field(repr=False)
    """(joint index, values on the grid), one per parameter of the spec, in order."""

    def column(self, fitter: FitterView) -> Column | None:
        col = np.zeros((fitter.N, fitter.n, len(self.terms)))
        for k, (j, values) in enumerate(self.terms):
            if values.shape != (fitter.N,):
                return None
            col[:, j, k] = values
        return Column(np.zeros_like(col), col, col)


def described_hook(fitter: FitterView) -> HookFactory:
    """The :data:`~calib.discovery.residual_model.HookFactory` of an arm: each (name, entry,
    term) as one column of the entry's joint."""
    joint_of = {f"{name} torque": j for j, name in enumerate(fitter.model.joint_names)}

    def make(triples: Sequence[tuple[str, Entry, Term]]) -> DescribedColumns:
        return DescribedColumns(tuple((joint_of[e.name], t.values) for _, e, t in triples))

    return make


def physics_hint(term: Term) -> str:
    """What a described term most likely is, in a machine's words ("" when nothing fits)."""
    fam, name = term.family, term.name
    if fam is Family.LINEAR and name.startswith("q") and not name.startswith("qd"):
        return "a spring on the joint (torque linear in its angle)"
    if fam is Family.LINEAR and name.startswith("qdd"):
        return "inertia the model lacks (a rotor, a gear stage)"
    if fam is Family.LINEAR and name.startswith("qd"):
        return "viscous friction"
    if fam in (Family.SIGN, Family.DEAD_ZONE) or (name.startswith("sign(qd") and "·" not in name):
        return "friction of another shape (stiction, a dead band)"
    if fam is Family.SQUARE:
        return "drag growing with speed squared"
    if fam is Family.PERIODIC:
        return "a torque repeating with the angle (cogging, an eccentric gear)"
    if fam is Family.BUMP:
        return "a tight spot at one angle (a bearing, a cable)"
    if fam is Family.DRIFT:
        return "a drift over the log (warming gear, a sensor's offset)"
    if fam is Family.PRODUCT and name.startswith("sign(qd"):
        return f"{PLAY} in the gear (the link lags the motor by a band)"
    return ""


def describe_arm(
    fitter: ArmFitter, current: ModelFit, *, explained: bool, seed: int = 0
) -> Description | None:
    """The residual model of ``current`` (a fit of ``fitter`` as the shared engine calls it):
    the residual screened is that of the same model fitted on the whole log (what the model
    leaves at its best); ``explained``: the current model already explains the log (a
    description must then bring more, :data:`calib.discovery.residual_model.EXPLAINED_GAIN`).
    None when the screen keeps nothing or a fit fails."""
    whole = fitter.fit_arm(current.effects)
    if whole is None:
        return None
    space = arm_residual_space(fitter, whole.residual, whole.t_s, fitter.floors, fitter.reg.Xc)
    return describe(
        fitter,
        current,
        space,
        arm_library(fitter),
        seed=seed,
        block=50 * fitter.n,
        hook=described_hook(fitter),
        explained=explained,
        forward=True,
    )
