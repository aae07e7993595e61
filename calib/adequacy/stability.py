"""Do the parameters hold across the log? A specification test by pieces.

Under the right model, the parameters fitted on separate pieces of a log (halves, thirds, time
blocks, runs) agree within their standard errors. Physics the model leaves out usually acts
differently in different pieces (another speed, other joint angles, a later temperature), so
the piece estimates scatter more than their errors allow, even where the residual stays close
to the noise floor. The scatter is measured as an overdispersion factor
sqrt(chi^2 / dof) per parameter; a factor significantly above one widens that parameter's
interval by it (and by the pieces' spread), and the estimate is determined only while the
widened interval stays narrow. It is the piece-wise counterpart of scaling a sandwich by the
misfit, and it needs no model of what was left out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from scipy.special import chdtrc

from calib.adequacy.changes import PieceFit
from calib.adequacy.intervals import Z95
from calib.results import Estimate, JsonRecord

__all__ = ["PieceStability", "piece_stability", "widen_unstable"]

P_UNSTABLE = 0.001
"""A parameter is unstable across pieces when its chi-square's p-value is below this."""


@dataclass(frozen=True)
class PieceStability(JsonRecord):
    """One parameter across pieces: ``chi2`` of the pieces about their weighted mean with
    ``dof`` degrees of freedom, its ``p_value``, the ``factor`` sqrt(chi2/dof) (>= 1) and the
    pieces' precision-weighted standard deviation ``spread``; ``unstable``: p below
    ``P_UNSTABLE``."""

    name: str
    pieces: int
    chi2: float
    dof: int
    p_value: float
    factor: float
    spread: float
    unstable: bool


def piece_stability(pieces: Sequence[PieceFit], names: Sequence[str]) -> dict[str, PieceStability]:
    """Per parameter in ``names``, how well its piece estimates agree (pieces without a finite
    value and positive standard error for it are left out; fewer than two: not judged)."""
    out: dict[str, PieceStability] = {}
    for n in names:
        vals = [
            (p.values[n], p.std[n])
            for p in pieces
            if n in p.values
            and math.isfinite(p.values[n])
            and math.isfinite(p.std.get(n, math.nan))
            and p.std.get(n, 0.0) > 0
        ]
        if len(vals) < 2:
            continue
        w = [1.0 / s**2 for _, s in vals]
        mean = sum(wi * v for wi, (v, _) in zip(w, vals, strict=True)) / sum(w)
        chi2 = sum(((v - mean) / s) ** 2 for v, s in vals)
        dof = len(vals) - 1
        p = float(chdtrc(dof, chi2))
        # precision-weighted spread: a piece that barely determines the parameter (a piece
        # that hardly turns) does not dominate it
        spread = math.sqrt(
            sum(wi * (v - mean) ** 2 for wi, (v, _) in zip(w, vals, strict=True))
            / sum(w)
            * len(vals)
            / dof
        )
        out[n] = PieceStability(
            n, len(vals), chi2, dof, p, max(1.0, math.sqrt(chi2 / dof)), spread, p < P_UNSTABLE
        )
    return out


def widen_unstable(
    estimates: Mapping[str, Estimate],
    stability: Mapping[str, PieceStability],
    *,
    rel_tol: float,
    scale: Mapping[str, float] | None = None,
) -> dict[str, Estimate]:
    """Each estimate whose parameter is unstable across pieces, with its standard error scaled
    by the overdispersion factor and combined with the pieces' spread; determined only while
    the widened 95 % half-width is within ``rel_tol`` of max(|value|, ``scale[name]``). Stable
    parameters are returned unchanged."""
    out = dict(estimates)
    for name, st in stability.items():
        e = estimates.get(name)
        if e is None or not st.unstable or not math.isfinite(e.std):
            continue
        std = math.hypot(e.std * st.factor, st.spread)
        half = Z95 * std
        size = max(abs(e.value), (scale or {}).get(name, 0.0))
        ok = e.identifiable and half <= rel_tol * size
        why = (
            f"{name} differs between pieces of the log beyond its errors (chi2 "
            f"{st.chi2:.3g} on {st.dof} dof): physics the model leaves out moves it; "
            f"interval widened x{std / e.std:.2g}"
        )
        out[name] = Estimate(
            e.name,
            e.value,
            std,
            (e.value - half, e.value + half),
            ok,
            e.unit,
            (e.note + "; " if e.note else "") + why,
        )
    return out
