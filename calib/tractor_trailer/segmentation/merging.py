"""Merging neighbouring pieces while the BIC improves, and absorbing too-short segments."""

from __future__ import annotations

import numpy as np

from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.segmentation.scoring import Piece, Scorer, score
from calib.tractor_trailer.segmentation.templates import TemplateFit

__all__ = ["absorb_short", "merge"]


def merge(segs: list[Piece], sc: Scorer) -> list[Piece]:
    """Greedy bottom-up merging of neighbours across soft boundaries while BIC improves."""
    for s in segs:
        score(s, sc)

    def union(i: int) -> tuple[float, TemplateFit | None, float]:
        left, right = segs[i], segs[i + 1]
        if right.jump_left:
            return -np.inf, None, np.inf
        both_other = (
            left.template.kind is CommandType.OTHER and right.template.kind is CommandType.OTHER
        )
        fit, bic = sc.best(left.a, right.b, allow_other=both_other)
        return left.bic + right.bic - bic, fit, bic

    gains = [union(i) for i in range(len(segs) - 1)]
    while gains:
        i = int(np.argmax([g[0] for g in gains]))
        gain, fit, bic = gains[i]
        if not gain >= 0:
            break
        left, right = segs[i], segs[i + 1]
        segs[i] = Piece(left.a, right.b, left.jump_left, fit, bic)
        del segs[i + 1]
        del gains[i]
        if i < len(gains):
            gains[i] = union(i)
        if i > 0:
            gains[i - 1] = union(i - 1)
    return segs


def absorb_short(segs: list[Piece], sc: Scorer, min_len: int) -> list[Piece]:
    """Merge segments shorter than ``min_len`` samples into the better-fitting neighbour."""
    while len(segs) > 1:
        lengths = [s.b - s.a for s in segs]
        i = int(np.argmin(lengths))
        if lengths[i] >= min_len:
            break
        options = []
        for j in (i - 1, i):
            if j >= 0 and j + 1 < len(segs):
                pair = (segs[j].template.kind, segs[j + 1].template.kind)
                fit, bic = sc.best(segs[j].a, segs[j + 1].b, CommandType.OTHER in pair)
                extra = bic - segs[j].bic - segs[j + 1].bic
                options.append((extra, j, fit, bic))
        _, j, fit, bic = min(options, key=lambda o: o[0])
        segs[j] = Piece(segs[j].a, segs[j + 1].b, segs[j].jump_left, fit, bic)
        del segs[j + 1]
    return segs
