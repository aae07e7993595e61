"""Pieces of the decimated command and their BIC scores (best template per piece).

BIC = RSS / sigma^2 + (k + 1) ln N on the merge grid (k template parameters, + 1 for the
boundary); templates are tried simplest first (``calib.tractor_trailer.segmentation.templates``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.segmentation.templates import (
    N_PARAMS_MIN,
    TEMPLATE_ORDER,
    TemplateFit,
    fit_template,
)

__all__ = ["Piece", "Scorer", "score"]


@dataclass
class Piece:
    """Decimated samples [a, b) of the command, with their best template once scored."""

    a: int  # decimated index, inclusive
    b: int  # decimated index, exclusive
    jump_left: bool  # the boundary at a is a jump
    fit: TemplateFit | None = None
    bic: float = np.inf
    hint: int = 0  # refinement half-window (samples) the boundary at a needs at least

    @property
    def template(self) -> TemplateFit:
        """The fitted template (set by ``score``)."""
        if self.fit is None:
            raise AssertionError("piece not scored yet")
        return self.fit


class Scorer:
    """Fits templates on the merge grid and scores them by BIC."""

    def __init__(self, t: np.ndarray, y: np.ndarray, step: int, sigma: float) -> None:
        self.t, self.y, self.step, self.sigma = t, y, step, sigma
        self.log_n = float(np.log(max(t.size / step, 2)))
        # merging and refining ask for the same stretches again (a boundary that does not
        # move is rescored on both sides); a fit depends on (a, b, allow_other) alone
        self._best: dict[tuple[int, int, bool], tuple[TemplateFit, float]] = {}

    def best_xy(
        self, tt: np.ndarray, yy: np.ndarray, weight: float, allow_other: bool = True
    ) -> tuple[TemplateFit, float]:
        """Lowest-BIC template on (tt local s, yy); ``weight`` merge-grid samples per point.

        Templates are tried simplest first; once the best so far fits to within the noise,
        templates with at least as many parameters are skipped (they cannot win by more
        than the noise).
        """
        best: tuple[TemplateFit, float] | None = None
        noise_rss = self.sigma**2 * tt.size * (1.0 + 4.0 * np.sqrt(2.0 / tt.size))
        for kind in TEMPLATE_ORDER:
            if kind is CommandType.OTHER and not allow_other:
                continue
            if (
                best is not None
                and best[0].rss <= noise_rss
                and best[0].n_params <= N_PARAMS_MIN[kind]
            ):
                continue
            f = fit_template(kind, tt, yy)
            if f is None:
                continue
            score = f.rss * weight / (self.sigma**2) + (f.n_params + 1) * self.log_n
            if best is None or score < best[1]:
                best = (f, score)
        if best is None:  # cannot happen: the constant template always fits
            raise AssertionError("no template fitted")
        return best

    def thin(self, a: int, b: int) -> int:
        """Stride of the merge grid on decimated samples [a, b)."""
        return self.step if (b - a) // self.step >= 8 else 1

    def weight(self, a: int, b: int) -> float:
        """Merge-grid samples each thinned sample of [a, b) stands for."""
        return self.thin(a, b) / self.step

    def best(self, a: int, b: int, allow_other: bool = True) -> tuple[TemplateFit, float]:
        """Lowest-BIC template on decimated samples [a, b), thinned to the merge grid."""
        key = (a, b, allow_other)
        if key not in self._best:
            sl = slice(a, b, self.thin(a, b))
            tt, yy = self.t[sl] - self.t[a], self.y[sl]
            self._best[key] = self.best_xy(tt, yy, self.weight(a, b), allow_other)
        return self._best[key]


def score(seg: Piece, sc: Scorer, allow_other: bool = True) -> Piece:
    seg.fit, seg.bic = sc.best(seg.a, seg.b, allow_other)
    return seg
