"""The arm's effect hooks: the three mechanisms by which an effect changes the arm's model
(columns added to the regressor, a transform of the logged torque, a move of the model's
inputs), and the view of the fitter they are called with.

An effect declares one of these hooks as its :class:`~calib.discovery.EffectSpec`'s ``model``;
the fitter (:mod:`calib.manipulator.discovery.fitter`) applies it by its mechanism, never by the
effect's id, so a new effect of one of these mechanisms needs no change to the fitter.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, TypeAlias

import numpy as np
from numpy.typing import NDArray

from calib.discovery import EffectSpec
from calib.manipulator.design import Design, Term
from calib.manipulator.model import ArmModel
from calib.manipulator.signals import JointSignals

__all__ = [
    "ArmEffect",
    "ArmEffectModel",
    "Column",
    "ColumnEffect",
    "FitterView",
    "InputEffect",
    "StateEffect",
    "hook",
]

Array = NDArray[np.float64]


class FitterView(Protocol):
    """What a hook sees of the fitter (:class:`~calib.manipulator.discovery.fitter.ArmFitter`):
    the arm, its prepared signals, the joint and sample counts, the baseline design and terms,
    the nominal rigid body (None: fitted), and a per-fitter cache for what a hook derives from
    the whole log."""

    model: ArmModel
    sig: JointSignals
    n: int
    N: int
    design: Design
    baseline: tuple[Term, ...]
    nominal: Array | None

    def cached(self, key: Hashable, make: Callable[[], Any]) -> Any: ...


class ArmEffect:
    """What every arm effect's hook answers, whatever its mechanism (defaults: an effect any
    model can take, which no baseline holds)."""

    def applies(self, fitter: FitterView) -> bool:
        """Whether the effect can enter ``fitter``'s model at all."""
        return True

    def absorbed(self, fitter: FitterView) -> bool:
        """Whether ``fitter``'s baseline model already holds it."""
        return False

    def replaces(self, baseline: Sequence[Term]) -> str | None:
        """The key of the baseline term it is fitted in place of (None: an extension)."""
        return None


@dataclass(frozen=True)
class Column:
    """Regressor columns of one :class:`ColumnEffect`, one per parameter, each (S, n, k):
    in the momentum form (``momentum``, ``rest``) and the classic one (``classic``);
    ``drop``: a baseline column name fitted in their place (left out when present);
    ``exclusive``: a token no two effects of one model may share."""

    momentum: Array
    rest: Array
    classic: Array
    drop: str | None = None
    exclusive: Hashable | None = None


class ColumnEffect(ArmEffect):
    """An effect linear in its parameters: columns added to the regressor."""

    def column(self, fitter: FitterView) -> Column | None:
        """Its columns on ``fitter``'s signals; None when it cannot enter this model."""
        raise NotImplementedError

    def body_change(self, fitter: FitterView) -> Array | None:
        """Against a nominal rigid body: the full rigid-body parameters' change per unit of
        the effect's parameter (None: it leaves the body as it is)."""
        return None


class InputEffect(ArmEffect):
    """The torque the model sees is a transform of the logged torque with one parameter ``p``
    (the null at 0), profiled over the parameter's bounds; one per model."""

    def acting(self, fitter: FitterView, p: float) -> Array:
        """The acting torque on the grid (S, n) from the filtered logged torque."""
        raise NotImplementedError

    def logged(self, fitter: FitterView, p: float, pred: Array) -> Array:
        """The logged torque the model predicts from the acting torque ``pred`` (grid)."""
        raise NotImplementedError


class StateEffect(ArmEffect):
    """The model's inputs move linearly with one parameter ``c`` (the null at 0): fitted by
    Gauss-Newton, its column a central difference of the regressor along the move."""

    def shift(self, fitter: FitterView, c: float, dq: Array, dqd: Array, dqdd: Array) -> None:
        """Add to ``dq``, ``dqd``, ``dqdd`` (S, n; in place) how the inputs move at ``c``."""
        raise NotImplementedError

    def step(self, fitter: FitterView) -> float:
        """The central difference's step in ``c``."""
        raise NotImplementedError


ArmEffectModel: TypeAlias = ColumnEffect | InputEffect | StateEffect
"""The hook of an arm effect's :class:`~calib.adequacy.EffectSpec`: one of the three mechanisms
the fitter applies."""


def hook(e: EffectSpec[ArmEffectModel]) -> ArmEffectModel:
    """``e``'s hook (ValueError when it has none)."""
    if not isinstance(e.model, ColumnEffect | InputEffect | StateEffect):
        raise ValueError(f"effect {e.key}: no model hook")
    return e.model
