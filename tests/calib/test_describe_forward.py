"""The residual model's forward growth (``calib.discovery.describe(forward=True)``): when the
screen's whole set of terms overfits in the robot's joint fit, the description is grown term by
term, each step the term whose joint fit is kept with the largest held-out gain.

A fake fitter whose held-out sum of squares is a table over the set of described terms stands
for a robot's fit (every coefficient significant), so the choice is checked exactly."""

from __future__ import annotations

from typing import Any

import numpy as np

from calib.discovery import EffectSpec, Entry, ModelFit, Term
from calib.discovery.library import Family
from calib.discovery.residual_model import _Column, _forward, _judged
from calib.results import Estimate

N = 100
HELD_OUT = {
    frozenset(): 1000.0,
    frozenset("a"): 700.0,
    frozenset("b"): 800.0,
    frozenset("c"): 950.0,
    frozenset("ab"): 500.0,
    frozenset("ac"): 690.0,
    frozenset("bc"): 790.0,
    frozenset("abc"): 2000.0,
}
"""Held-out sums of squares (noise units, ``N`` samples): the three together overfit."""


def _fit(names: frozenset[str], spec: EffectSpec[Any] | None) -> ModelFit:
    held = HELD_OUT[names]
    pars = {}
    if spec is not None:
        pars = {
            spec.key: {
                p.name: Estimate(p.name, 1.0, 0.1, (0.8, 1.2), True, "") for p in spec.params
            }
        }
    return ModelFit(
        (() if spec is None else (spec,)),
        {},
        pars,
        held,
        held,
        N,
        len(names),
        bic_value=held + 5.0 * len(names),
    )


class TableFitter:
    def __call__(self, effects: tuple[EffectSpec[Any], ...]) -> ModelFit | None:
        spec = effects[-1] if effects else None
        names = frozenset(p.name.split(": ")[1] for p in spec.params) if spec else frozenset()
        return _fit(names, spec)


def _columns() -> list[_Column]:
    entry = Entry("torque", "N·m", "tau1", lambda t: None)
    return [
        _Column(entry, Term(n, "1", np.ones(3), Family.LINEAR, n), np.arange(3.0)) for n in "abc"
    ]


def test_the_whole_set_overfits_and_forward_growth_keeps_the_best_pair() -> None:
    fitter, base, cols = TableFitter(), _fit(frozenset(), None), _columns()
    whole = _judged(fitter, base, cols, [0.0] * 3, None, 0.1)
    assert whole is not None
    assert not whole[3]  # held-out worse: not kept
    grown = _forward(fitter, base, cols, [0.0] * 3, None, 0.1)
    assert grown is not None
    spec, _fit_ab, kept, ok, gain, _ = grown
    assert ok
    assert [c.term.name for c in kept] == ["a", "b"]
    assert abs(gain - (1000.0 - 500.0) / (1000.0 - N)) < 1e-12
    assert [p.name for p in spec.params] == ["torque: a", "torque: b"]


def test_forward_growth_stops_when_no_single_term_is_kept() -> None:
    fitter, cols = TableFitter(), _columns()
    base = _fit(frozenset("ab"), None)  # nothing left to gain beyond a and b alone
    assert _forward(fitter, base, cols[2:], [0.0], None, 0.9) is None
