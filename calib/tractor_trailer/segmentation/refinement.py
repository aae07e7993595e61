"""Boundary refinement: short segments handed to their neighbours, soft boundaries moved."""

from __future__ import annotations

import numpy as np

from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.segmentation.scoring import Piece, Scorer, score
from calib.tractor_trailer.segmentation.templates import TemplateFit, fit_all

__all__ = ["dissolve_short", "refine", "refine_pair"]


def dissolve_short(segs: list[Piece], sc: Scorer, max_len: int, win: int) -> list[Piece]:
    """Hand short segments to their neighbours where that lowers the BIC.

    A short segment between two templates usually straddles a smooth join of the two. It goes
    to the neighbours it is not separated from by a jump (split at its middle, then the new
    boundary refined, when both qualify); the change is kept only if the total BIC drops.
    """
    i = 0
    while i < len(segs):
        mid_seg = segs[i]
        left = segs[i - 1] if i > 0 and not mid_seg.jump_left else None
        right = segs[i + 1] if i + 1 < len(segs) and not segs[i + 1].jump_left else None
        if mid_seg.b - mid_seg.a > max_len or (left is None and right is None):
            i += 1
            continue
        old = mid_seg.bic + (left.bic if left else 0.0) + (right.bic if right else 0.0)
        kinds = {x.template.kind for x in (left, mid_seg, right) if x is not None}
        other = kinds == {CommandType.OTHER}  # never turn a template into "other"
        if left is not None and right is not None:
            half = (mid_seg.a + mid_seg.b) // 2
            new_l = score(Piece(left.a, half, left.jump_left), sc, other)
            new_r = Piece(half, right.b, False, hint=mid_seg.b - mid_seg.a)
            score(new_r, sc, other)
            refine_pair(new_l, new_r, sc, win, allow_other=other)
            new = [new_l, new_r]
        elif left is not None:
            new = [score(Piece(left.a, mid_seg.b, left.jump_left), sc, other)]
        else:
            assert right is not None  # one neighbour at least (checked above)
            new = [score(Piece(mid_seg.a, right.b, mid_seg.jump_left), sc, other)]
        if sum(s.bic for s in new) < old:
            lo = i - 1 if left is not None else i
            hi = i + 2 if right is not None else i + 1
            segs[lo:hi] = new
            i = max(lo, 0)
        else:
            i += 1
    return segs


def refine_pair(
    left: Piece, right: Piece, sc: Scorer, win: int, passes: int = 4, allow_other: bool = True
) -> None:
    """Move the soft boundary between two segments to where their templates split best.

    Each side's template is fitted away from the boundary (a margin of a quarter of the
    window, or half the ``hint``) and extrapolated over the window; the boundary moves to the
    least summed squared residuals if that lowers the BIC. Both sides are relabelled (best
    template other than "other") before each pass, so a boundary that was off at first gets
    the right templates on both sides as it converges.
    """
    t, y = sc.t, sc.y
    for _ in range(passes):
        score(left, sc, allow_other=False)
        score(right, sc, allow_other=False)
        b = right.a
        w = min(max(win, right.hint), (b - left.a) // 3, (right.b - b) // 3)
        if w < 2:
            break
        m = min(max(w // 4, right.hint // 2), w)  # margin kept out of the fits
        fl = fit_kind(left.template.kind, t[left.a : b - m] - t[left.a], y[left.a : b - m])
        fr = fit_kind(right.template.kind, t[b + m : right.b] - t[b + m], y[b + m : right.b])
        if fl is None or fr is None:
            break
        tw, yw = t[b - w : b + w], y[b - w : b + w]
        rl = (yw - fl(tw - t[left.a])) ** 2
        rr = (yw - fr(tw - t[b + m])) ** 2
        cost = np.concatenate([[0.0], np.cumsum(rl)]) + np.concatenate(
            [np.cumsum(rr[::-1])[::-1], [0.0]]
        )
        nb = int(np.clip(b - w + int(np.argmin(cost)), left.a + 2, right.b - 2))
        if nb == b:
            break
        before = left.bic + right.bic
        left.b = right.a = nb
        after = score(left, sc, False).bic + score(right, sc, False).bic
        if after > before:  # keep only improvements
            left.b = right.a = b
            break
    score(left, sc, allow_other)
    score(right, sc, allow_other)


def refine(segs: list[Piece], sc: Scorer, win: int) -> None:
    """Refine every boundary that is not a jump (see ``refine_pair``)."""
    for i in range(1, len(segs)):
        if not segs[i].jump_left:
            refine_pair(segs[i - 1], segs[i], sc, win)


def fit_kind(kind: CommandType, t: np.ndarray, y: np.ndarray) -> TemplateFit | None:
    if t.size < 8:
        return None
    fits = fit_all(t, y, (kind,))
    return fits[0] if fits else None
