"""Column effects of the arm's catalogue: a model term's column on one joint (friction, an
offset), a spring on one joint and a point mass at the tool point (against a nominal rigid body
only)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from calib.manipulator.design import ALTERNATIVES, Term, term_column, term_name
from calib.manipulator.discovery.hooks import Array, Column, ColumnEffect, FitterView

__all__ = ["PayloadColumn", "SpringColumn", "TermColumn"]


@dataclass(frozen=True)
class TermColumn(ColumnEffect):
    """A model term's column on one joint."""

    term: Term
    joint: str

    def absorbed(self, fitter: FitterView) -> bool:
        return term_name(self.term, self.joint) in fitter.design.names

    def replaces(self, baseline: Sequence[Term]) -> str | None:
        alt = ALTERNATIVES.get(self.term)
        return f"{alt}({self.joint})" if alt is not None and alt in baseline else None

    def column(self, fitter: FitterView) -> Column | None:
        j = fitter.model.joint_names.index(self.joint)
        col = np.zeros((fitter.N, fitter.n, 1))
        col[:, j, 0] = np.broadcast_to(term_column(self.term, fitter.sig.qd[:, j]), (fitter.N,))
        alt = ALTERNATIVES.get(self.term)
        return Column(
            np.zeros_like(col),
            col,
            col,
            None if alt is None else term_name(alt, self.joint),
            None if alt is None else (frozenset((self.term, alt)), self.joint),
        )


class PayloadColumn(ColumnEffect):
    """A point mass at the tool point: only against a nominal rigid body."""

    def applies(self, fitter: FitterView) -> bool:
        return fitter.nominal is not None

    def column(self, fitter: FitterView) -> Column | None:
        if fitter.nominal is None:
            return None

        def cols() -> tuple[Array, Array, Array]:
            inc = fitter.model.payload_increment()
            s = fitter.sig
            return (
                (fitter.model.momentum(s.q, s.qd) @ inc)[:, :, None],
                (fitter.model.rest(s.q, s.qd) @ inc)[:, :, None],
                (fitter.model.regressor(s.q, s.qd, s.qdd) @ inc)[:, :, None],
            )

        cp, cr, cc = fitter.cached("payload", cols)
        return Column(cp, cr, cc)

    def body_change(self, fitter: FitterView) -> Array | None:
        return np.asarray(fitter.model.payload_increment(), dtype=float)


@dataclass(frozen=True)
class SpringColumn(ColumnEffect):
    """A spring on one joint: a torque linear in its angle, ``k q_J`` (a gravity compensator, a
    cable or hose, a return spring), the rest position's torque left to an offset."""

    joint: str

    def column(self, fitter: FitterView) -> Column | None:
        j = fitter.model.joint_names.index(self.joint)
        col = np.zeros((fitter.N, fitter.n, 1))
        col[:, j, 0] = fitter.sig.q[:, j]
        return Column(np.zeros_like(col), col, col)
