"""The tractor-trailer's side of the residual model (:mod:`calib.discovery.residual_model`)
along the measured path.

Signals at the joint-angle samples: link 1's speed ``v`` and path curvature ``kappa`` (from the
measured path), its yaw rate ``omega`` = v kappa, and the modelled true joint angle ``psi`` (an
angle: periodic terms and bumps, for an encoder's periodic error or a dead zone). A term enters
the model through:

- ``joint-angle reading`` (rad): it adds to what the encoder records;
- ``d psi/ds`` (rad/m): it adds to the trailer's kinematics, d psi/ds = kappa (1 + L1/L2 cos psi)
  - sin(psi)/L2 + g; its effect on the angle is the linearised response along the path,
  d delta/ds = a(s) delta + g(s) with a = -kappa (L1/L2) sin psi - cos(psi)/L2, from rest at
  each piece's start (a speed-dependent trailer slip, a yaw damping).

In the joint fit a described effect is one added column of the reading per term
(:class:`AddedColumn`, a one-parameter path effect like the catalogue's), so the fitter, the
held-out check and the corrected joint angle (its undo) treat it as any other path effect.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from calib.discovery import (
    EffectKind,
    EffectParam,
    EffectSpec,
    Entry,
    ResidualSpace,
    Role,
    Signal,
    Term,
    build_library,
)
from calib.discovery.residual_model import DescribedTerms
from calib.tractor_trailer.path_adequacy import BLOCKS_PER_FOLD, FOLDS, INITIAL_SAMPLES
from calib.tractor_trailer.path_effects import JointPathModel, PathState, Undone

__all__ = [
    "ENTRY_DYNAMICS",
    "ENTRY_READING",
    "AddedColumn",
    "expand_described",
    "joint_jacobian",
    "path_entries",
    "path_library",
    "path_residual_space",
]

FloatArray = NDArray[np.float64]
ENTRY_READING = "joint-angle reading"
ENTRY_DYNAMICS = "d psi/ds"


@dataclass(frozen=True)
class AddedColumn:
    """One described term as a path effect: the reading plus value x ``column`` (rad per unit
    of the coefficient, at the model's joint-angle samples)."""

    column: FloatArray = field(repr=False)
    order: int = 50
    tolerated: None = None

    def stamp_shift(self, t_rel: FloatArray, value: float) -> None:
        return None

    def apply(self, state: PathState, value: float) -> tuple[PathState, FloatArray]:
        return replace(state, y=state.y + value * self.column), self.column.copy()

    def undo(self, state: Undone, value: float) -> Undone:
        return replace(state, z=state.z - value * self.column)


def expand_described(spec: EffectSpec, floor_rad: float) -> tuple[EffectSpec, ...]:
    """A described effect (its hook :class:`DescribedTerms`, columns in noise units of
    ``floor_rad``) as one-parameter path effects, one per term; any other effect as itself."""
    hook = spec.model
    if spec.kind is not EffectKind.DESCRIBED or not isinstance(hook, DescribedTerms):
        return (spec,)
    out = []
    for j, (name, p) in enumerate(zip(hook.names, spec.params, strict=True)):
        out.append(
            EffectSpec(
                spec.id,
                f"psi: {name}",
                EffectKind.DESCRIBED,
                (EffectParam(p.name, p.unit, 0.0, p.lower, p.upper, p.init),),
                spec.physics,
                model=AddedColumn(np.asarray(hook.columns[:, j] * floor_rad, dtype=float)),
            )
        )
    return tuple(out)


def _rates(model: JointPathModel) -> tuple[FloatArray, FloatArray]:
    dt = 0.05
    s0, th0 = model.path.at(model.t - dt)
    s1, th1 = model.path.at(model.t + dt)
    ds = s1 - s0
    v = ds / (2 * dt)
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.where(np.abs(ds) > 1e-3, (th1 - th0) / ds, 0.0)
    return np.asarray(v, dtype=float), np.asarray(kappa, dtype=float)


def path_library(model: JointPathModel, true_psi: FloatArray) -> list[Term]:
    """The candidate terms along the path (module docstring)."""
    v, kappa = _rates(model)
    signals = [
        Signal("v", "m/s", v, Role.RATE, "speed of link 1"),
        Signal("kappa", "1/m", kappa, Role.STATE, "path curvature"),
        Signal("omega", "rad/s", v * kappa, Role.RATE, "yaw rate of link 1"),
        Signal("psi", "rad", np.asarray(true_psi, dtype=float), Role.ANGLE, "joint angle"),
    ]
    return build_library(signals, model.t, periodic_orders=(1, 2, 3), n_bumps=5)


def _responses(
    model: JointPathModel, x: FloatArray, true_psi: FloatArray, g: FloatArray
) -> FloatArray:
    """The joint angle's linearised responses to added d psi/ds columns ``g`` (n, k) (module
    docstring), from rest at each piece's first sample: one pass over the samples for every
    column at once."""
    L1, L2 = float(x[0]), float(x[1])
    s, _ = model.path.at(model.t)
    _, kappa = _rates(model)
    a = -kappa * (L1 / L2) * np.sin(true_psi) - np.cos(true_psi) / L2
    ds = np.diff(s, prepend=s[0])
    out = np.zeros_like(g)
    for lo, hi in zip(model._piece_lo, model._piece_hi, strict=True):
        d = np.zeros(g.shape[1])
        for i in range(lo + 1, hi):
            d = d + (a[i - 1] * d + g[i - 1]) * ds[i]
            out[i] = d
    return out


def path_entries(
    model: JointPathModel,
    x: FloatArray,
    true_psi: FloatArray,
    floor_rad: float,
    library: Sequence[Term],
) -> list[Entry]:
    """The reading and kinematics entries for the terms of ``library``, in the joint fit's
    residual layout (the model's joint-angle samples) and noise units."""
    g = np.column_stack([np.asarray(t.values, dtype=float) for t in library])
    resp = _responses(model, x, np.asarray(true_psi, dtype=float), g) / floor_rad
    by_name = {t.name: resp[:, j] for j, t in enumerate(library)}

    def reading(term: Term) -> FloatArray:
        return np.asarray(term.values, dtype=float) / floor_rad

    def dynamics(term: Term) -> FloatArray | None:
        return by_name.get(term.name)

    return [
        Entry(ENTRY_READING, "rad", "psi", reading),
        Entry(ENTRY_DYNAMICS, "rad/m", "psi", dynamics),
    ]


def path_residual_space(
    model: JointPathModel,
    residual: FloatArray,
    floor_rad: float,
    entries: Sequence[Entry],
    jacobian: FloatArray | None = None,
) -> ResidualSpace:
    """The joint fit's residual in noise units with the held-out check's folds (each piece's
    first samples in none: they set its initial angle); ``jacobian``: the reading's derivatives
    to the fit's own parameters (L1, L2, the effects', each piece's initial angle)."""
    t = model.t
    edges = np.linspace(t[0], t[-1], FOLDS * BLOCKS_PER_FOLD + 1)
    block = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, edges.size - 2)
    fold = (block % FOLDS).astype(np.intp)
    rank = np.arange(t.size) - model.first_idx[model.piece]
    fold[rank < INITIAL_SAMPLES] = -1
    nuisance = None if jacobian is None else np.asarray(jacobian, dtype=float) / floor_rad
    return ResidualSpace(np.asarray(residual, dtype=float) / floor_rad, fold, entries, nuisance)


def joint_jacobian(
    model: JointPathModel, x: FloatArray, effects: tuple[EffectSpec, ...]
) -> FloatArray:
    """The modelled reading's derivatives to (L1, L2, the effects' parameters, each piece's
    initial angle) at ``x``."""
    _, J, d0, _, _ = model.evaluate(x, effects)
    pieces = np.zeros((d0.size, model.n_pieces))
    pieces[np.arange(d0.size), model.piece] = d0
    return np.column_stack([J, pieces])
