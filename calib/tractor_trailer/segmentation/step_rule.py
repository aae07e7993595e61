"""The step rule: constant levels joined by jumps grouped into ``step`` segments."""

from __future__ import annotations

from calib.tractor_trailer.results import CommandType
from calib.tractor_trailer.segmentation.scoring import Piece, Scorer, score

__all__ = ["pair_levels", "step_rule"]


def pair_levels(lengths: list[int]) -> list[int]:
    """Group consecutive constant levels into steps (2 levels) and constants (1 level).

    As many steps as possible; among those groupings, the one whose jumps sit nearest the
    middle of their step segments. Returns the group sizes in order.
    """
    n = len(lengths)
    # best[i]: (-steps, off-centre penalty, groups) for the first i levels
    best: list[tuple[int, float, list[int]]] = [(0, 0.0, [])]
    for i in range(1, n + 1):
        prev = best[i - 1]
        cand = [(prev[0], prev[1], [*prev[2], 1])]
        if i >= 2:
            p2 = best[i - 2]
            off = abs(lengths[i - 2] / (lengths[i - 2] + lengths[i - 1]) - 0.5)
            cand.append((p2[0] - 1, p2[1] + off, [*p2[2], 2]))
        best.append(min(cand, key=lambda c: (c[0], c[1])))
    return best[n][2]


def step_rule(segs: list[Piece], sc: Scorer) -> list[Piece]:
    """Turn constant levels joined by jumps into step segments (see module doc)."""
    out: list[Piece] = []
    i = 0
    while i < len(segs):
        j = i
        while (
            j + 1 < len(segs)
            and segs[j + 1].jump_left
            and segs[j].template.kind is CommandType.CONSTANT
            and segs[j + 1].template.kind is CommandType.CONSTANT
        ):
            j += 1
        run = segs[i : j + 1]
        k = 0
        for size in pair_levels([s.b - s.a for s in run]):
            if size == 1:
                out.append(run[k])
            else:
                out.append(score(Piece(run[k].a, run[k + 1].b, run[k].jump_left), sc))
            k += size
        i = j + 1
    return out
